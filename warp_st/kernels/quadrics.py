"""Exact analytic shapes in their canonical coordinates (pure Warp device code, float64).

Each shape is a convex solid in canonical coordinates q, its axis along z:

- QUADRIC_SPHERE (1): the unit ball |q| <= 1 (an ellipsoid once its transform is applied);
- QUADRIC_CYLINDER (2): q_x^2 + q_y^2 <= r^2, |q_z| <= h;
- QUADRIC_CONE (3): q_x^2 + q_y^2 <= k^2 (h - q_z)^2, |q_z| <= h, k = r / (2 h) (apex at +h);
- QUADRIC_CAPSULE (4): within r of the segment |q_z| <= h on the axis.

``solid_interval`` gives the line q(s) = q0 + s qd's interval [entry, exit] inside the solid
with the outward normals there. Every solid is an intersection (cylinder, cone) or a union
(capsule) of convex pieces whose intervals come from one quadratic or one slab each, and the
solid's interval is the intersection (or union) of those: no rim or seam is tested twice, so
a ray cannot slip between a side and a cap.
"""
import warp as wp

__all__ = ["QUADRIC_SPHERE", "QUADRIC_CYLINDER", "QUADRIC_CONE", "QUADRIC_CAPSULE", "make_quadrics"]

QUADRIC_SPHERE = 1
QUADRIC_CYLINDER = 2
QUADRIC_CONE = 3
QUADRIC_CAPSULE = 4


