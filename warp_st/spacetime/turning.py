"""Turning rigid bodies as per-vertex worldlines: watertight by construction (docs/spec.md §2.1, 0.8.0).

A rigidly animated body cut into pieces of uniform motion (``spacetime.animation``) holds
one orientation per piece, so where the orientation steps between pieces a primary ray can
slip between them (the spinning rod's seam holes). Here a turning body instead becomes a
deforming body (docs/spec.md §2.2): each vertex i moves linearly between common sample
times s_k, x_i(s_k) = o(s_k) + (p_i - o(t_s)) L(s_k) (``core.motion.BodyMotion``), so its
world-tube is continuous (the tetrahedra between slices share their faces) and the
existing tetrahedral path traces it, with point velocities for Doppler and shading.

Which bodies (``worldline_body``): an animated body whose linear part L changes (it turns
or scales), without a UsdGeom.Sphere, not a lone analytic surface (a lone Cylinder, Cone or
Capsule is the rigid path's exact shape; those beside meshes, never exact, are traced as their
triangles: the rolling wheel's tyre), and
Lorentz-decoupled, or with its pivot at rest over all its probes and held motion, or coupled
on a moving pivot below c. Decoupled or at rest, A(v) = I at every time, so x_i above is
USD's world-tube exactly (no choice of v at a sample), and proper time is unchanged: t - t_ref
(decoupled, or a pivot at rest: §2.1's integral of dt / gamma with gamma = 1).

A Sphere keeps its pieces: the pieces re-tessellate it per frame within half a pixel
(``adaptive``; at least the reader's 64 segments, ~4,000 triangles) and turning does not
change its shape, while as worldlines its triangles would be extruded at about every probe
(the velocity rule binds for fast bodies): circular_orbit's coupled moon (a Sphere and a
Cube) took over 6 GB for one frame's tetrahedra.

Coupled on a moving pivot (Unreleased; ``moving_pivot``): x_i(s_k) = o(s_k) + r_i G(s_k),
G = L A(v(s_k)) (``sample_shapes``), v(s_k) the mean of the probes' chord velocities on
both sides of the probe (the inside one at the first and last: ``probe_velocities``): for
uniform motion that is §2's tube exactly, and the tetrahedra between slices keep the tube
continuous whatever the choice. Its held ends are always ``animation``'s held pieces. Its
proper time is its pivot's, ``pivot_clock`` (``Body.clock``), at every point at the same lab
time: the extrusion stores it per slice vertex and the kernel blends it with the hit's
barycentrics (linear between slices); the sample rule keeps the pivot's 1 / gamma within
TAU_RATE_TOLERANCE of each chord's mean, so that errs by at most 1e-3 x the lab time to the
nearer slice.

Error. Between two samples a and b, vertex i is at the chord of its path, and USD (the
probes' linear interpolation, within PROBE_TOLERANCE of USD) at o(t) + r L(t), |r| <= R:
the distance is at most |o(t) - chord_o(t)| + R |L(t) - chord_L(t)|_2, both piecewise
linear in t between probes, so largest at a probe: checked at every probe between a and b
(``worldline_times``; on a moving pivot with L A_q in probe interval q, at both ends of every
interval: ``_coupled_fits``). For a rotation by theta over [a, b] that is R (1 - cos(theta / 2))
~ R theta^2 / 8 (second order; a held orientation errs by ~ R theta / 2). The samples are
grown greedily while it stays within half the rigid path's tolerance at every probe
(``animation._tolerances``: half a pixel at the nearest distance any camera can see the
body), so the chords are within a quarter pixel; the tetrahedra between slices then add at
most the deforming path's own half pixel (``deform.deform_slices`` splits each sample
interval for that, and only inside the body's visibility windows). The tetrahedral path
shades with each chord's velocity, so the samples also keep every vertex's chord velocity
within VELOCITY_TOLERANCE of the probes' in each probe interval it spans (for fast tips
this rule binds: ~ every probe).

Clipping: only the chunks of the motion the frames reach (``spacetime.reach``) are
sampled, each from its own start; a run of reached chunks is one deforming body living
over its times, the held ends no run meets are ``animation``'s held pieces.

Flat surfaces (no authored normals) get one copy of their corners per triangle, numbered in
the original order (copy k of point i is ordered by (k, i)): the deforming path's per-slice
vertex normals are then each face's own normal (a box stays a box), and every triangle's
corners keep their relative order, so neighbouring prisms still split their shared sides
alike (``extrude._prism_tets``' rule) and the tube stays watertight.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.core.deform import PointSamples
from warp_st.core.scene import Body

__all__ = ["VELOCITY_TOLERANCE", "TAU_RATE_TOLERANCE", "WORLDLINES", "worldline_body", "worldline_times",
           "worldline_cuts", "is_worldlines", "worldline_count", "worldline_bodies", "moving_pivot", "probe_velocities",
           "sample_shapes", "pivot_clock"]

#: The first item of an animated body's cuts (``animation.animation_cuts``) when it is
#: traced as per-vertex worldlines; the sample times follow.
WORLDLINES = "worldlines"


def worldline_body(body: Body) -> bool:
    """Whether ``body`` is traced as per-vertex worldlines (module docstring)."""
    m = body.motion
    if m is None or not body.surfaces:
        return False
    if any(s.samples is not None for s in body.surfaces):
        return False
    if len(body.surfaces) == 1 and body.surfaces[0].quadric is not None:
        return False  # a lone analytic surface: the rigid path's exact quadric, as pieces
    if any(s.sphere is not None for s in body.surfaces):
        return False  # a Sphere: its pieces' adaptive tessellation (module docstring)
    if not np.ptp(np.asarray(m.linear, dtype=np.float64), axis=0).max() > 0.0:
        return False
    if body.decoupled or not moving_pivot(body):
        return True
    return bool(np.linalg.norm(m.chord_velocities(), axis=1).max() < 1.0)  # the reader refuses >= c


def moving_pivot(body: Body) -> bool:
    """Whether ``body`` (animated) is coupled with a pivot not at rest over all its probes
    and its held motion: its worldlines then carry A(v(s_k)) and its pivot's proper time."""
    m = body.motion
    return not body.decoupled and (bool(np.ptp(m.pivot, axis=0).max() > 0.0)
                                   or bool(np.any(np.asarray(m.hold_velocity) != 0.0)))


