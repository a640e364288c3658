"""Ray casting against rigid bodies as instances (pure Warp device code).

Two levels (``warp_st.spacetime.rigid``, ``warp_st.accel.instances``):

- top: the 4-wide 4D BVH (``traverse.py``) over motion segments, each a body over a
  lab-time span [t_lo, t_hi] with its 4D box;
- bottom: one 4-wide 3D BVH per distinct shape (``blas.py``), its triangles at rest in body coordinates
  (an animated body's pieces share one: ``body_map`` turns the ray into it).

A leaf's segment takes the ray E(s) = O + s d into its body's coordinates: with the
body's reference event (t_ref, o) on the pivot's worldline as anchor, the ray is the
3D line (spacetime/rigid.py)

    r(s) = A^-1 (w + s D),   w = o_x - o - v (o_t - t_ref),   D = n + v  (finite c)
                                                               D = n      (infinite c)

(A^-1 = I for decoupled bodies), computed in float64, and s is the mesh query's own
parameter. A body at rest with A^-1 = I (``AT_REST``) sees r(s) = (o_x - o) + s n: its d,
1 / d and the bottom level's shear (``blas.ray_shear``) are the ray's, computed once in
``prepare`` instead of per segment (the same values, bit for bit: tests/accel/test_at_rest.py).
The segment admits s in [s_lo, s_hi]: (s_min, best) cut to its span (t = o_t - s in
[t_lo, t_hi]; with infinite c, o_t itself must lie in it). The query runs over the part
of that where r(s) is inside the body's rest box (see ``leaf``).
Hits on body ``skip_body`` (or another piece of its animated object, ``body_object``)
nearer than ``skip_dist`` are left out by starting that body's query at skip_dist
instead: the same rule as the prism path, without a test per hit. A hit on the triangle
a secondary ray leaves (``skip_tri``: a grazing ray can meet its own facet again within
rounding) is stepped over and the query repeated; for that body a shadow ray runs the
closest-hit query (which sees triangles), every other body the any-hit one. In a merged
class's shape (``body_merged``: several bodies of one motion as one shape,
spacetime/merge_classes.merge_plan) the bottom level itself leaves out skip_tri and skip_body's
triangles nearer than skip_dist, so the class's other bodies are met from the ray's
start and a shadow ray runs the any-hit query.

The hit's barycentrics (u, v, 1 - u - v) weigh the triangle's vertices in the mesh's
index order; the primitive index returned is the global triangle (its own triangle:
``prim_lookup``), so the shading reads the same tables as on the prism path.

A body flagged ``body_quadric`` is an exact analytic shape (``kernels/quadrics.py``: an
ellipsoid, cylinder, cone or capsule) in canonical coordinates q = Q (r - c) of its frame's
(spacetime/rigid.py): the ray r(s) = p + s d is a line there too, and the shape's interval
along it comes from quadratics and slabs solved in float64 (``quadric_hit``). Such a hit
returns the body's first triangle (its material and body for the shading) and, in place
of barycentrics, the unit lab normal with a 4th component of ANALYTIC
(``shade.shading_normal``): the canonical normal taken back by Q^T and to the lab by A^-T. A secondary ray leaving the surface
has a root at its start, within the float32 rounding of the hit event (~1e-7 of the
path): the self-intersection offset s_min (``shade.SELF_EPS``, 1e-4 of the path) drops
it, and as the ellipsoid is convex and the ray a straight line in its frame, the other
root lies behind the ray unless it leaves into the inside (every shape is convex).

Deforming bodies (``tets``, docs/design/mixed-leaves.md): their tetrahedra are a second
leaf kind. A segment whose body is -1 holds the deforming bodies' 4D tetrahedron BVH
(``g.tets``, the tet path's own Geometry, ``trace.py``): the leaf runs that path's
traversal and exact tetrahedron test on it, nested as the bottom level is, with the
ray's own s_min, best, skips and any-hit flag, so its hits are the tet path's. A
tetrahedron hit returns primitive ``tet_first`` + its index (``prim_lookup``).
"""

