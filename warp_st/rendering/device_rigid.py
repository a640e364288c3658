"""NumPy -> Warp for the two-level rigid database (``kernels/trace_rigid.py``).

Frame-independent (``RigidArrays``): the shading tables, the bottom levels (accel/blas.py) and
each body's root in them, each body's first triangle, velocity and rest_from_lab map, the segments' bodies
in top-level leaf order and the top level's links. Per frame (``make_rigid_geometry``):
the bodies' frame events, the segments' spans and boxes and the top level's boxes, recentred on
the camera event in float64 and only then rounded (boxes outward): O(segments), so a
frame costs no per-triangle work on the host.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.accel.bvh import FlatBVH
from warp_st.accel.bvh_wide import collapse
from warp_st.accel.instances import BottomLevels
from warp_st.kernels import Kernels
from warp_st.kernels.struct_ref import seal
from warp_st.rendering.device import ShadingTables, outward, set_nodes, shared
from warp_st.spacetime.rigid import MotionSegments, RigidShapes
from warp_st.spacetime.shape_tables import shading_tables

__all__ = ["RigidArrays", "make_rigid_geometry"]

_DEVICE = "cpu"


class RigidArrays(ShadingTables):
    """Frame-independent device arrays of a rigid database: ``shapes`` with their
    ``bottom`` levels, ``segments`` under the ``top`` level (segments in input order;
    ``top.order`` puts them in leaf order). The shading tables share the memory of
    ``shapes``' when their floats are the kernels' (``spacetime.shape_tables.shading_tables``)."""

    def __init__(self, k: Kernels, shapes: RigidShapes, bottom: BottomLevels, segments: MotionSegments,
                 top: FlatBVH):
        np_scalar = np.float32 if k.scalar == wp.float32 else np.float64
        tables = shading_tables(shapes, np_scalar)
        super().__init__(k, tables)
        self.bottom = bottom  # its tables back the blas_* arrays
        self.shape_vidx = shared(shapes.shape_vidx, np.int32, wp.vec3i)
        self.body_shape_tri = wp.array(shapes.body_shape_tri, dtype=wp.int32, device=_DEVICE)
        self.body_vert_base = wp.array(shapes.body_vert_base.astype(np.int32), dtype=wp.int32, device=_DEVICE)
        self.body_blas = wp.array(bottom.body_root, dtype=wp.int32, device=_DEVICE)
        self.body_holder = wp.array(shapes.body_holder, dtype=wp.int32, device=_DEVICE)
        self.body_merged = wp.array(shapes.body_merged, dtype=wp.int32, device=_DEVICE)
        # The bottom levels' own tables, over their memory.
        self.blas_q = shared(bottom.node_q, np.uint8, wp.types.vector(24, wp.uint8))
        self.blas_frame = shared(bottom.node_frame, np.float32, wp.types.vector(6, wp.float32))
        self.blas_link = shared(bottom.node_link, np.int32, wp.vec4i)
        self.blas_points = shared(bottom.points, np.float32, wp.vec3)
        self.body_blas_vert = wp.array(bottom.body_vert, dtype=wp.int32, device=_DEVICE)
        self.body_tri_base = wp.array(shapes.body_tri_base.astype(np.int32), dtype=wp.int32, device=_DEVICE)
        self.body_rest = wp.array(shapes.rest_from_lab, dtype=wp.mat33d, device=_DEVICE)
        self.body_end = np.array([b.lifetime[1] for b in shapes.bodies], dtype=np.float64)
        self.body_frame = shapes.body_frame
        self.body_rest_lo = wp.array(shapes.body_rest_lo, dtype=wp.vec3d, device=_DEVICE)
        self.body_rest_hi = wp.array(shapes.body_rest_hi, dtype=wp.vec3d, device=_DEVICE)
        self.body_start_lo = wp.array(shapes.body_start_lo, dtype=wp.vec3d, device=_DEVICE)
        self.body_start_hi = wp.array(shapes.body_start_hi, dtype=wp.vec3d, device=_DEVICE)
        velocity = np.array([b.velocity for b in shapes.bodies], dtype=np.float64).reshape(-1, 3)
        self.body_velocity64 = wp.array(velocity, dtype=wp.vec3d, device=_DEVICE)
        # kernels/trace_rigid's bits: START_OWN (1) where the body's start box is its own
        # (it touches no other body of its frame: spacetime/start_boxes.py); AT_REST (2) where v = 0, A^-1 = I
        # and the bottom level is in the body's coordinates (not body_mapped).
        start_own = np.all((shapes.body_start_lo == shapes.body_rest_lo) & (shapes.body_start_hi == shapes.body_rest_hi),
                           axis=1)
        identity = np.all(shapes.rest_from_lab.reshape(-1, 9) == np.eye(3).reshape(9), axis=1)
        at_rest = (shapes.body_mapped == 0) & np.all(velocity == 0.0, axis=1) & identity
        self.body_flags = wp.array(start_own.astype(np.int32) | (at_rest.astype(np.int32) << 1), dtype=wp.int32,
                                   device=_DEVICE)
        self.body_quadric = wp.array(shapes.body_quadric.astype(np.int32), dtype=wp.int32, device=_DEVICE)
        self.quadric_inv = wp.array(shapes.quadric_inv, dtype=wp.mat33d, device=_DEVICE)
        self.quadric_centre = wp.array(shapes.quadric_centre, dtype=wp.vec3d, device=_DEVICE)
        self.quadric_param = wp.array(shapes.quadric_param, dtype=wp.vec3d, device=_DEVICE)
        self.body_mapped = wp.array(shapes.body_mapped, dtype=wp.int32, device=_DEVICE)
        self.body_map = wp.array(shapes.body_map, dtype=wp.mat33d, device=_DEVICE)
        self.body_map_shift = wp.array(shapes.body_map_shift, dtype=wp.vec3d, device=_DEVICE)
        self.order = top.order
        self.seg_body = wp.array(segments.body[top.order].astype(np.int32), dtype=wp.int32, device=_DEVICE)
        self.wide = collapse(top)
        self.node_link = wp.array(self.wide.link, dtype=wp.vec4i, device=_DEVICE)

    def add_leaves(self, k: Kernels, g, origin: np.ndarray) -> None:
        """Other leaf kinds' geometry on ``g`` (``device_mixed.MixedArrays``: tetrahedra); none here."""