def probe_velocities(m) -> np.ndarray:
    """The pivot's velocity taken at each probe, (N, 3): the mean of its chord velocities on
    both sides (the one side at the first and last probe). Where USD's velocity is
    continuous the two sides differ by the probes' spacing x the acceleration; where it
    jumps (a sample of a piecewise-linear path) this is the documented choice; for uniform
    motion it is v exactly (docs/spec.md §2.1)."""
    v = m.chord_velocities()
    out = np.empty((len(v) + 1, 3))
    out[0], out[-1] = v[0], v[-1]
    out[1:-1] = 0.5 * (v[:-1] + v[1:])
    return out


def contractions(v: np.ndarray) -> np.ndarray:
    """A(v) per row of ``v`` (|v| < 1), (K, 3, 3): I - (1 - 1/gamma) v^ v^T."""
    speed = np.linalg.norm(v, axis=1)
    vhat = np.divide(v, speed[:, None], out=np.zeros_like(v), where=speed[:, None] > 0.0)
    k = 1.0 - np.sqrt(np.clip(1.0 - speed * speed, 0.0, None))
    return np.eye(3)[None] - k[:, None, None] * vhat[:, :, None] * vhat[:, None, :]


def sample_shapes(m) -> np.ndarray:
    """G(s) = L(s) A(v(s)) at every probe (``probe_velocities``), (N, 3, 3): a body point r
    (about the static pivot) is at o(s) + r G(s) (row vectors; A symmetric)."""
    return np.einsum("kij,kjl->kil", m.linear, contractions(probe_velocities(m)))


