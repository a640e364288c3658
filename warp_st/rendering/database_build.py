"""The 4D database of the extrusion paths (prism, tet): extrude, then build the BVH over it."""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.accel.bvh import FlatBVH, build_bvh
from warp_st.core.scene import Scene
from warp_st.spacetime.extrude import SpacetimeMesh, extrude_scene

__all__ = ["build_database"]


def build_database(scene: Scene, windows: list, primitive: str = "prism", *, fine: bool = True,
                   fraction: float | None = None, view=None) -> tuple[SpacetimeMesh, FlatBVH]:
    """Extrude ``scene`` over per-body time ``windows`` and build the 4D BVH.

    ``primitive``: what the BVH's leaves hold and the kernels intersect: "prism" (one
    comoving triangle test per extruded triangle and segment; every body moves
    uniformly, so this is exact) or "tet" (three tetrahedra per prism, the general
    path). The returned mesh stores that primitive array in BVH leaf order (a leaf is
    a contiguous range), so primitive indices refer to that order. ``fine`` and
    ``fraction``: the time-segment rule (``extrude.body_slices``); ``view``: the cameras
    deforming bodies' slices follow within half a pixel (``deform.SliceView``).
    """
    if primitive not in ("prism", "tet"):
        raise ValueError(f"primitive must be prism or tet, got {primitive!r}")
    mesh = dataclasses.replace(extrude_scene(scene, windows, fine=fine, fraction=fraction, view=view),
                               primitive=primitive)
    lo, hi = mesh.prim_boxes() if mesh.prim_count else (np.zeros((0, 4)), np.zeros((0, 4)))
    bvh = build_bvh(lo, hi, primitive=primitive)
    if primitive == "prism":
        mesh = dataclasses.replace(mesh, prisms=mesh.prisms[bvh.order], prism_tri=mesh.prism_tri[bvh.order],
                                   prism_span=mesh.prism_span[bvh.order])
    else:
        mesh = dataclasses.replace(mesh, tets=mesh.tets[bvh.order], tet_tri=mesh.tet_tri[bvh.order])
    return mesh, bvh