import warp as wp

from warp_st.kernels.blas import make_blas_query, ray_inv, ray_shear
from warp_st.kernels.layout import ANALYTIC
from warp_st.kernels.quadrics import make_quadrics
from warp_st.kernels.struct_ref import referenced
from warp_st.kernels.trace import make_trace
from warp_st.kernels.traverse import STACK_SIZE, make_box_ops, make_traverse

__all__ = ["make_trace_rigid"]


def make_trace_rigid(scalar, tets: bool = False, stack_size: int = STACK_SIZE):
    """The rigid path's Geometry and traversal in ``scalar``. The bottom levels'
    bottom-level queries are float32 whatever ``scalar`` is (``at``): in float64 the path
    is exact only for analytic shapes, which is why the renderer takes it in float64 only
    for scenes of exact quadrics (``rendering.renderer``). ``tets``: the Geometry also
    holds deforming bodies' tetrahedra (``tets``, ``tet_first``; see the module docstring).
    ``stack_size``: the top level's traversal stack (``traverse.stack_for`` its tree; the
    tetrahedra's own traversal takes the full one)."""
    vec2 = wp.types.vector(2, scalar)
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    vec16 = wp.types.vector(16, scalar)
    vec24ub = wp.types.vector(24, wp.uint8)
    vec6f = wp.types.vector(6, wp.float32)
    solid_interval = make_quadrics()
    fmin, fmax, _, SLAB_GROW = make_box_ops(scalar)
    fmin64, fmax64 = make_box_ops(wp.float64)[:2]  # single compare-selects: no slab value is NaN
    # A hit on the triangle a secondary ray leaves (skip_tri) is stepped over by this
    # fraction of its lookback (and as much absolutely): far past the float32 rounding of
    # the crossing (~1e-7), far below the self-intersection offset SELF_EPS (1e-4).
    SKIP_STEP = 1.0e-6
    START_OWN = wp.constant(1)  # body_flags' bits
    AT_REST = wp.constant(2)
    TetGeometry, tet_trace = make_trace(scalar, "tet")[:2] if tets else (None, None)
    with_tets = tets  # the struct's field is named tets

    @referenced
    class Geometry:
        # Shading tables (global triangles, each a primitive: ``prim_lookup``): each
        # shape's triangles (vertex indices in the shape), where each body's shape starts
        # there and the body's first global vertex.
        shape_vidx: wp.array(dtype=wp.vec3i)
        body_shape_tri: wp.array(dtype=wp.int32)
        body_vert_base: wp.array(dtype=wp.int32)
        tri_body: wp.array(dtype=wp.int32)
        body_object: wp.array(dtype=wp.int32)  # the object of each body (an animated body's pieces share one)
        # Merged classes (spacetime/merge_classes.merge_plan): the body holding each body's shape
        # and segments, and 1 for the bodies of a class of several.
        body_holder: wp.array(dtype=wp.int32)
        body_merged: wp.array(dtype=wp.int32)
        # Bodies: bottom level (the root wide node of the body's shape in blas_*, -1:
        # none), first global triangle, velocity and rest_from_lab (A^-1) in float64.
        body_blas: wp.array(dtype=wp.int32)
        body_tri_base: wp.array(dtype=wp.int32)
        body_velocity: wp.array(dtype=wp.vec3d)
        body_rest: wp.array(dtype=wp.mat33d)
        body_rest_lo: wp.array(dtype=wp.vec3d)  # the shape's box in its frame's coordinates, padded
        body_rest_hi: wp.array(dtype=wp.vec3d)
        body_start_lo: wp.array(dtype=wp.vec3d)  # the box of the shapes of that frame it may touch (start_boxes.py)
        body_start_hi: wp.array(dtype=wp.vec3d)
        # START_OWN: that box is the body's own (it touches no other body of its frame); AT_REST: the
        # body is at rest with A^-1 = I and not body_mapped, so its ray is the lab ray
        # moved (p = o - anchor, d = n) and its direction, 1 / d and shear are the ray's own
        body_flags: wp.array(dtype=wp.int32)
        body_anchor: wp.array(dtype=wp.vec4d)  # the frame's event relative to the render origin
        body_end: wp.array(dtype=wp.float64)  # the lifetime's end relative to the render origin
        body_quadric: wp.array(dtype=wp.int32)  # >0: the body is that exact shape (kernels/quadrics.py)
        quadric_inv: wp.array(dtype=wp.mat33d)
        quadric_centre: wp.array(dtype=wp.vec3d)
        quadric_param: wp.array(dtype=wp.vec3d)  # (radius, half height, -) of a cylinder, cone or capsule
        # A body whose bottom level is held in other coordinates (an animated body's pieces
        # share its unturned shape): the mesh sees r(s) as body_map (r(s) - body_map_shift).
        body_mapped: wp.array(dtype=wp.int32)
        body_map: wp.array(dtype=wp.mat33d)
        body_map_shift: wp.array(dtype=wp.vec3d)
        # Motion segments in top-level leaf order: body, lab-time span (t_lo, t_hi) and
        # 4D box, relative to the render origin.
        seg_body: wp.array(dtype=wp.int32)
        seg_span: wp.array(dtype=vec2)
        seg_lo: wp.array(dtype=vec4)
        seg_hi: wp.array(dtype=vec4)
        # The top level's 4-wide BVH over the segments (traverse.py).
        node_lo: wp.array(dtype=vec16)
        node_hi: wp.array(dtype=vec16)
        node_link: wp.array(dtype=wp.vec4i)
        root_lo: vec4
        root_hi: vec4
        root_link: int  # where the traversal starts: 0 (wide node 0), or its one child's link
        # The bottom levels (accel/blas.py, kernels/blas.py): every shape's 4-wide 3D
        # BVH over its triangles (shape_vidx, in leaf order), the shapes' rest points and
        # where each body's shape's points start in them.
        blas_q: wp.array(dtype=vec24ub)  # child boxes, a byte per coordinate in the node's frame
        blas_frame: wp.array(dtype=vec6f)
        blas_link: wp.array(dtype=wp.vec4i)
        blas_points: wp.array(dtype=wp.vec3)
        body_blas_vert: wp.array(dtype=wp.int32)
        if with_tets:  # deforming bodies' tetrahedra (trace.py's Geometry), primitives from tet_first on
            tets: TetGeometry
            tet_first: int

    blas_query = make_blas_query(Geometry)

    @wp.func
    def reciprocal(d: wp.vec3d) -> wp.vec3d:
        """1 / d per axis where d is not 0 (rest_range's slabs; 0 where it is)."""
        inv = wp.vec3d()
        for k in range(3):
            if d[k] != wp.float64(0.0):
                inv[k] = wp.float64(1.0) / d[k]
        return inv

    @wp.struct
    class Ray:
        inv: vec4  # 1 / d per axis for the segment boxes' slab test
        fin: scalar  # 1 for finite light speed (D = n + v), 0 for infinite (D = n)
        n64: wp.vec3d  # n in float64, and its reciprocal(): an AT_REST body's d and 1 / d
        inv64: wp.vec3d
        shear: wp.vec4  # the float32 n's ray_shear and ray_inv: an AT_REST body's bottom-level query's
        inv32: wp.vec3

    @wp.func
    def prepare(g: Geometry, o: vec4, n: vec3, finite: int, inv: vec4) -> Ray:
        r = Ray()
        r.fin = scalar(0.0)
        if finite != 0:
            r.fin = scalar(1.0)
        r.inv = inv
        r.n64 = wp.vec3d(wp.float64(n[0]), wp.float64(n[1]), wp.float64(n[2]))
        r.inv64 = reciprocal(r.n64)
        n32 = wp.vec3(wp.float32(n[0]), wp.float32(n[1]), wp.float32(n[2]))
        r.shear = ray_shear(n32)
        if wp.static(scalar == wp.float32):
            r.inv32 = wp.vec3(r.inv[1], r.inv[2], r.inv[3])  # ray_inv(n): the same safe_inv, in null_inv
        else:
            r.inv32 = ray_inv(n32)
        return r

    @wp.func
    def box_range(lo: vec4, hi: vec4, o: vec4, inv: vec4, s_lo: scalar, s_hi: scalar):
        """(s_lo, s_hi) cut to where the ray is inside the 4D box [lo, hi] (empty: s_lo > s_hi)."""
        a = wp.cw_mul(lo - o, inv)
        b = wp.cw_mul(hi - o, inv)
        near = s_lo
        far = s_hi
        for k in range(4):
            near = fmax(near, fmin(a[k], b[k]))
            far = fmin(far, fmax(a[k], b[k]) * scalar(SLAB_GROW))
        return near, far

    @wp.func
    def body_ray(g: Geometry, body: int, o: vec4, n: vec3, fin: scalar):
        """The ray in the coordinates of ``body``'s frame, r(s) = p + s d, in float64 from
        the frame's event (the anchor; spacetime/rigid.py): (p, d)."""
        a = g.body_anchor[body]
        v = g.body_velocity[body]
        rest = g.body_rest[body]
        d = wp.vec3d(wp.float64(n[0]), wp.float64(n[1]), wp.float64(n[2])) + v * wp.float64(fin)
        w = wp.vec3d(wp.float64(o[1]) - a[1], wp.float64(o[2]) - a[2], wp.float64(o[3]) - a[3]) - v * (
            wp.float64(o[0]) - a[0])
        return rest * w, rest * d

    @wp.func
    def rest_range(lo: wp.vec3d, hi: wp.vec3d, p: wp.vec3d, d: wp.vec3d, inv: wp.vec3d, s0: wp.float64,
                   s1: wp.float64):
        """[s0, s1] cut to where r(s) = p + s d lies in the box [lo, hi] (float64 slabs,
        ``inv`` = reciprocal(d); empty: s0 >= s1). No slab value is NaN (an axis with
        d = 0 is told apart, and 1 / d is finite on the others), so the minima and maxima
        are single compare-selects."""
        for k in range(3):
            if d[k] != wp.float64(0.0):
                a = (lo[k] - p[k]) * inv[k]
                b = (hi[k] - p[k]) * inv[k]
                s0 = fmax64(s0, fmin64(a, b))
                s1 = fmin64(s1, fmax64(a, b))
            elif p[k] < lo[k] or p[k] > hi[k]:
                s1 = wp.float64(-1.0)
        return s0, s1

    @wp.func
    def quadric_hit(g: Geometry, body: int, p: wp.vec3d, d: wp.vec3d, lo: wp.float64, hi: wp.float64):
        """(s, lab normal) of the first crossing of ``body``'s analytic shape in [lo, hi]
        (``kernels/quadrics.py`` in its canonical coordinates q = Q (r - c)); s < lo when
        none. The normal: the canonical one taken back by Q^T, then to the lab by A^-T."""
        q_inv = g.quadric_inv[body]
        q0 = q_inv * (p - g.quadric_centre[body])
        qd = q_inv * d
        entry, leave, n_entry, n_leave = solid_interval(g.body_quadric[body], q0, qd, g.quadric_param[body])
        s = lo - wp.float64(1.0)
        n = n_entry
        if entry <= leave:
            if entry >= lo and entry <= hi:
                s = entry
            elif leave >= lo and leave <= hi:  # the ray starts inside the solid
                s = leave
                n = n_leave
        normal = vec3(scalar(0.0))
        if s >= lo:
            lab = wp.normalize(wp.transpose(g.body_rest[body]) * (wp.transpose(q_inv) * n))
            normal = vec3(scalar(lab[0]), scalar(lab[1]), scalar(lab[2]))
        return s, normal

    @wp.func
    def at(p: wp.vec3d, d: wp.vec3d, s: wp.float64) -> wp.vec3:
        """The ray's point at s, as a float32 bottom-level query takes it."""
        q = p + d * s
        return wp.vec3(wp.float32(q[0]), wp.float32(q[1]), wp.float32(q[2]))

    @wp.func
    def leaf(g: Geometry, ray: Ray, first: int, count: int, o: vec4, n: vec3, finite: int, s_min: scalar,
             best: scalar, best_prim: int, best_lam: vec4, skip_tri: int, skip_body: int, skip_dist: scalar,
             any_hit: int):
        """The closest hit so far, updated by the leaf's motion segments (see the module docstring).

        The query starts where the ray enters the body's start box (float64, the frame's
        event as anchor): the rest box of the bodies of its frame it may touch
        (spacetime/start_boxes.py). Neither depends on the segment, so a hit comes out
        bit-identical from whichever database (windows, segments) it is found in; bodies
        in contact get the same float32 ray, so none slips through their seams; and the
        rounding is of their size, not of the distance. A hit before
        the segment's span (possible where a lifetime or a cut between segments ends it
        inside the box) is discarded and the query repeated from past it: from the
        lifetime's end if the hit lies beyond that (the start is still the body's), else
        from the span's start (then the dropped hit is another segment's, and nearer).
        A leaf of one segment skips the segment's 4D box test: the node's visit has just
        tested the same box (its child's), and the rest-box slabs and the span test
        below decide alike."""
        # best_lam as four scalars (see traverse.py's trace): no vector merged under a branch
        lam0 = best_lam[0]
        lam1 = best_lam[1]
        lam2 = best_lam[2]
        lam3 = best_lam[3]
        for k in range(count):
            si = first + k
            span = g.seg_span[si]
            body = g.seg_body[si]
            if wp.static(tets):
                if body < 0:  # the deforming bodies' tetrahedra: the tet path's traversal and test
                    tp, ts, tl, _visits, _ovf = tet_trace(g.tets.ref, o, n, finite, s_min, best, skip_tri, skip_body,
                                                          skip_dist, any_hit)
                    if tp >= 0:
                        best = ts
                        best_prim = g.tet_first + tp
                        lam0 = tl[0]
                        lam1 = tl[1]
                        lam2 = tl[2]
                        lam3 = tl[3]
                        if any_hit != 0:
                            return best, best_prim, tl
                    continue
            s_from = s_min
            own = int(0)  # a body of skip_body's object (an animated body's piece)
            filtered = int(-1)  # skip_body, when its class's merged shape is queried
            if skip_body >= 0:
                if g.body_merged[body] != 0:
                    if g.body_holder[skip_body] == body:
                        own = 1
                        filtered = skip_body
                elif g.body_object[body] == g.body_object[skip_body]:
                    own = 1
            if own != 0 and filtered < 0:
                s_from = fmax(s_from, skip_dist)
            s_lo = s_from
            s_hi = best
            if finite != 0:
                s_lo = fmax(s_lo, o[0] - span[1])
                s_hi = fmin(s_hi, o[0] - span[0])
            elif o[0] < span[0] or o[0] > span[1]:
                s_hi = scalar(-1.0)
            met = s_lo < s_hi
            if met and count > 1:  # a leaf of one segment: the node's visit just tested its box
                b_lo, b_hi = box_range(g.seg_lo[si], g.seg_hi[si], o, ray.inv, s_lo, s_hi)
                met = b_lo <= b_hi
            if met:
                flags = g.body_flags[body]
                p = wp.vec3d()
                d = ray.n64
                inv_d = ray.inv64
                if flags & AT_REST != 0:
                    a = g.body_anchor[body]
                    p = wp.vec3d(wp.float64(o[1]) - a[1], wp.float64(o[2]) - a[2], wp.float64(o[3]) - a[3])
                else:
                    p, d = body_ray(g, body, o, n, ray.fin)
                    inv_d = reciprocal(d)
                e0, e1 = rest_range(g.body_rest_lo[body], g.body_rest_hi[body], p, d, inv_d, wp.float64(s_from),
                                    wp.float64(s_hi))
                if e0 < e1 and flags & START_OWN == 0:  # its box is met: start where its start box is entered
                    e0, _e = rest_range(g.body_start_lo[body], g.body_start_hi[body], p, d, inv_d,
                                        wp.float64(s_from), wp.float64(s_hi))
                pm = p  # the ray as the bottom level sees it (the same s)
                dm = d
                if g.body_mapped[body] != 0:
                    pm = g.body_map[body] * (p - g.body_map_shift[body])
                    dm = g.body_map[body] * d
                shear = ray.shear  # an AT_REST body's direction is n: the ray's own
                inv32 = ray.inv32
                if flags & AT_REST == 0:
                    direction = wp.vec3(wp.float32(dm[0]), wp.float32(dm[1]), wp.float32(dm[2]))
                    shear = ray_shear(direction)
                    inv32 = ray_inv(direction)
                root = g.body_blas[body]
                base = g.body_tri_base[body]
                if g.body_quadric[body] != 0:
                    s, normal = quadric_hit(g, body, p, d, wp.float64(s_lo), wp.float64(s_hi))
                    if s >= wp.float64(s_lo):
                        best = scalar(s)
                        best_prim = base
                        lam0 = normal[0]
                        lam1 = normal[1]
                        lam2 = normal[2]
                        lam3 = scalar(ANALYTIC)
                        if any_hit != 0:
                            return best, best_prim, vec4(lam0, lam1, lam2, lam3)
                elif root >= 0:
                    # Start at the body's rest box. A shadow ray (any hit) on another
                    # body needs one query. Otherwise a hit on ``skip_tri`` is stepped
                    # over; one before the span (a later lab time) is dropped and the
                    # query repeated from past it: from the lifetime's end when the hit
                    # lies beyond it, else from the span. (One call site: it is inlined.)
                    shadow = int(0)
                    if any_hit != 0 and (own == 0 or filtered >= 0):
                        shadow = 1
                        e0 = wp.max(e0, wp.float64(s_lo))
                    s_life = wp.float64(o[0]) - g.body_end[body]
                    attempt = int(0)  # a while loop: a constant range would be unrolled
                    while attempt < 4 and e0 < e1:
                        attempt += 1
                        found, qt, qu, qv, face = blas_query(g, root, g.body_blas_vert[body], g.body_shape_tri[body],
                                                             at(pm, dm, e0), shear, inv32, wp.float32(e1 - e0), shadow,
                                                             base, filtered, wp.float32(wp.float64(skip_dist) - e0),
                                                             skip_tri)
                        if found == 0:
                            e1 = wp.float64(-1.0)
                        elif shadow != 0:
                            return s_hi, base, vec4(scalar(0.0))
                        else:
                            s = e0 + wp.float64(qt)
                            if base + face == skip_tri:
                                e0 = s + wp.float64(SKIP_STEP) * (wp.float64(1.0) + wp.abs(s))
                            elif s >= wp.float64(s_lo):
                                best = scalar(s)
                                best_prim = base + face
                                lam0 = scalar(qu)
                                lam1 = scalar(qv)
                                lam2 = scalar(1.0) - scalar(qu) - scalar(qv)
                                lam3 = scalar(0.0)
                                e1 = wp.float64(-1.0)
                            elif s < s_life:
                                e0 = s_life
                            else:
                                e0 = wp.float64(s_lo)
                    if any_hit != 0 and best_prim >= 0:
                        return best, best_prim, vec4(lam0, lam1, lam2, lam3)
        return best, best_prim, vec4(lam0, lam1, lam2, lam3)

    trace = make_traverse(scalar, Geometry, prepare, leaf, stack_size=stack_size)
    Geometry.tet_geometry = TetGeometry  # the nested struct's type (None without tets)
    return Geometry, trace, prepare, leaf