def pivot_clock(body: Body) -> tuple[np.ndarray, np.ndarray]:
    """(times, tau): the pivot's proper time, the integral of dt / gamma from
    ``body.reference_time`` along the probes' chords (``animation._proper_times``' rule),
    at the probe times; piecewise linear between them (gamma is constant on a chord), with
    the held velocity's slope outside."""
    m = body.motion
    speed2 = np.einsum("ij,ij->i", *(m.chord_velocities(),) * 2)
    f = np.concatenate([[0.0], np.cumsum(np.sqrt(np.clip(1.0 - speed2, 0.0, None)) * np.diff(m.times))])
    t_ref = float(body.reference_time)
    hold = float(np.sqrt(max(1.0 - float(m.hold_velocity @ m.hold_velocity), 0.0)))
    if t_ref < m.times[0]:
        f0 = (t_ref - m.times[0]) * hold
    elif t_ref > m.times[-1]:
        f0 = f[-1] + (t_ref - m.times[-1]) * hold
    else:
        f0 = float(np.interp(t_ref, m.times, f))
    return np.array(m.times, dtype=np.float64), f - f0


#: Largest difference (c) between a vertex's velocity on its chord (what the tetrahedral
#: path shades with: Doppler, the light's side) and USD's (the probes') in every probe
#: interval the chord spans: R |chord rate of L - L'| + |chord velocity - o'|. For a
#: rotation by theta over the chord at tip speed w R it is ~ w R theta / 2; 2e-3 c moves
#: the Doppler factor by ~2e-3 at most, half a step of an 8-bit colour channel.
VELOCITY_TOLERANCE = 2.0e-3

#: Largest difference between the pivot's 1 / gamma in any probe interval a chord of a
#: coupled body on a moving pivot spans and the chord's mean (the slope of its proper time
#: over the chord): the kernel interpolates proper time linearly between slices, so it errs
#: by at most 2 x this x min(t - s_k, s_k+1 - t) <= 1e-3 of the time from the nearer slice.
TAU_RATE_TOLERANCE = 5.0e-4


def worldline_times(body: Body, tol: np.ndarray, radius: float, first: int = 0, last: int | None = None) -> np.ndarray:
    """Sample times among ``body.motion``'s probe times from probe ``first`` to ``last``
    (None: the last probe), increasing: greedily the longest chords whose bound (module
    docstring) stays within ``tol`` (per probe) at every probe they span and whose vertex
    velocities stay within VELOCITY_TOLERANCE of the probes' in every interval they span
    (and, coupled on a moving pivot, whose proper time's slope within TAU_RATE_TOLERANCE)."""
    m = body.motion
    t, o, lin = m.times, m.pivot, m.linear
    n = len(t) if last is None else last + 1

    rate = np.diff(lin, axis=0) / np.diff(t)[:, None, None]  # L' and o' per probe interval
    vel = np.diff(o, axis=0) / np.diff(t)[:, None]
    if moving_pivot(body):
        return t[_greedy(_coupled_fits(body, tol, radius), first, n)]

    def fits(k: int, j: int) -> bool:
        f = ((t[k:j + 1] - t[k]) / (t[j] - t[k]))[:, None]
        dev = np.linalg.norm(o[k:j + 1] - (o[k] + f * (o[j] - o[k])), axis=1)
        turn = np.linalg.norm(lin[k:j + 1] - (lin[k] + f[:, :, None] * (lin[j] - lin[k])), ord=2, axis=(1, 2))
        if not (dev + radius * turn <= tol[k:j + 1]).all():
            return False
        dv = np.linalg.norm(vel[k:j] - (o[j] - o[k]) / (t[j] - t[k]), axis=1)
        dw = np.linalg.norm(rate[k:j] - (lin[j] - lin[k]) / (t[j] - t[k]), ord=2, axis=(1, 2))
        return bool((dv + radius * dw <= VELOCITY_TOLERANCE).all())

    return t[_greedy(fits, first, n)]


def _greedy(fits, first: int, n: int) -> list:
    """Probe indices from ``first`` to n - 1: each chord the longest that ``fits(k, j)``
    (exponential, then binary search; one probe interval always fits)."""
    out, k = [first], first
    while k < n - 1:
        lo, step = k + 1, 1  # one probe interval always fits: the probes' own chord
        while lo + step <= n - 1 and fits(k, lo + step):
            lo += step
            step *= 2
        hi = min(lo + step, n)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if fits(k, mid):
                lo = mid
            else:
                hi = mid
        out.append(lo)
        k = lo
    return out


