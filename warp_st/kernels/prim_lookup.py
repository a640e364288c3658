"""A primitive's triangle and vertex slots, as each Geometry stores them (pure Warp device code).

The extrusion's Geometry (``trace.py``) holds both per primitive: its triangle
(``prim_tri``) and four vertex slots (``prim_vidx``) that the hit's barycentrics weigh.
The rigid one (``trace_rigid.py``) returns global triangles as its primitives, so its
primitive is its triangle, and holds vertex indices per shape, not per body
(``spacetime.rigid.RigidShapes.shape_vidx``): triangle k of a body is its shape's
triangle k, its vertices that triangle's plus the body's first global vertex. The
fourth slot is the first vertex again, weighed 0 (a mesh hit's barycentrics are
(u, v, 1 - u - v, 0)), as the prism's is. So the shading reads one rule either way and
the rigid database keeps no identity table, no fourth index and no vertex indices per
body (issue 17). A rigid Geometry with deforming bodies' tetrahedra (``tets``) numbers
them from ``tet_first`` on and reads their triangle and slots from the tet tables, as the
tet path does (docs/design/mixed-leaves.md).
"""
import warp as wp

__all__ = ["make_prim_lookup"]

_MADE: dict = {}


def make_prim_lookup(Geometry):
    """(prim_triangle(g, prim) -> int, prim_vertices(g, prim) -> vec4i) for ``Geometry``."""
    if Geometry in _MADE:
        return _MADE[Geometry]
    if "prim_tri" in Geometry.vars:

        @wp.func
        def prim_triangle(g: Geometry, prim: int) -> int:
            return g.prim_tri[prim]

        @wp.func
        def prim_vertices(g: Geometry, prim: int) -> wp.vec4i:
            return g.prim_vidx[prim]

    elif "tets" in Geometry.vars:

        @wp.func
        def prim_triangle(g: Geometry, prim: int) -> int:
            if prim >= g.tet_first:
                return g.tets.prim_tri[prim - g.tet_first]
            return prim

        @wp.func
        def prim_vertices(g: Geometry, prim: int) -> wp.vec4i:
            if prim >= g.tet_first:
                return g.tets.prim_vidx[prim - g.tet_first]
            b = g.tri_body[prim]
            v = g.shape_vidx[g.body_shape_tri[b] + prim - g.body_tri_base[b]]
            base = g.body_vert_base[b]
            return wp.vec4i(v[0] + base, v[1] + base, v[2] + base, v[0] + base)

    else:

        @wp.func
        def prim_triangle(g: Geometry, prim: int) -> int:
            return prim

        @wp.func
        def prim_vertices(g: Geometry, prim: int) -> wp.vec4i:
            b = g.tri_body[prim]
            v = g.shape_vidx[g.body_shape_tri[b] + prim - g.body_tri_base[b]]
            base = g.body_vert_base[b]
            return wp.vec4i(v[0] + base, v[1] + base, v[2] + base, v[0] + base)

    _MADE[Geometry] = (prim_triangle, prim_vertices)
    return _MADE[Geometry]