def make_quadrics():
    f64 = wp.float64
    BIG = 1.0e300

    @wp.func
    def roots(a: f64, b: f64, c: f64):
        """(found, s1 <= s2) of a s^2 + 2 b s + c = 0 (a != 0; the stable form)."""
        disc = b * b - a * c
        if disc < f64(0.0):
            return 0, f64(0.0), f64(0.0)
        root = wp.sqrt(disc)
        k = -b - root
        if b < f64(0.0):
            k = -b + root
        if k == f64(0.0):
            return 1, f64(0.0), f64(0.0)
        s1 = k / a
        s2 = c / k
        return 1, wp.min(s1, s2), wp.max(s1, s2)

    @wp.func
    def inside_quadratic(a: f64, b: f64, c: f64):
        """Where a s^2 + 2 b s + c <= 0 along the line, for a convex quadric (a >= 0) or
        one nappe's worth (a < 0: the two outer pieces): (lo, hi, lo2, hi2), empty pieces
        as lo > hi."""
        lo2 = f64(BIG)
        hi2 = f64(-BIG)
        if a == f64(0.0):
            if b == f64(0.0):
                if c <= f64(0.0):
                    return f64(-BIG), f64(BIG), lo2, hi2
                return f64(BIG), f64(-BIG), lo2, hi2
            t = -c / (f64(2.0) * b)
            if b > f64(0.0):
                return f64(-BIG), t, lo2, hi2
            return t, f64(BIG), lo2, hi2
        found, s1, s2 = roots(a, b, c)
        if a > f64(0.0):
            if found == 0:
                return f64(BIG), f64(-BIG), lo2, hi2
            return s1, s2, lo2, hi2
        if found == 0:  # a < 0 and no roots: negative everywhere
            return f64(-BIG), f64(BIG), lo2, hi2
        return f64(-BIG), s1, s2, f64(BIG)

    @wp.func
    def slab(z0: f64, dz: f64, h: f64):
        """Where |z0 + s dz| <= h: (lo, hi), empty as lo > hi."""
        if dz == f64(0.0):
            if wp.abs(z0) <= h:
                return f64(-BIG), f64(BIG)
            return f64(BIG), f64(-BIG)
        a = (-h - z0) / dz
        b = (h - z0) / dz
        return wp.min(a, b), wp.max(a, b)

    @wp.func
    def cap_normal(dz: f64, entering: int) -> wp.vec3d:
        """The cap a ray along dz enters (entering) or leaves through, outward."""
        up = dz < f64(0.0)
        if entering == 0:
            up = dz > f64(0.0)
        if up:
            return wp.vec3d(f64(0.0), f64(0.0), f64(1.0))
        return wp.vec3d(f64(0.0), f64(0.0), f64(-1.0))

    @wp.func
    def capped(lo: f64, hi: f64, n_in: wp.vec3d, n_out: wp.vec3d, zlo: f64, zhi: f64, dz: f64):
        """A side's interval [lo, hi] cut by the slab's [zlo, zhi]: where the slab bounds it,
        the cap's normal."""
        if zlo > lo:
            lo = zlo
            n_in = cap_normal(dz, 1)
        if zhi < hi:
            hi = zhi
            n_out = cap_normal(dz, 0)
        return lo, hi, n_in, n_out

    @wp.func
    def ball(q0: wp.vec3d, qd: wp.vec3d, centre_z: f64, r: f64):
        """The ball of radius r about (0, 0, centre_z): (entry, exit, n_entry, n_exit)."""
        c = q0 - wp.vec3d(f64(0.0), f64(0.0), centre_z)
        lo, hi, _a, _b = inside_quadratic(wp.dot(qd, qd), wp.dot(c, qd), wp.dot(c, c) - r * r)
        return lo, hi, c + qd * lo, c + qd * hi

    @wp.func
    def cylinder(q0: wp.vec3d, qd: wp.vec3d, r: f64, h: f64):
        lo, hi, _a, _b = inside_quadratic(qd[0] * qd[0] + qd[1] * qd[1], q0[0] * qd[0] + q0[1] * qd[1],
                                          q0[0] * q0[0] + q0[1] * q0[1] - r * r)
        zlo, zhi = slab(q0[2], qd[2], h)
        a = q0 + qd * lo
        b = q0 + qd * hi
        n_in = wp.vec3d(a[0], a[1], f64(0.0))
        n_out = wp.vec3d(b[0], b[1], f64(0.0))
        return capped(lo, hi, n_in, n_out, zlo, zhi, qd[2])

    @wp.func
    def cone_side(q: wp.vec3d, k2: f64, h: f64) -> wp.vec3d:
        n = wp.vec3d(q[0], q[1], k2 * (h - q[2]))
        if wp.length(n) == f64(0.0):  # the apex: the axis
            n = wp.vec3d(f64(0.0), f64(0.0), f64(1.0))
        return n

    @wp.func
    def cone(q0: wp.vec3d, qd: wp.vec3d, r: f64, h: f64):
        k = r / (f64(2.0) * h)
        k2 = k * k
        w = h - q0[2]
        lo, hi, lo2, hi2 = inside_quadratic(qd[0] * qd[0] + qd[1] * qd[1] - k2 * qd[2] * qd[2],
                                            q0[0] * qd[0] + q0[1] * qd[1] + k2 * w * qd[2],
                                            q0[0] * q0[0] + q0[1] * q0[1] - k2 * w * w)
        zlo, zhi = slab(q0[2], qd[2], h)
        # Of the quadric's pieces only the lower nappe's meets the slab (the upper one lies
        # at z > h); near the apex keep the longer overlap.
        a0 = wp.max(lo, zlo)
        a1 = wp.min(hi, zhi)
        b0 = wp.max(lo2, zlo)
        b1 = wp.min(hi2, zhi)
        if b1 - b0 > a1 - a0:
            lo = lo2
            hi = hi2
        n_in = cone_side(q0 + qd * lo, k2, h)
        n_out = cone_side(q0 + qd * hi, k2, h)
        return capped(lo, hi, n_in, n_out, zlo, zhi, qd[2])

    @wp.func
    def capsule(q0: wp.vec3d, qd: wp.vec3d, r: f64, h: f64):
        """The union of the cylinder and the two end balls: a convex solid, so its interval
        is from the earliest entry to the latest exit of the pieces the line meets."""
        lo, hi, n_in, n_out = cylinder(q0, qd, r, h)
        for end in range(2):
            z = h
            if end == 1:
                z = -h
            b_lo, b_hi, b_in, b_out = ball(q0, qd, z, r)
            if b_lo <= b_hi:
                if lo > hi:
                    lo = b_lo
                    hi = b_hi
                    n_in = b_in
                    n_out = b_out
                else:
                    if b_lo < lo:
                        lo = b_lo
                        n_in = b_in
                    if b_hi > hi:
                        hi = b_hi
                        n_out = b_out
        return lo, hi, n_in, n_out

    @wp.func
    def solid_interval(kind: int, q0: wp.vec3d, qd: wp.vec3d, param: wp.vec3d):
        """(entry, exit, outward normal at entry, at exit) of shape ``kind`` (module
        docstring; param = (r, h, -)); entry > exit when the line misses it."""
        if kind == QUADRIC_CYLINDER:
            return cylinder(q0, qd, param[0], param[1])
        if kind == QUADRIC_CONE:
            return cone(q0, qd, param[0], param[1])
        if kind == QUADRIC_CAPSULE:
            return capsule(q0, qd, param[0], param[1])
        return ball(q0, qd, f64(0.0), f64(1.0))

    return solid_interval
