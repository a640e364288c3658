"""Ray casting against the 4D database of prisms or tetrahedra (pure Warp device code).

A ray is the null line E(s) = O + s d with d = (-1, n) for finite light speed or
(0, n) for infinite light speed (docs/spec.md §1), s >= 0 the lookback. Everything is in
render-origin coordinates (the camera event is the origin).

Ray/tetrahedron intersection (thesis §4.3.2, barycentric): the 4D line meets the
tetrahedron V0..V3 where O + s d = sum_i lam_i V_i, sum lam_i = 1, lam_i >= 0. We
project along d onto the 3D space transverse to the ray,

    q(P) = (x_rel . n + t_rel, x_rel . u, x_rel . w),   s(P) = -t_rel      (finite)
    q(P) = (t_rel,             x_rel . u, x_rel . w),   s(P) = x_rel . n   (infinite)

with (n, u, w) orthonormal and rel = P - O; the ray becomes the point q = 0 and the
barycentric coordinates of 0 in the projected tetrahedron are ratios of triple
products of its faces. Faces are evaluated in ascending global vertex order (the
extrusion stores every tetrahedron's indices sorted), so the two tetrahedra sharing
a face compute its triple product bit-identically and a ray can never slip between
them: the watertight construction of pbrt's triangle test, one dimension up.

Ray/prism intersection (the fast path): a prism is a triangle moving rigidly with the
body's velocity v over [t0, t1], x_i(t) = x_i + v (t - t0). The ray meets it where
o_x + s n = sum b_i x_i + v (o_t - s - t0), i.e. the static triangle x_i is met by the
3D ray O' + s D with O' = o_x - v (o_t - t0) and D = n + v (D = n with infinite light
speed, where t = o_t), subject to t_lo <= o_t - s <= t_hi: one 3D triangle test instead
of three 4D ones. A prism is exactly the union of its three tetrahedra (the side quads
are parallelograms), so both paths give the same hits (tests/spacetime/test_prisms.py); [t_lo,
t_hi] is the segment [t0, t1] overlapping its neighbours slightly (extrude.PRISM_OVERLAP:
the same moving triangle, continued), which keeps slice times watertight.
The test projects along D (pbrt's permute-and-shear) and evaluates each edge function
over the sorted global vertex indices with a rounding tolerance that depends on the
edge only, so neighbouring prisms agree on every shared edge (watertight).

Traversal: the 4-wide form of the 4D BVH (bvh_wide.py, ``traverse.py``); a leaf holds
a range of prisms or tetrahedra.
"""

import warp as wp

from warp_st.kernels.struct_ref import referenced
from warp_st.kernels.traverse import STACK_SIZE, make_traverse

__all__ = ["make_trace", "STACK_SIZE"]