def make_rigid_geometry(k: Kernels, static: RigidArrays, segments: MotionSegments, top: FlatBVH, origin: np.ndarray):
    """Geometry struct of the rigid path, recentred on ``origin`` = (t_c, c)."""
    g = k.Geometry()
    ns = static.np_scalar
    order = static.order
    for name in ("shape_vidx", "body_shape_tri", "body_vert_base", "tri_body", "body_object", "body_blas",
                 "body_holder", "body_merged", "body_tri_base", "body_rest", "body_rest_lo", "body_rest_hi",
                 "body_start_lo", "body_start_hi", "body_flags", "seg_body", "body_quadric", "quadric_inv", "quadric_centre", "quadric_param", "body_mapped", "body_map",
                 "body_map_shift", "blas_q", "blas_frame", "blas_link", "blas_points", "body_blas_vert"):
        setattr(g, name, getattr(static, name))
    g.body_velocity = static.body_velocity64
    vec2 = wp.types.vector(2, k.scalar)
    g.seg_span = wp.array((segments.span[order] - origin[0]).astype(ns).reshape(-1, 2), dtype=vec2, device=_DEVICE)
    g.seg_lo = wp.array(outward(segments.lo[order] - origin, ns, -np.inf).reshape(-1, 4), dtype=k.vec4,
                        device=_DEVICE)
    g.seg_hi = wp.array(outward(segments.hi[order] - origin, ns, np.inf).reshape(-1, 4), dtype=k.vec4, device=_DEVICE)
    g.body_end = wp.array(static.body_end - origin[0], dtype=wp.float64, device=_DEVICE)
    g.body_anchor = wp.array((static.body_frame - origin).reshape(-1, 4), dtype=wp.vec4d, device=_DEVICE)
    set_nodes(k, g, static.wide, static.node_link, top, origin, ns)
    static.add_leaves(k, g, origin)
    seal(g)
    return g
