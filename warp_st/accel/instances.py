"""Two-level acceleration of rigid bodies: bottom levels per shape, a 4D top level over segments.

- Bottom level (``BottomLevels``, ``blas.py``): one 4-wide 3D BVH per distinct shape
  of ``spacetime.rigid.RigidShapes``, over its float32 triangles at rest in body
  coordinates, traced with a watertight triangle test (``kernels/blas.py``). It depends
  on nothing but the shape, so it is built once per scene and tessellation
  (``rendering.database_cache``) and serves every frame, speed and window.
- Top level (``build_top_level``): our 4D BVH (``bvh.py``, traced 4-wide) over the
  bodies' motion segments (``spacetime.rigid.motion_segments``). It depends on the
  frames' windows only through the segments' boxes and spans, and costs O(segments):
  rebuilt whenever the frames need other segments.

Until 0.6.0 the bottom level was ``wp.Mesh``; ours replaced it when it traced faster on
the benchmark scenes (docs/design/two-level.md). Moving bodies with piecewise motion or
deforming surfaces would add top-level segments with other maps into body coordinates;
the bottom level stays.
"""
from __future__ import annotations

import numpy as np

from warp_st.accel.blas import BottomLevels, bottom_levels, shapes_and_bottom_levels
from warp_st.accel.bvh import FlatBVH, build_bvh
from warp_st.spacetime.rigid import MotionSegments

__all__ = ["BottomLevels", "bottom_levels", "build_top_level", "shapes_and_bottom_levels"]


def build_top_level(segments: MotionSegments) -> FlatBVH:
    """The 4D BVH over the segments' boxes; leaves of single segments unless the SAH
    (with a bottom-level query as the intersection cost) prefers a few together."""
    if segments.count == 0:
        return build_bvh(np.zeros((0, 4)), np.zeros((0, 4)), "rigid", leaf_size=1)
    return build_bvh(segments.lo, segments.hi, "rigid", leaf_size=1)
