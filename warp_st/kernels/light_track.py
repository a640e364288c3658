"""Animated lights: the emission event on a light's worldline seen from a hit event.

Pure Warp device code (docs/spec.md §3.4). A light's track is its probes (lab times
relative to the render origin, pivots o_j, linear parts M_j = L(t_j)^T), piecewise linear
between them and held before the first and after the last (USD holds the values). A light
point authored at p_rel from the static pivot is at o(t) + M(t) p_rel. Light that reaches
the hit event (t_h, x_h) left that point at the retarded time t_e with
t_h - t_e = |x_h - x(t_e)| (c = 1); g(t) = t_h - t - |x_h - x(t)| decreases along a
subluminal worldline, so the probe interval holding its root is found by bisection and
the root is the smaller root of a quadratic there. With infinite light speed t_e = t_h.
"""
import functools

import warp as wp

__all__ = ["make_light_track"]


@functools.lru_cache(maxsize=None)
def make_light_track(scalar):
    """(Track struct, linear_at, emission_event, emission_velocity) for ``scalar`` (one struct type per scalar:
    the host fills the same ``Track`` the kernels read)."""
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    mat33 = wp.types.matrix((3, 3), scalar)

    @wp.struct
    class Track:
        first: wp.array(dtype=wp.int32)  # per light: its first probe in t/o/m
        count: wp.array(dtype=wp.int32)  # per light: its probe count (0: at rest)
        t: wp.array(dtype=scalar)
        o: wp.array(dtype=vec3)
        m: wp.array(dtype=mat33)  # L(t_j) transposed: a column vector p_rel maps to m p_rel

    @wp.func
    def probe_point(trk: Track, j: int, p_rel: vec3) -> vec3:
        return trk.o[j] + trk.m[j] * p_rel

    @wp.func
    def locate(trk: Track, li: int, t: scalar):
        """(j, f): the probe interval [j, j + 1] of light li holding t and t's fraction of it,
        f clamped to [0, 1] (held outside the probes)."""
        lo = trk.first[li]
        hi = lo + trk.count[li] - 1
        if t <= trk.t[lo]:
            return lo, scalar(0.0)
        if t >= trk.t[hi]:
            return hi - 1, scalar(1.0)
        while hi - lo > 1:
            mid = (lo + hi) / 2
            if trk.t[mid] <= t:
                lo = mid
            else:
                hi = mid
        return lo, (t - trk.t[lo]) / (trk.t[lo + 1] - trk.t[lo])

    @wp.func
    def linear_at(trk: Track, li: int, t: scalar) -> mat33:
        j, f = locate(trk, li, t)
        return trk.m[j] + f * (trk.m[j + 1] - trk.m[j])

    @wp.func
    def point_at(trk: Track, li: int, p_rel: vec3, t: scalar) -> vec3:
        j, f = locate(trk, li, t)
        a = probe_point(trk, j, p_rel)
        return a + f * (probe_point(trk, j + 1, p_rel) - a)

    @wp.func
    def lag(trk: Track, j: int, p_rel: vec3, event: vec4) -> scalar:
        """g(t_j) = t_h - t_j - |x_h - x(t_j)|: >= 0 when probe j is on or inside the past lightcone."""
        x = vec3(event[1], event[2], event[3])
        return event[0] - trk.t[j] - wp.length(x - probe_point(trk, j, p_rel))

    @wp.func
    def emission_event(trk: Track, li: int, p_static: vec3, pivot: vec3, event: vec4, finite: int) -> vec4:
        """(t_e, x_e): where the light point ``p_static`` (as authored, relative to the render
        origin; ``pivot``: the light's static pivot) emitted the light that reaches ``event``."""
        x = vec3(event[1], event[2], event[3])
        if trk.count[li] == 0:
            dt = scalar(0.0)
            if finite != 0:
                dt = wp.length(x - p_static)
            return vec4(event[0] - dt, p_static[0], p_static[1], p_static[2])
        first = trk.first[li]
        p_rel = p_static - pivot
        if finite == 0:
            p = point_at(trk, li, p_rel, event[0])
            return vec4(event[0], p[0], p[1], p[2])
        lo = first
        hi = first + trk.count[li] - 1
        p = probe_point(trk, lo, p_rel)
        t_e = scalar(0.0)
        if lag(trk, lo, p_rel, event) < scalar(0.0):  # before the first probe: held there
            t_e = event[0] - wp.length(x - p)
        elif lag(trk, hi, p_rel, event) >= scalar(0.0):  # after the last: held there
            p = probe_point(trk, hi, p_rel)
            t_e = event[0] - wp.length(x - p)
        else:
            while hi - lo > 1:
                mid = (lo + hi) / 2
                if lag(trk, mid, p_rel, event) >= scalar(0.0):
                    lo = mid
                else:
                    hi = mid
            # |d - V tau| = T - tau, tau in [0, span]: (1 - V.V) tau^2 - 2 q tau + (T^2 - d^2) = 0
            # with q = T - d.V >= 0 and T >= |d|; its smaller root, in the stable form.
            p = probe_point(trk, lo, p_rel)
            span = trk.t[hi] - trk.t[lo]
            vel = (probe_point(trk, hi, p_rel) - p) / span
            d = x - p
            big_t = event[0] - trk.t[lo]
            dl = wp.length(d)
            c = (big_t - dl) * (big_t + dl)
            q = big_t - wp.dot(d, vel)
            a = scalar(1.0) - wp.dot(vel, vel)
            den = q + wp.sqrt(wp.max(q * q - a * c, scalar(0.0)))
            tau = scalar(0.0)
            if den > scalar(0.0):
                tau = wp.clamp(c / den, scalar(0.0), span)
            p = p + tau * vel
            t_e = trk.t[lo] + tau
        return vec4(t_e, p[0], p[1], p[2])

    @wp.func
    def emission_velocity(trk: Track, li: int, p_static: vec3, pivot: vec3, t_e: scalar) -> vec3:
        """The lab velocity of the light point ``p_static`` at lab time ``t_e`` (an emission
        event's): the chord of the probe interval holding t_e, where the worldline is linear;
        0 for a light at rest and where it is held (before the first probe, after the last)."""
        zero = vec3(scalar(0.0))
        if trk.count[li] < 2:
            return zero
        lo = trk.first[li]
        hi = lo + trk.count[li] - 1
        if t_e < trk.t[lo] or t_e > trk.t[hi]:
            return zero
        j, _f = locate(trk, li, t_e)
        p_rel = p_static - pivot
        return (probe_point(trk, j + 1, p_rel) - probe_point(trk, j, p_rel)) / (trk.t[j + 1] - trk.t[j])

    return Track, linear_at, emission_event, emission_velocity
