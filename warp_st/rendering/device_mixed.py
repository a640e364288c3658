"""NumPy -> Warp for the rigid path with deforming bodies' tetrahedra (``spacetime.mixed``).

``MixedArrays`` is ``RigidArrays`` over the mixed shapes (rigid tables, then the
extrusion's) plus what the tet path's shading reads for a tetrahedron hit: the deforming
bodies' points per slice and point velocities, and the tetrahedra's texture corners. Per
frame the nested tet Geometry (``kernels/trace.py``'s) is recentred as the tet path's
is (``device.make_geometry``): O(tetrahedra), the deforming bodies only.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.accel.bvh_wide import collapse
from warp_st.kernels import Kernels
from warp_st.kernels.texture import CORNERS_DEFAULT
from warp_st.rendering.device import make_geometry
from warp_st.rendering.device_rigid import RigidArrays
from warp_st.rendering.device_textures import tet_corners

__all__ = ["MixedArrays", "rigid_arrays"]

_DEVICE = "cpu"


class _TetArrays:
    """The frame-independent part of the nested tet Geometry (``device.make_geometry``'s
    ``static``): slots, triangles in the mixed numbering, the shared body tables, links."""

    def __init__(self, k: Kernels, rigid: RigidArrays, mesh, bvh, tri_offset: int):
        self.np_scalar = rigid.np_scalar
        self.prim_vidx = wp.array(mesh.tets.astype(np.int32), dtype=wp.vec4i, device=_DEVICE)
        self.prim_tri = wp.array((mesh.tet_tri + tri_offset).astype(np.int32), dtype=wp.int32, device=_DEVICE)
        self.tri_body = rigid.tri_body
        self.body_object = rigid.body_object
        self.wide = collapse(bvh)
        self.node_link = wp.array(self.wide.link, dtype=wp.vec4i, device=_DEVICE)


class MixedArrays(RigidArrays):
    """``RigidArrays`` of a database with deforming bodies (``db.tets``: the extrusion and
    its BVH, ``renderer``), float32 only (the rigid path's meshes are)."""

    def __init__(self, k: Kernels, db):
        if k.scalar != wp.float32:
            raise ValueError("deforming bodies join the rigid path in float32 only (float64: primitive='tet')")
        super().__init__(k, db.shapes, db.bottom, db.segments, db.bvh)
        mesh, bvh, tri_offset = db.tets
        self.tet_mesh, self.tet_bvh = mesh, bvh
        self.tet_first = len(db.shapes.tri_body)
        self.tet_static = _TetArrays(k, self, mesh, bvh, tri_offset)
        if len(mesh.vertex_velocity):  # the deforming points' own velocities (kernels/shade.py)
            self.body_points = wp.array(mesh.body_points, dtype=wp.int32, device=_DEVICE)
            self.vert_velocity = wp.array(mesh.vertex_velocity.astype(self.np_scalar), dtype=k.vec3, device=_DEVICE)
        if len(mesh.vertex_clock):  # a turning coupled body's pivot clock (spacetime/turning.py)
            self.vert_clock = wp.array(mesh.vertex_clock.astype(self.np_scalar), dtype=k.scalar, device=_DEVICE)
        if self.textures.info.shape[0]:  # rigid triangles' corners in order, then the tetrahedra's
            corners = np.concatenate([np.full(self.tet_first, CORNERS_DEFAULT, np.int32), tet_corners(mesh.tets)])
            self.textures.prim_corner = wp.array(corners, dtype=wp.int32, device=_DEVICE)

    def add_leaves(self, k: Kernels, g, origin: np.ndarray) -> None:
        """The tetrahedra's Geometry on the rigid Geometry ``g``, recentred on ``origin``."""
        g.tets = make_geometry(k, self.tet_static, self.tet_mesh, self.tet_bvh, origin,
                               geometry=k.Geometry.tet_geometry)
        g.tet_first = self.tet_first


def rigid_arrays(k: Kernels, db) -> RigidArrays:
    """The frame-independent arrays of the rigid database ``db`` (with tetrahedra or not)."""
    if db.tets is not None:
        return MixedArrays(k, db)
    return RigidArrays(k, db.shapes, db.bottom, db.segments, db.bvh)