def _coupled_fits(body: Body, tol: np.ndarray, radius: float):
    """``worldline_times``' test of a chord [k, j] for a coupled body on a moving pivot.
    USD's (the probes') body point r is at o(t) + r L(t) A_q in probe interval q (A_q of its
    chord velocity: linear in t there, so its distance from the chord o + r G, G between
    the samples' ``sample_shapes``, is largest at the interval's ends): at both ends of
    every interval spanned, |o - chord_o| + R |L A_q - chord_G|_2 <= tol; the vertices'
    chord velocity within VELOCITY_TOLERANCE of v_q + r L'_q A_q (§2.1's u, the change of A
    left out); the pivot's 1 / gamma_q within TAU_RATE_TOLERANCE of the chord's mean."""
    m = body.motion
    t, o, lin = m.times, m.pivot, m.linear
    dt = np.diff(t)
    vel = m.chord_velocities()
    a_q = contractions(vel)
    left = np.einsum("kij,kjl->kil", lin[:-1], a_q)  # L(t_q) A_q, L(t_q+1) A_q
    right = np.einsum("kij,kjl->kil", lin[1:], a_q)
    rate = np.einsum("kij,kjl->kil", np.diff(lin, axis=0) / dt[:, None, None], a_q)
    g = sample_shapes(m)
    inv_gamma = np.sqrt(np.clip(1.0 - np.einsum("ij,ij->i", vel, vel), 0.0, None))

    def fits(k: int, j: int) -> bool:
        span = t[j] - t[k]
        f = ((t[k:j + 1] - t[k]) / span)[:, None]
        dev = np.linalg.norm(o[k:j + 1] - (o[k] + f * (o[j] - o[k])), axis=1)
        chord = g[k] + f[:, :, None] * (g[j] - g[k])
        lo = np.linalg.norm(left[k:j] - chord[:-1], ord=2, axis=(1, 2))
        hi = np.linalg.norm(right[k:j] - chord[1:], ord=2, axis=(1, 2))
        if not ((dev[:-1] + radius * lo <= tol[k:j]).all() and (dev[1:] + radius * hi <= tol[k + 1:j + 1]).all()):
            return False
        dv = np.linalg.norm(vel[k:j] - (o[j] - o[k]) / span, axis=1)
        dw = np.linalg.norm(rate[k:j] - (g[j] - g[k]) / span, ord=2, axis=(1, 2))
        if not (dv + radius * dw <= VELOCITY_TOLERANCE).all():
            return False
        mean = float(inv_gamma[k:j] @ dt[k:j]) / span
        return bool((np.abs(inv_gamma[k:j] - mean) <= TAU_RATE_TOLERANCE).all())

    return fits


