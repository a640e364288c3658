"""The rigid database's deforming part: the deforming bodies' tetrahedra beside the rigid instances.

``spacetime.mixed`` says what goes where; this builds it for the renderer's rigid database:
the extrusion of the deforming bodies alone over their windows (``build_database``, the tet
path's own, so its tetrahedra and BVH are the ones the all-tet path builds for those bodies),
the shading tables joined, and the top-level leaf that holds them.
"""
from __future__ import annotations

from warp_st.rendering.budget import BYTES_PER_PIXEL, check_resources
from warp_st.rendering.database_build import build_database
from warp_st.spacetime.mixed import deforming_windows, mixed_shapes, with_tet_segment

__all__ = ["shapes_key", "tet_leaves"]


def shapes_key(tessellation: tuple) -> tuple:
    """The rigid shapes' cache key: ``tessellation`` without its deforming slices' view
    (the rigid shapes leave deforming bodies out, so other cameras reuse them)."""
    return tuple(e for e in tessellation if not (isinstance(e, tuple) and e and e[0] == "deform"))


def tet_leaves(scene, windows: list, shapes, segments, *, view, rigid_bytes: int = 0, **limits):
    """(tets, shapes, segments, bytes) of the deforming bodies of ``scene``: ``tets`` =
    (extrusion, its BVH, the rigid triangle count), the rigid ``shapes`` joined with its
    tables and ``segments`` with its leaf; ``bytes``: its memory estimate
    (``budget.check_resources`` refuses before the build what would not fit ``limits``'
    ``max_memory`` beside the rigid part's ``rigid_bytes``)."""
    windows = deforming_windows(scene, windows)
    if limits.get("max_memory") is not None:
        limits = dict(limits, max_memory=limits["max_memory"] - rigid_bytes)
    nbytes = check_resources(scene, windows, view=view, **limits)
    nbytes -= limits["width"] * limits["height"] * BYTES_PER_PIXEL
    mesh, bvh = build_database(scene, windows, "tet", view=view)
    return (mesh, bvh, len(shapes.tri_body)), mixed_shapes(shapes, mesh), with_tet_segment(segments, mesh), nbytes