def make_trace(scalar, primitive: str = "prism"):
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    vec16 = wp.types.vector(16, scalar)
    dvec3 = wp.types.vector(3, wp.float64)
    # The tetrahedron test always computes in float64 (from float32 or float64
    # storage): its rounding bound then stays ~1e-15 relative, far inside the
    # outward padding of the node boxes, at the same scalar-CPU cost.
    FACE_EPS = 8.0 * 1.12e-16

    @referenced
    class Geometry:
        vert: wp.array(dtype=vec4)
        # Primitive i's data at 4i..4i+3: a tetrahedron's 4 events, or a prism's 3 bottom
        # events and (t_hi, v) with t_lo in the second event's time slot. Positions are
        # bit-identical copies of the shared vertices.
        prim_event: wp.array(dtype=vec4)
        prim_f: wp.array2d(dtype=scalar)  # prim_event's memory as rows of 4 scalars
        prim_vidx: wp.array(dtype=wp.vec4i)  # vertex indices for shading (prism: a, b, c, a)
        prim_tri: wp.array(dtype=wp.int32)
        tri_body: wp.array(dtype=wp.int32)
        body_object: wp.array(dtype=wp.int32)  # the object of each body (an animated body's pieces share one)
        # The 4-wide BVH (bvh_wide.py): wide node j's four child boxes, axis-major
        # (t0..t3, x0..x3, y0..y3, z0..z3), low corners in node_lo[j], high in
        # node_hi[j]; its children's links first << LINK_SHIFT | count (a leaf's
        # primitive range, or a wide node with count 0; -1 for an empty slot).
        # The root is wide node 0.
        node_lo: wp.array(dtype=vec16)
        node_hi: wp.array(dtype=vec16)
        node_link: wp.array(dtype=wp.vec4i)
        root_lo: vec4  # the root's box (the whole database)
        root_hi: vec4
        root_link: int  # where the traversal starts: 0 (wide node 0), or its one child's link

    @wp.func
    def ray_basis(n: vec3):
        # Duff et al. 2017, "Building an orthonormal basis, revisited".
        sign = scalar(1.0)
        if n[2] < scalar(0.0):
            sign = scalar(-1.0)
        a = scalar(-1.0) / (sign + n[2])
        b = n[0] * n[1] * a
        u = vec3(scalar(1.0) + sign * n[0] * n[0] * a, sign * b, -sign * n[0])
        w = vec3(b, sign + n[1] * n[1] * a, -n[1])
        return u, w

    @wp.func
    def project(p: vec4, o: vec4, n: dvec3, u: dvec3, w: dvec3, finite: int):
        """Transverse coordinates q (float64) and lookback s of event p along the ray."""
        rt = wp.float64(p[0]) - wp.float64(o[0])
        rx = dvec3(wp.float64(p[1]) - wp.float64(o[1]), wp.float64(p[2]) - wp.float64(o[2]), wp.float64(p[3]) - wp.float64(o[3]))
        a = wp.dot(rx, n)
        q = dvec3(rt, wp.dot(rx, u), wp.dot(rx, w))
        s = a
        if finite != 0:
            q = dvec3(a + rt, q[1], q[2])
            s = -rt
        return q, s

    @wp.func
    def triple(a: dvec3, b: dvec3, c: dvec3) -> wp.float64:
        return wp.dot(a, wp.cross(b, c))

    @wp.func
    def to_d(v: vec3) -> dvec3:
        return dvec3(wp.float64(v[0]), wp.float64(v[1]), wp.float64(v[2]))

    @wp.func
    def l1(q: dvec3) -> wp.float64:
        return wp.abs(q[0]) + wp.abs(q[1]) + wp.abs(q[2])

    @wp.func
    def hit_tet(g: Geometry, ti: int, o: vec4, nd: dvec3, ud: dvec3, wd: dvec3, finite: int, s_min: scalar, s_max: scalar):
        """(hit, s, barycentrics) of the ray with tetrahedron ti, for s in (s_min, s_max).

        nd, ud, wd: the ray's orthonormal basis in float64 (see ``ray_basis``)."""
        # The events are stored inline per tetrahedron (one cache line, no gather); they
        # are bit-identical copies of the shared vertices, which watertightness needs.
        base = 4 * ti
        q0, s0 = project(g.prim_event[base], o, nd, ud, wd, finite)
        q1, s1 = project(g.prim_event[base + 1], o, nd, ud, wd, finite)
        q2, s2 = project(g.prim_event[base + 2], o, nd, ud, wd, finite)
        q3, s3 = project(g.prim_event[base + 3], o, nd, ud, wd, finite)
        # D_i = signed volume with vertex i replaced by the ray point (the origin):
        # cofactor signs of the 4x4 [q 1] determinant. Every face is evaluated as
        # q_a . (q_b x q_c) with a < b < c (the indices are sorted), so a face shared by
        # two tetrahedra gives bit-identical values in both.
        # Rounding bound of each face's triple product, |err| <= 5 eps |a|1 |b|1 |c|1
        # (taken as 8 eps). It depends only on the face, so both tetrahedra sharing
        # it use the same tolerance: a point within rounding of a face (or of an edge
        # where several faces meet, whose computed signs are noise) is accepted by
        # every tetrahedron around it instead of possibly by none. Without it, rays
        # through shared 4D edges slip through (measured: ~1 in 1000).
        m0 = l1(q0)
        m1 = l1(q1)
        m2 = l1(q2)
        m3 = l1(q3)
        d3 = triple(q0, q1, q2)
        e3 = wp.float64(FACE_EPS) * m0 * m1 * m2
        d2 = -triple(q0, q1, q3)
        e2 = wp.float64(FACE_EPS) * m0 * m1 * m3
        # Early out: two faces certain of opposite signs put the ray outside.
        if (d2 > e2 and d3 < -e3) or (d2 < -e2 and d3 > e3):
            return False, scalar(0.0), vec4(scalar(0.0))
        c23 = wp.cross(q2, q3)
        d1 = wp.dot(q0, c23)
        e1 = wp.float64(FACE_EPS) * m0 * m2 * m3
        pos = d1 > e1 or d2 > e2 or d3 > e3
        neg = d1 < -e1 or d2 < -e2 or d3 < -e3
        if pos and neg:
            return False, scalar(0.0), vec4(scalar(0.0))
        d0 = -wp.dot(q1, c23)
        e0 = wp.float64(FACE_EPS) * m1 * m2 * m3
        det = d0 + d1 + d2 + d3
        if det < wp.float64(0.0):
            det = -det
            d0 = -d0
            d1 = -d1
            d2 = -d2
            d3 = -d3
        lam = vec4(scalar(0.0))
        s = scalar(0.0)
        hit = False
        # A tetrahedron seen edge-on (det within rounding) is left to its neighbours.
        if det > e0 + e1 + e2 + e3:
            if d0 >= -e0 and d1 >= -e1 and d2 >= -e2 and d3 >= -e3:
                inv = wp.float64(1.0) / det
                sd = (d0 * s0 + d1 * s1 + d2 * s2 + d3 * s3) * inv
                lam = vec4(scalar(d0 * inv), scalar(d1 * inv), scalar(d2 * inv), scalar(d3 * inv))
                s = scalar(sd)
                hit = s > s_min and s < s_max
        return hit, s, lam

    @wp.func
    def cross2(a: wp.vec2d, b: wp.vec2d) -> wp.float64:
        return a[0] * b[1] - a[1] * b[0]

    @wp.func
    def edge_eps(a: wp.vec2d, b: wp.vec2d) -> wp.float64:
        # Rounding bound of cross2(a, b) (3 eps (|a0 b1| + |a1 b0|), taken as 8 eps):
        # a function of the edge only, like FACE_EPS for tetrahedron faces.
        return wp.float64(FACE_EPS) * (wp.abs(a[0] * b[1]) + wp.abs(a[1] * b[0]))

    @wp.func
    def prism_frame(nd: dvec3, v: dvec3, fin: wp.float64):
        """Projection of the prism test for ray direction D = n + fin v: (ok, kz, S).

        pbrt's permute-and-shear: with k_z the largest component of D and (k_x, k_y)
        the next two cyclically, a relative position r projects to
        (r[k_x] + S_x r[k_z], r[k_y] + S_y r[k_z]) on the plane transverse to D, and
        S_z r[k_z] is its lookback along D. It depends only on the ray and the body's
        velocity: the traversal computes it once per ray for bodies at rest."""
        d = nd + v * fin
        ax = wp.abs(d[0])
        ay = wp.abs(d[1])
        az = wp.abs(d[2])
        one = wp.float64(1.0)
        kz = int(2)
        S = dvec3(wp.float64(0.0))
        ok = True
        if ax > ay and ax > az:  # kz = 0, kx = 1, ky = 2
            kz = 0
            inv_z = one / d[0]
            S = dvec3(-d[1] * inv_z, -d[2] * inv_z, inv_z)
        elif ay > az:  # kz = 1, kx = 2, ky = 0
            kz = 1
            inv_z = one / d[1]
            S = dvec3(-d[2] * inv_z, -d[0] * inv_z, inv_z)
        elif az > wp.float64(0.0):  # kz = 2, kx = 0, ky = 1
            inv_z = one / d[2]
            S = dvec3(-d[0] * inv_z, -d[1] * inv_z, inv_z)
        else:
            ok = False  # D = 0: a decoupled body moving at -n, never met
        return ok, kz, S

    @wp.func
    def permute(x: dvec3, kz: int) -> dvec3:
        """(x[k_x], x[k_y], x[k_z]) of ``prism_frame``'s cyclic permutation."""
        if kz == 0:
            return dvec3(x[1], x[2], x[0])
        if kz == 1:
            return dvec3(x[2], x[0], x[1])
        return x

    @wp.func
    def event_p(g: Geometry, row: int, kz: int) -> dvec3:
        """Row ``row`` of prim_event's spatial part, permuted (``permute``), read in place."""
        kx = 1 + kz
        if kx == 3:
            kx = 0
        ky = 1 + kx
        if ky == 3:
            ky = 0
        return dvec3(wp.float64(g.prim_f[row, 1 + kx]), wp.float64(g.prim_f[row, 1 + ky]), wp.float64(g.prim_f[row, 1 + kz]))

    @wp.func
    def hit_prism_in(g: Geometry, pi: int, o: vec4, org: dvec3, kz: int, S: dvec3, finite: int, s_min: scalar, s_max: scalar):
        """(hit, s, barycentrics (b0, b1, b2, 0)) of the ray with prism pi, s in (s_min, s_max),
        with its velocity's projection (``prism_frame``) and the ray origin in the
        prism's comoving coordinates, permuted, ``org`` = o_x - v (o_t - t0)
        (``comoving_origin``)."""
        base = 4 * pi
        t_lo = wp.float64(g.prim_f[base + 1, 0])  # the segment [t0, t1], widened where it meets the next
        t_hi = wp.float64(g.prim_f[base + 3, 0])
        ot = wp.float64(o[0])
        if finite == 0 and (ot < t_lo or ot > t_hi):
            return False, scalar(0.0), vec4(scalar(0.0))
        r0 = event_p(g, base, kz) - org
        r1 = event_p(g, base + 1, kz) - org
        r2 = event_p(g, base + 2, kz) - org
        p0 = wp.vec2d(r0[0] + S[0] * r0[2], r0[1] + S[1] * r0[2])
        p1 = wp.vec2d(r1[0] + S[0] * r1[2], r1[1] + S[1] * r1[2])
        p2 = wp.vec2d(r2[0] + S[0] * r2[2], r2[1] + S[1] * r2[2])
        # Edge functions over ascending vertex indices (a < b): shared edges give
        # bit-identical values in both prisms. b_i is the edge opposite vertex i.
        b0 = cross2(p1, p2)
        b1 = -cross2(p0, p2)
        b2 = cross2(p0, p1)
        f0 = edge_eps(p1, p2)
        f1 = edge_eps(p0, p2)
        f2 = edge_eps(p0, p1)
        det = b0 + b1 + b2
        if det < wp.float64(0.0):
            det = -det
            b0 = -b0
            b1 = -b1
            b2 = -b2
        # A triangle seen edge-on along D (det within rounding) is left to its neighbours.
        if det <= f0 + f1 + f2 or b0 < -f0 or b1 < -f1 or b2 < -f2:
            return False, scalar(0.0), vec4(scalar(0.0))
        inv = wp.float64(1.0) / det
        sd = (b0 * r0[2] + b1 * r1[2] + b2 * r2[2]) * S[2] * inv
        if finite != 0:
            th = ot - sd
            if th < t_lo or th > t_hi:
                return False, scalar(0.0), vec4(scalar(0.0))
        s = scalar(sd)
        return s > s_min and s < s_max, s, vec4(scalar(b0 * inv), scalar(b1 * inv), scalar(b2 * inv), scalar(0.0))

    @wp.func
    def comoving_origin(g: Geometry, pi: int, o: vec4, org: dvec3, kz: int) -> dvec3:
        """The permuted ray origin ``org`` moved into prism pi's comoving coordinates."""
        t0 = wp.float64(g.prim_f[4 * pi, 0])
        return org - event_p(g, 4 * pi + 3, kz) * (wp.float64(o[0]) - t0)

    @wp.func
    def prism_v(g: Geometry, pi: int) -> dvec3:
        top = g.prim_event[4 * pi + 3]
        return dvec3(wp.float64(top[1]), wp.float64(top[2]), wp.float64(top[3]))

    @wp.func
    def origin_x(o: vec4) -> dvec3:
        return dvec3(wp.float64(o[1]), wp.float64(o[2]), wp.float64(o[3]))

    @wp.func
    def hit_prism(g: Geometry, pi: int, o: vec4, nd: dvec3, ud: dvec3, wd: dvec3, finite: int, s_min: scalar, s_max: scalar):
        """``hit_prism_in`` with the projection computed for this prism alone."""
        v = prism_v(g, pi)
        fin = wp.float64(0.0)
        if finite != 0:
            fin = wp.float64(1.0)
        ok, kz, S = prism_frame(nd, v, fin)
        if not ok:
            return False, scalar(0.0), vec4(scalar(0.0))
        org = comoving_origin(g, pi, o, permute(origin_x(o), kz), kz)
        return hit_prism_in(g, pi, o, org, kz, S, finite, s_min, s_max)

    @wp.struct
    class Ray:
        """What the leaf tests need per ray: its orthonormal basis in float64 and the
        prism projection of bodies at rest (D = n; every body with infinite c)."""

        nd: dvec3
        ud: dvec3
        wd: dvec3
        fin: wp.float64  # 1 for finite light speed (D = n + v), 0 for infinite (D = n)
        rest_kz: int
        rest_S: dvec3
        rest_org: dvec3

    @wp.func
    def prepare(g: Geometry, o: vec4, n: vec3, finite: int, inv: vec4) -> Ray:  # inv: unused here
        r = Ray()
        u, w = ray_basis(n)
        r.nd = to_d(n)
        r.ud = to_d(u)
        r.wd = to_d(w)
        r.fin = wp.float64(0.0)
        if finite != 0:
            r.fin = wp.float64(1.0)
        _rest_ok, rest_kz, rest_S = prism_frame(r.nd, dvec3(wp.float64(0.0)), wp.float64(0.0))
        r.rest_kz = rest_kz
        r.rest_S = rest_S
        r.rest_org = permute(origin_x(o), rest_kz)
        return r

    hit = hit_prism if primitive == "prism" else hit_tet

    @wp.func
    def leaf(g: Geometry, ray: Ray, first: int, count: int, o: vec4, n: vec3, finite: int, s_min: scalar,
             best: scalar, best_prim: int, best_lam: vec4, skip_tri: int, skip_body: int, skip_dist: scalar,
             any_hit: int):
        """The closest hit so far, updated by the leaf's prisms or tetrahedra."""
        zero = wp.float64(0.0)
        # The projection for the leaf's first prism's velocity, shared by the leaf's
        # prisms of the same velocity (leaves hold one body's prisms but for a few at
        # body boundaries).
        leaf_v = dvec3(zero)
        leaf_ok = bool(False)
        leaf_kz = int(0)
        leaf_S = dvec3(zero)
        leaf_org = dvec3(zero)
        if wp.static(primitive == "prism"):
            leaf_v = prism_v(g, first)
            if finite != 0 and (leaf_v[0] != zero or leaf_v[1] != zero or leaf_v[2] != zero):
                leaf_ok, leaf_kz, leaf_S = prism_frame(ray.nd, leaf_v, ray.fin)
                leaf_org = permute(origin_x(o), leaf_kz)
        for k in range(count):
            ti = first + k
            tri = int(-2)
            if skip_tri >= 0 or skip_body >= 0:
                tri = g.prim_tri[ti]
            if tri != skip_tri:
                h = bool(False)
                s = scalar(0.0)
                lam = vec4(scalar(0.0))
                if wp.static(primitive == "prism"):
                    v = prism_v(g, ti)
                    if v[0] == zero and v[1] == zero and v[2] == zero:
                        h, s, lam = hit_prism_in(g, ti, o, ray.rest_org, ray.rest_kz, ray.rest_S, finite, s_min, best)
                    elif finite == 0:
                        org = comoving_origin(g, ti, o, ray.rest_org, ray.rest_kz)
                        h, s, lam = hit_prism_in(g, ti, o, org, ray.rest_kz, ray.rest_S, finite, s_min, best)
                    elif v[0] == leaf_v[0] and v[1] == leaf_v[1] and v[2] == leaf_v[2]:
                        if leaf_ok:
                            org = comoving_origin(g, ti, o, leaf_org, leaf_kz)
                            h, s, lam = hit_prism_in(g, ti, o, org, leaf_kz, leaf_S, finite, s_min, best)
                    else:
                        h, s, lam = hit_prism(g, ti, o, ray.nd, ray.ud, ray.wd, finite, s_min, best)
                else:
                    h, s, lam = hit(g, ti, o, ray.nd, ray.ud, ray.wd, finite, s_min, best)
                if h and skip_body >= 0 and s < skip_dist:
                    # (Warp may evaluate both sides of `or`: no index with tri = -2.)
                    if g.body_object[g.tri_body[tri]] == g.body_object[skip_body]:
                        h = False
                if h:
                    best = s
                    best_prim = ti
                    best_lam = lam
        return best, best_prim, best_lam

    trace = make_traverse(scalar, Geometry, prepare, leaf)
    return Geometry, trace, prepare, leaf
