"""A bottom level's ray query: our 4-wide 3D BVH and a watertight triangle test (device code).

The tree is ``accel/blas.py``'s (every shape's nodes and triangles in shared arrays,
``Geometry.blas_*``). ``make_blas_query(Geometry)`` gives

    blas_query(g, root, vert, tri0, p, shear, inv, t_max, any_hit, tri_base, skip_body, skip_t,
               skip_tri) -> (hit, t, u, v, face)

the closest (with ``any_hit``, any) crossing of the float32 ray p + t d, given by its
direction's ``ray_shear(d)`` and ``ray_inv(d)`` (a caller tracing one direction into
several bottom levels computes them once), t in
[0, t_max], with the triangles under wide node ``root``; with ``skip_body`` >= 0 (a
merged shape holds several bodies) leaving out the global triangle ``skip_tri`` and
those of that body (``g.tri_body`` of the global triangle ``tri_base`` + face) nearer
than ``skip_t``: t in units of d, (u, v) the
barycentric weights of the triangle's first and second vertices, ``face`` its index in
its shape — what ``wp.mesh_query_ray`` returns for the same ray and triangles. A leaf's
triangle slot i is row i of the shapes' own vertex indices (``g.shape_vidx``, in leaf
order: accel/blas.py), its points ``g.blas_points[vert + index]`` (``vert``: where the
shape's points start), and its face i - ``tri0`` (``tri0``: the shape's first row).

The triangle test is Woop, Benthin and Wald's watertight one (JCGT 2(1), 2013): the
ray's largest axis becomes z, the vertices are sheared so that the ray is the z axis,
and the 2D edge functions U, V, W decide. Each is a difference of two products of
float32 numbers, computed in float64 (where the products are exact) and rounded once:
as accurate as ``wp.Mesh``'s fused products, and two triangles sharing an edge get it
with opposite signs bit for bit, so a ray through the edge meets one of them (no
cracks). Box tests widen the far slab by ``SLAB_GROW`` (pbrt's rule), so a box is never
missed by rounding; the boxes are a byte per coordinate in their node's frame
(``accel/blas.py``), decoded per visit. A visit tests the four child boxes at once, goes
to the nearest hit child and pushes the others farthest first.

The query is C++ (``blas_query.inc``, inserted with ``wp.func_native``) on clang's
portable vector types: a node's four boxes and a leaf's four triangles each go through
one vector operation per step, and its stack is not zeroed per query. Warp's own vector
types went through memory between steps (docs/design/two-level.md). Its Warp-language
twin, ``tests/accel/blas_twin.py``, computes the same bits (the tests hold them equal).
"""
import warp as wp

from warp_st.kernels.layout import LINK_MASK, LINK_SHIFT
from warp_st.kernels.native import float_bits, snippet
from warp_st.kernels.traverse import STACK_SIZE, make_box_ops

__all__ = ["make_blas_query", "ray_shear", "ray_inv"]


@wp.func_native(snippet("blas_query.inc", STACK=STACK_SIZE, SHIFT=LINK_SHIFT, MASK=LINK_MASK,
                        GROW=make_box_ops(wp.float32)[3]))
def native_query(vidx: wp.array(dtype=wp.vec3i), pts: wp.array(dtype=wp.vec3),
                 q: wp.array(dtype=wp.types.vector(24, wp.uint8)), frm: wp.array(dtype=wp.types.vector(6, wp.float32)),
                 lk: wp.array(dtype=wp.vec4i), tri_body: wp.array(dtype=wp.int32), root: int, vert: int, tri0: int,
                 p: wp.vec3, shear: wp.vec4, inv: wp.vec3, t_max: wp.float32, any_hit: int, tri_base: int,
                 skip_body: int, skip_t: wp.float32, skip_tri: int) -> wp.vec4:
    """(t, u, v, the hit slot's int32 bits; -1 without a hit) of the ray from ``p`` whose
    direction d gives ``shear`` = ray_shear(d) and ``inv`` = 1 / d (``ray_inv``)."""


@wp.func_native(snippet("ray_shear.inc"))
def ray_shear(d: wp.vec3) -> wp.vec4:
    """Woop's shear of direction ``d`` (``ray_shear.inc``), as ``native_query`` takes it."""


_safe_inv = make_box_ops(wp.float32)[2]


@wp.func
def ray_inv(d: wp.vec3) -> wp.vec3:
    """1 / d per axis for the query's slabs (traverse.safe_inv: +-1e30 for a zero)."""
    return wp.vec3(_safe_inv(d[0]), _safe_inv(d[1]), _safe_inv(d[2]))


def make_blas_query(Geometry):
    @wp.func(inline=True)
    def blas_query(g: Geometry, root: int, vert: int, tri0: int, p: wp.vec3, shear: wp.vec4, inv: wp.vec3,
                   t_max: wp.float32, any_hit: int, tri_base: int, skip_body: int, skip_t: wp.float32, skip_tri: int):
        r = native_query(g.shape_vidx, g.blas_points, g.blas_q, g.blas_frame, g.blas_link, g.tri_body, root, vert, tri0,
                         p, shear, inv, t_max, any_hit, tri_base, skip_body, skip_t, skip_tri)
        slot = float_bits(r[3])
        hit = int(0)
        if slot >= 0:
            hit = 1
        return hit, r[0], r[1], r[2], slot - tri0

    return blas_query
