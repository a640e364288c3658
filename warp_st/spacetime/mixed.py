"""Deforming bodies beside rigid ones on the two-level path: their tetrahedra as a second leaf kind.

A scene with a deforming body (docs/spec.md §2.2) keeps its rigid bodies as instances
(``spacetime.rigid``); only the deforming bodies are extruded into tetrahedra
(``spacetime.deform``, ``extrude.extrude_scene`` over their windows alone). The top level
gets one more leaf, a segment of body -1 whose box holds every tetrahedron
(``with_tet_segment``): the leaf traces the tetrahedra's own 4D BVH with the tet path's
traversal and test (``kernels/trace_rigid.py``). docs/design/mixed-leaves.md says why.

Numbering (``mixed_shapes``): the shading tables are the rigid shapes' followed by the
extrusion's, so a rigid hit's triangle is unchanged and a tetrahedron's triangle is the
extrusion's plus the rigid triangle count; the vertex tables put the extrusion's vertices
first (its per-slice normals and point velocities, ``kernels/shade.py``), the rigid
bodies' after them (their first global vertex moves by the extrusion's vertex count).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.core.deform import deforming
from warp_st.spacetime.extrude import SpacetimeMesh
from warp_st.spacetime.rigid import MotionSegments, RigidShapes

__all__ = ["TET_SEGMENT", "has_deforming", "rigid_part", "deforming_windows", "mixed_shapes", "with_tet_segment"]

#: seg_body of the top-level leaf that holds the deforming bodies' tetrahedra.
TET_SEGMENT = -1


def has_deforming(scene) -> bool:
    """True when a body of ``scene`` deforms (its tetrahedra join the rigid path)."""
    return any(deforming(b) for b in scene.bodies)


def rigid_part(scene):
    """``scene`` with its deforming bodies' surfaces left out (the rigid shapes' input:
    every body keeps its index, a deforming one has no shape and no segment)."""
    bodies = tuple(dataclasses.replace(b, surfaces=()) if deforming(b) else b for b in scene.bodies)
    return dataclasses.replace(scene, bodies=bodies)


def deforming_windows(scene, windows: list) -> list:
    """``windows`` of the deforming bodies, None for every other one (the extrusion's input)."""
    return [w if deforming(b) else None for b, w in zip(scene.bodies, windows)]


def mixed_shapes(shapes: RigidShapes, mesh: SpacetimeMesh) -> RigidShapes:
    """The rigid ``shapes`` (of ``rigid_part``) with the extrusion ``mesh``'s shading tables
    (see the module docstring for the numbering), in the shapes' float type."""
    dtype = shapes.tri_normal.dtype
    n_tri = len(shapes.tri_body)
    textured = len(shapes.tri_st) or any(t is not None for m in mesh.materials for t in m.textures)
    st = (np.concatenate([shapes.tri_st if len(shapes.tri_st) else np.zeros((n_tri, 3, 2), dtype),
                          mesh.tri_st.astype(dtype)]) if textured else shapes.tri_st)
    return dataclasses.replace(
        shapes,
        vertex_normals=np.concatenate([mesh.vertex_normals.astype(dtype), shapes.vertex_normals]),
        body_vert_base=shapes.body_vert_base + len(mesh.vertices),
        tri_normal=np.concatenate([shapes.tri_normal, mesh.tri_normal.astype(dtype)]),
        tri_smooth=np.concatenate([shapes.tri_smooth, mesh.tri_smooth.astype(np.int32)]),
        tri_size=np.concatenate([shapes.tri_size, mesh.tri_size.astype(dtype)]),
        tri_body=np.concatenate([shapes.tri_body, mesh.tri_body.astype(np.int32)]),
        tri_material=np.concatenate([shapes.tri_material,
                                     mesh.tri_material.astype(np.int32) + len(shapes.materials)]),
        materials=tuple(shapes.materials) + tuple(mesh.materials),
        tri_st=st,
    )


def with_tet_segment(segments: MotionSegments, mesh: SpacetimeMesh) -> MotionSegments:
    """``segments`` and one more, body TET_SEGMENT, whose 4D box and span hold every
    tetrahedron of ``mesh`` (none when it has none)."""
    if not mesh.tet_count:
        return segments
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    return MotionSegments(body=np.append(segments.body, np.int32(TET_SEGMENT)).astype(np.int32),
                          span=np.vstack([segments.span, [[lo[0], hi[0]]]]),
                          lo=np.vstack([segments.lo, lo]), hi=np.vstack([segments.hi, hi]))