def worldline_cuts(body: Body, tol: np.ndarray, radius: float, chunks: np.ndarray, keep=None) -> tuple:
    """``animation_cuts``' entry of a worldline body: (WORLDLINES, run, ...), a run the
    sample times (``worldline_times``, chords within half the tolerance ``tol``: the
    tetrahedra take the other half) over a maximal run of consecutive chunks (probe
    indices ``chunks``, ``animation.motion_chunks``) that ``keep`` says the frames reach
    (None: all, one run). No run: the frames see only the held ends, if anything. Each
    chunk is sampled from its own start, so its samples are the same whichever chunks are
    kept (the tetrahedra's slices still follow the visibility windows' ends)."""
    keep = np.ones(len(chunks) - 1, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    half = 0.5 * np.asarray(tol, dtype=np.float64)
    runs, q = [], 0
    while q < len(keep):
        if not keep[q]:
            q += 1
            continue
        times = []
        while q < len(keep) and keep[q]:  # each chunk sampled from its own start
            part = worldline_times(body, half, radius, int(chunks[q]), int(chunks[q + 1]))
            times.extend(float(x) for x in part[1 if times else 0:])
            q += 1
        runs.append(tuple(times))
    return (WORLDLINES, *runs)


def is_worldlines(cuts) -> bool:
    """Whether an animated body's cuts are ``worldline_cuts``'."""
    return len(cuts) > 0 and cuts[0] == WORLDLINES


def worldline_count(cuts) -> int:
    """How many sample intervals ``worldline_cuts``' runs hold."""
    return sum(len(run) - 1 for run in cuts[1:])


def _unshared(surface):
    """``surface`` with its corners copied per triangle when it is flat (no normals),
    numbered in (triangle, point) order so that every triangle keeps its corners' order."""
    if surface.normals is not None:
        return surface
    tris = np.asarray(surface.triangles, dtype=np.int64).reshape(-1, 3)
    key = np.arange(len(tris))[:, None] * len(surface.points) + tris
    used, index = np.unique(key.reshape(-1), return_inverse=True)
    points = np.asarray(surface.points, dtype=np.float64)[used % len(surface.points)]
    return dataclasses.replace(surface, points=points, triangles=index.reshape(-1, 3))


def worldline_bodies(body: Body, cuts: tuple, held) -> list[Body]:
    """``body`` as deforming bodies, one per run of ``cuts`` (``worldline_cuts``), each
    living over its run (a run at the first or last probe also over the held motion
    before or after it), its surfaces carrying per-vertex samples at the run's times; and
    the held ends no run covers, ``held()`` -> (before, after) (``animation``'s pieces of
    uniform motion, meeting the runs' first and last poses). The held velocity
    (``spacetime:fourVelocity`` of a decoupled body; zero for a coupled one) stays the
    body's, taken out of the samples, so that outside the probes the points move with it.

    A coupled body on a moving pivot (``moving_pivot``): x_i(s_k) = o(s_k) + r_i G(s_k)
    (``sample_shapes``: A of the pivot's velocity at the probe), no held velocity; each run
    lives over its own times only (the held ends are always the held pieces, §2 with the
    held velocity's contraction), and carries the pivot's proper time (``Body.clock``,
    ``pivot_clock``). Analytic surfaces (a Cylinder beside meshes) are their triangles."""
    m = body.motion
    coupled = moving_pivot(body)
    v = np.zeros(3) if coupled else np.asarray(m.hold_velocity, dtype=np.float64)
    flat = [_unshared(dataclasses.replace(s, sphere=None, quadric=None)) for s in body.surfaces]
    shapes = sample_shapes(m) if coupled else None
    clock = pivot_clock(body) if coupled else None
    out = []
    runs = [np.asarray(run, dtype=np.float64) for run in cuts[1:]]
    for times in runs:
        if coupled:  # the samples are probes: their own G
            pivot, linear = m.pivot[np.searchsorted(m.times, times)], shapes[np.searchsorted(m.times, times)]
        else:
            pivot, linear = m.at(times)
        drift = v * (times - body.reference_time)[:, None]  # deform.points_at adds it back
        surfaces = []
        for s in flat:
            r = np.asarray(s.points, dtype=np.float64) - m.static_pivot
            pts = pivot[:, None, :] - drift[:, None, :] + np.einsum("pj,kjl->kpl", r, linear)
            surfaces.append(dataclasses.replace(s, samples=PointSamples(times=times, points=pts)))
        lo = body.lifetime[0] if times[0] <= m.times[0] and not coupled else max(body.lifetime[0], float(times[0]))
        hi = body.lifetime[1] if times[-1] >= m.times[-1] and not coupled else min(body.lifetime[1], float(times[-1]))
        if lo < hi:
            out.append(dataclasses.replace(body, surfaces=tuple(surfaces), motion=None, velocity=v.copy(), spin=None,
                                           piece_linear=None, seam=0.0, lifetime=(lo, hi), clock=clock))
    before, after = held()
    if not runs or runs[0][0] > m.times[0] or coupled:
        out.insert(0, before)
    if not runs or runs[-1][-1] < m.times[-1] or coupled:
        out.append(after)
    return [b for b in out if b is not None]
