"""Two-level acceleration of rigid bodies: bottom levels per shape, a 4D top level over segments.

- Bottom level (``BottomLevels``): one ``wp.Mesh`` (Warp's SAH BVH) per distinct shape
  of ``spacetime.rigid.RigidShapes``, over its float32 triangles at rest in body
  coordinates. It depends on nothing but the shape, so it is built once per scene and
  tessellation (``rendering.database_cache``) and serves every frame, speed and window.
- Top level (``build_top_level``): our 4D BVH (``bvh.py``, traced 4-wide) over the
  bodies' motion segments (``spacetime.rigid.motion_segments``). It depends on the
  frames' windows only through the segments' boxes and spans, and costs O(segments):
  rebuilt whenever the frames need other segments.

Why ``wp.Mesh``: measured against our own BVH on the benchmark scenes
(examples/benchmarks/bench_two_level.py; docs/design/database-cache.md), it builds in
native code and its closest-hit query is exact for float32 rays (Woop's watertight
triangle test). Moving bodies with piecewise motion or deforming surfaces would add
top-level segments with other maps into body coordinates; the bottom level stays.
"""
from __future__ import annotations

import time

import numpy as np

from warp_st.accel.bvh import FlatBVH, build_bvh
from warp_st.spacetime.rigid import MotionSegments, RigidShapes

__all__ = ["BottomLevels", "build_top_level"]


class BottomLevels:
    """One ``wp.Mesh`` per shape of ``shapes`` (float32 rest points), on the CPU.

    ``body_mesh``: the mesh id of each body's shape, (B,) uint64 (0 for a body without
    triangles); ``nbytes``: what the meshes hold (points, indices, BVH nodes), bytes.
    """

    def __init__(self, shapes: RigidShapes):
        import warp as wp

        t0 = time.perf_counter()
        self.meshes = []
        for rest, tris in zip(shapes.shape_rest, shapes.shape_triangles):
            self.meshes.append(wp.Mesh(points=wp.array(np.asarray(rest, np.float32), dtype=wp.vec3, device="cpu",
                                                       copy=False),  # the shape's own float32 points
                                       indices=wp.array(tris.reshape(-1), dtype=wp.int32, device="cpu", copy=False)))
        ids = np.array([m.id for m in self.meshes] + [0], dtype=np.uint64)
        self.body_mesh = ids[shapes.body_shape]  # -1 (no shape) picks the trailing 0
        self.build_seconds = time.perf_counter() - t0
        # Points and indices as uploaded, and Warp's BVH: 2 nodes per leaf triangle at
        # most, each two 16-byte halves, plus the primitive permutation.
        tris = sum(len(t) for t in shapes.shape_triangles)
        points = sum(len(r) for r in shapes.shape_rest)
        self.nbytes = int(12 * points + 12 * tris + 2 * tris * 32 + 4 * tris)


def build_top_level(segments: MotionSegments) -> FlatBVH:
    """The 4D BVH over the segments' boxes; leaves of single segments unless the SAH
    (with a bottom-level query as the intersection cost) prefers a few together."""
    if segments.count == 0:
        return build_bvh(np.zeros((0, 4)), np.zeros((0, 4)), "rigid", leaf_size=1)
    return build_bvh(segments.lo, segments.hi, "rigid", leaf_size=1)
