"""Animated rigid bodies as pieces of uniform motion, within half a pixel (docs/spec.md §2.1).

The reader samples each animated body's worldline through USD (``Body.motion``: probes of
the pivot o(t) and the linear part L(t)). Here each body is cut at probes into pieces;
a piece over [a, b] moves its pivot uniformly along the chord o(a) -> o(b), holds the
orientation of its middle probe and (coupled) the contraction of its chord velocity:
every piece is a uniform-motion body (docs/spec.md §2), so the rest of the renderer (both
tracing paths, shading, Doppler, proper time) takes it as is. The pieces' world-tubes meet
at the pivot.

Error. A body point r (about the pivot, |r| <= R) is modelled at o_p(t) + r G_p and USD puts
it at o(t) + r G(t), G = L A(v) (A the contraction of the instantaneous velocity; I for
decoupled bodies), so the distance is at most |o_p(t) - o(t)| + R |G_p - G(t)|_2, taken at
every probe (probe intervals split evenly where one would not fit, ``_dense_times``:
between probes USD is linear within the reader's PROBE_TOLERANCE). Pieces are grown
greedily while that stays under the tolerance of every probe they hold: ``pixels`` x the
smallest pixel angle x the nearest distance at which any camera can see the body near that
probe (its pivot's distance minus R) / the camera's angular magnification (``adaptive``'s
rule for spheres). Pieces overlap in time at their seams (``_body_cuts``).

Clipping. The probes are grouped into chunks (``motion_chunks``), each cut from its own
start, and only the chunks some frame can reach (``spacetime.reach``) are cut: the pieces
of a chunk are the same whichever others are, so clipping changes no image.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.core.lorentz import contraction_matrix
from warp_st.core.motion import velocity_gradient
from warp_st.core.scene import Body, Scene
from warp_st.spacetime.adaptive import _camera_stretch, min_pixel_angle
from warp_st.spacetime.turning import is_worldlines, worldline_bodies, worldline_body, worldline_count, worldline_cuts

__all__ = ["animation_cuts", "animated_bodies", "piece_bodies", "piece_count", "body_radius", "motion_chunks",
           "FLOOR_FRACTION"]

#: Where no bound applies (a camera inside the body's reach, a decoupled body at >= c) the
#: tolerance is this fraction of the body's radius about its pivot.
FLOOR_FRACTION = 1.0e-4


def body_radius(body: Body) -> float:
    """The largest distance of a body point from its pivot at the start time code, R."""
    if body.motion is None or not body.surfaces:
        return 0.0
    pts = np.concatenate([np.asarray(s.points, dtype=np.float64) for s in body.surfaces])
    return float(np.linalg.norm(pts - body.motion.static_pivot, axis=1).max()) if len(pts) else 0.0


def _contractions(v: np.ndarray, decoupled: bool) -> np.ndarray:
    """A(v) per row of ``v``, (K, 3, 3)."""
    eye = np.broadcast_to(np.eye(3), (len(v), 3, 3)).copy()
    if decoupled:
        return eye
    speed = np.linalg.norm(v, axis=1)
    vhat = np.divide(v, speed[:, None], out=np.zeros_like(v), where=speed[:, None] > 0.0)
    k = 1.0 - np.sqrt(np.clip(1.0 - speed * speed, 0.0, None))
    return eye - k[:, None, None] * vhat[:, :, None] * vhat[:, None, :]


def _tolerances(body: Body, radius: float, cameras, angle: float, pixels: float) -> np.ndarray:
    """The distance tolerance at each probe of ``body`` (see the module docstring)."""
    m = body.motion
    floor = FLOOR_FRACTION * max(radius, 1e-12)
    stretch = 1.0
    if body.decoupled:
        speed = float(np.linalg.norm(m.chord_velocities(), axis=1).max())
        stretch = np.inf if speed >= 1.0 else 1.0 / np.sqrt(1.0 - speed * speed)
    tol = np.full(len(m.times), np.inf)
    for cam in cameras:
        s = stretch * _camera_stretch(cam)
        d = np.linalg.norm(m.pivot - np.asarray(cam.position, dtype=np.float64), axis=1) - radius
        tol = np.minimum(tol, np.where(d > 0.0, pixels * angle * d / s if np.isfinite(s) else 0.0, 0.0))
    return np.maximum(tol, floor)


def _dense_times(body: Body, tol: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The probes' times with each probe interval split evenly until the orientation and
    contraction change across one part costs at most half the tolerance (so one part is
    always a piece that fits), and the tolerance at each time (its interval's smaller)."""
    m = body.motion
    g = m.linear @ _contractions(np.vstack([m.chord_velocities(), m.chord_velocities()[-1:]]), body.decoupled)
    change = radius * np.linalg.norm(np.diff(g, axis=0), ord=2, axis=(1, 2))
    t_tol = np.minimum(tol[:-1], tol[1:])
    parts = np.clip(np.ceil(2.0 * change / t_tol), 1, MAX_PARTS).astype(np.int64)
    times = [m.times[:1]]
    tols = [tol[:1]]
    for k, n in enumerate(parts):
        part = m.times[k] + (m.times[k + 1] - m.times[k]) * np.arange(1, n + 1) / n
        part[-1] = m.times[k + 1]  # the probes' own times stay among them (``_body_cuts``' chunks)
        times.append(part)
        tols.append(np.full(n, t_tol[k]))
    return np.concatenate(times), np.concatenate(tols)


#: Most parts one probe interval is split into for the cutting (a tolerance far below the
#: probes' spacing: a camera almost inside the body's reach).
MAX_PARTS = 64


#: Most chunks a body's probes are grouped into, and the longest chunk in lab time in
#: units of the body's radius R about its pivot (``motion_chunks``).
MAX_CHUNKS = 256
CHUNK_RADII = 4.0


def motion_chunks(body: Body, radius: float) -> np.ndarray:
    """Indices of the probes that bound ``body``'s chunks, increasing from 0 to the last:
    consecutive probe intervals grouped while a chunk lasts at most max(CHUNK_RADII x R, the
    probes' span / MAX_CHUNKS) (one interval at least). The cutting restarts at every
    chunk's start and a chunk is cut only where the frames can reach it
    (``spacetime.reach``): a chunk's pieces do not depend on which other chunks are cut.
    A frame reaches a body over about its light-crossing time 2 R at least, so chunks of a
    few R lose little of the clipping; each restart costs at most one piece."""
    t = body.motion.times
    length = max(CHUNK_RADII * radius, (t[-1] - t[0]) / MAX_CHUNKS)
    bounds, first = [0], t[0]
    for k in range(1, len(t) - 1):
        if t[k + 1] - first > length:
            bounds.append(k)
            first = t[k]
    bounds.append(len(t) - 1)
    return np.array(bounds, dtype=np.int64)


def _cut_arrays(body: Body, t: np.ndarray):
    """What ``_body_cuts``' error bound reads at the dense times ``t``."""
    p, lin = body.motion.at(t)
    turn = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(lin, axis=0), ord=2, axis=(1, 2)))])
    scale = np.linalg.norm(lin, ord=2, axis=(1, 2))
    vel = np.diff(p, axis=0) / np.diff(t)[:, None]
    # The contraction changes only where the pivot's velocity does (never at rest or uniform).
    moving = not body.decoupled and bool(np.ptp(vel, axis=0).max() > 0.0)
    return p, turn, scale, _contractions(vel, body.decoupled), moving


def _body_cuts(body: Body, tol: np.ndarray, radius: float, keep=None) -> tuple[tuple[float, float, float], ...]:
    """(cut time, start time, orientation time) per piece of ``body`` (the first row only
    opens the first piece): a piece moves along the chord between its cut and the next,
    exists from its start (<= its cut) and holds the orientation of the probe at its
    orientation time (its middle probe). ``keep``: per chunk (``motion_chunks``), whether
    to cut it (None: all); the chunks not cut get no pieces, one row each run of them with
    an infinite orientation time (a gap: no body between the previous row's cut and its
    own; not NaN, so that equal cuts are equal keys of ``database_cache``).

    Error bound of a piece [k, j] at each (densified) probe m it holds (module docstring):
    |o(t_m) - chord(t_m)| + R (|L_m - L_mid|_2 + s_m |A(v_chord) - A(v_m)|_F), s_m the
    largest singular value of L_m, and |L_m - L_mid|_2 at most the sum of the probe-to-probe
    changes between them (no matrix norm per query). Pieces are grown within half the
    tolerance, then each is extended back in time over its predecessor while it stays within
    the whole tolerance: where two pieces' surfaces differ at a seam, a ray crossing the seam
    between them would otherwise enter the earlier one through its cap (no surface) and see
    its far side; in the overlap it meets the later one's surface first. Each chunk is
    cut from its own start, its bound read from arrays over it and the chunk before (the
    extension back), so a chunk's rows are the same whichever chunks are kept."""
    t_all, tol_all = _dense_times(body, 0.5 * tol, radius)
    tol_all = 2.0 * tol_all
    chunks = motion_chunks(body, radius)
    # dense index of each probe: the probe times are among the dense times
    dense = np.searchsorted(t_all, body.motion.times[chunks])
    dense[-1] = len(t_all) - 1
    keep = np.ones(len(chunks) - 1, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    rows = [(float(t_all[0]),) * 3]
    last = None  # (first index, cut index) of the previous chunk's last piece, global
    for q in range(len(chunks) - 1):
        if not keep[q]:
            gap = (float(t_all[dense[q + 1]]),) * 2 + (np.inf,)
            rows[-1:] = [gap] if np.isinf(rows[-1][2]) else [rows[-1], gap]
            last = None
            continue
        base = dense[q - 1] if q > 0 else dense[0]  # the arrays hold the chunk before too
        t, tol = t_all[base:dense[q + 1] + 1], tol_all[base:dense[q + 1] + 1]
        p, turn, scale, a, moving = _cut_arrays(body, t)

        def errors(k: int, j: int, lo: int, hi: int) -> np.ndarray:
            """Bound per probe in [lo, hi] of the piece [k, j] (lo <= k < j; hi <= j)."""
            c = (k + j) // 2
            v = (p[j] - p[k]) / (t[j] - t[k])
            dev = np.linalg.norm(p[lo:hi + 1] - (p[k] + v * (t[lo:hi + 1] - t[k])[:, None]), axis=1)
            rot = np.abs(turn[lo:hi + 1] - turn[c])
            if moving:  # the contraction of either interval in [lo, hi] the probe ends
                da = np.linalg.norm(a[lo:hi] - contraction_matrix(v, False), axis=(1, 2))
                probes = np.arange(hi - lo + 1)
                left, right = np.maximum(probes - 1, 0), np.minimum(probes, hi - lo - 1)
                rot = rot + scale[lo:hi + 1] * np.maximum(da[left], da[right])
            return dev + radius * rot

        n = len(t)
        k = dense[q] - base
        cuts = [k]
        while k < n - 1:
            def fits(j):
                return bool((errors(k, j, k, j) <= 0.5 * tol[k:j + 1]).all())
            lo, step = k + 1, 1  # lo always fits (a single part is the finest piece)
            while lo + step <= n - 1 and fits(lo + step):
                lo += step
                step *= 2
            hi = min(lo + step, n)  # first known not to fit (or past the end)
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if fits(mid):
                    lo = mid
                else:
                    hi = mid
            cuts.append(lo)
            k = lo
        prevs = [None if last is None else last[0] - base] + cuts[:-2]
        for prev, k, j in zip(prevs, cuts[:-1], cuts[1:]):
            start = k
            if prev is not None:  # extend back over the previous piece while within the whole tolerance
                bad = np.nonzero(errors(k, j, prev, k) > tol[prev:k + 1])[0]
                start = min(prev + (int(bad[-1]) + 1 if bad.size else 0), k)
            rows.append((float(t[j]), float(t[start]), float(t[(k + j) // 2])))
        last = (cuts[-2] + base, cuts[-1] + base)
    return tuple(rows)


def piece_count(cuts) -> int:
    """How many pieces ``_body_cuts``' rows ``cuts`` make: one per row after the first that
    is not a gap, and the two held ends; for ``turning.worldline_cuts``, the sample intervals."""
    if is_worldlines(cuts):
        return worldline_count(cuts)
    return sum(1 for row in cuts[1:] if not np.isinf(row[2])) + 2


def animation_cuts(scene: Scene, cameras, *, width: int, height: int, pixels: float = 0.5, reach=None,
                   worldlines: bool = False) -> tuple:
    """((body index, cut times), ...) for every animated body of ``scene`` (empty: none),
    the pieces within ``pixels`` pixels for every camera state of ``cameras``. ``reach``:
    ``reach(scene, margins) -> {body index: per chunk, whether the frames reach it}``
    (``spacetime.reach.motion_reach``; margins: per body index, how far its pieces may
    stray from each of its probes); None: every chunk is cut. ``worldlines``: turning
    bodies (``turning.worldline_body``) get ``turning.worldline_cuts`` instead (the
    tetrahedral path's per-vertex worldlines, over the chunks ``reach`` keeps)."""
    cameras = list(cameras)
    animated = [i for i, b in enumerate(scene.bodies) if b.motion is not None and b.surfaces]
    if not animated:
        return ()
    angle = min((min_pixel_angle(c, width, height) for c in cameras), default=np.inf)
    radii = {i: body_radius(scene.bodies[i]) for i in animated}
    tols = {i: _tolerances(scene.bodies[i], radii[i], cameras, angle, pixels) for i in animated}
    kept = reach(scene, tols) if reach is not None and cameras else {}
    return tuple((i, worldline_cuts(scene.bodies[i], tols[i], radii[i], motion_chunks(scene.bodies[i], radii[i]),
                                    kept.get(i)) if worldlines and worldline_body(scene.bodies[i])
                  else _body_cuts(scene.bodies[i], tols[i], radii[i], kept.get(i))) for i in animated)


def _moved(surface, linear: np.ndarray, shift: np.ndarray):
    """``surface`` under p -> p @ linear + shift (normals by the inverse transpose)."""
    points = np.asarray(surface.points, dtype=np.float64) @ linear + shift
    normals = surface.normals
    if normals is not None:
        n = np.asarray(normals, dtype=np.float64) @ np.linalg.inv(linear).T
        normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    move = np.eye(4)
    move[:3, :3], move[3, :3] = linear, shift
    sphere, quadric = surface.sphere, surface.quadric  # the analytic shapes move with the points
    if sphere is not None:
        sphere = (sphere[0], np.asarray(sphere[1], dtype=np.float64).reshape(4, 4) @ move)
    if quadric is not None:
        quadric = (*quadric[:4], np.asarray(quadric[4], dtype=np.float64).reshape(4, 4) @ move)
    return dataclasses.replace(surface, points=points, normals=normals, sphere=sphere, quadric=quadric)


def piece_bodies(body: Body, cuts: tuple[tuple[float, float, float], ...]) -> list[Body]:
    """``body``'s pieces of uniform motion: held before the first probe, one per row after
    the first of ``_body_cuts`` (a piece moves from the previous row's cut to its own,
    exists from its start, holds the orientation at its orientation time), held after the
    last; cut to the body's lifetime.

    A row with an infinite orientation time is a gap (``_body_cuts``' chunks the frames cannot
    reach): no piece from the previous row's cut to its own.

    Proper time: a coupled piece's reference event is put on its worldline where the
    integral of dt / gamma from ``body.reference_time`` along the probes (``_proper_times``)
    would be 0, so §2's tau = gamma ((t - t_ref) - v.(x - o)) takes that integral's value
    at the piece's anchor (the start of its chord), whichever pieces are cut."""
    m = body.motion
    rows = np.array(cuts, dtype=np.float64).reshape(-1, 3)
    times = rows[:, 0]
    gap = np.isinf(rows[1:, 2])
    p, _ = m.at(times)
    _, mid = m.at(np.where(gap, times[1:], rows[1:, 2]))
    spans = [(-np.inf, times[0], times[0], p[0], m.hold_velocity, m.linear[0])]
    spins = [None]
    for k in np.nonzero(~gap)[0]:
        a, b = times[k], times[k + 1]
        spans.append((rows[k + 1, 1], b, a, p[k], (p[k + 1] - p[k]) / (b - a), mid[k]))
        spins.append(_spin(m, rows[k + 1, 2], spans[-1][4], body.decoupled))
    spans.append((times[-1], np.inf, times[-1], p[-1], m.hold_velocity, m.linear[-1]))
    spins.append(None)
    inv_gamma = [1.0 if body.decoupled else float(np.sqrt(max(1.0 - float(v @ v), 0.0))) for *_, v, _l in spans]
    t_ref = body.reference_time
    # proper time at each span's anchor (its chord's start, the first span's end)
    taus = _proper_times(m, body.decoupled, [s[2] for s in spans]) - _proper_times(m, body.decoupled, [t_ref])[0]
    seams = _seams(spans, body_radius(body), body.decoupled)
    pieces = []
    life_lo, life_hi = body.lifetime
    for (lo, hi, t_anchor, o_anchor, v, linear), g, tau, spin, seam in zip(spans, inv_gamma, taus, spins, seams):
        lo, hi = max(lo, life_lo), min(hi, life_hi)
        if not lo < hi:
            continue
        ref = t_ref if body.decoupled else t_anchor - tau / g if g > 0.0 else t_anchor
        origin = o_anchor + v * (ref - t_anchor)
        shift = origin - m.static_pivot @ linear
        pieces.append(dataclasses.replace(body, surfaces=tuple(_moved(s, linear, shift) for s in body.surfaces),
                                          origin=origin, velocity=np.asarray(v, dtype=np.float64).copy(),
                                          reference_time=float(ref), lifetime=(float(lo), float(hi)), motion=None,
                                          spin=spin, piece_linear=np.array(linear, dtype=np.float64),
                                          seam=float(seam)))
    return pieces


def _seams(spans, radius: float, decoupled: bool) -> np.ndarray:
    """``Body.seam`` of each span: the largest distance between the surface it models and
    its neighbours' where they overlap in time, bounded by R |G_k - G_k+1|_2 (G = L A(v),
    the pivots meet at the seam) plus the pivots' drift apart over the overlap."""
    if len(spans) < 2:
        return np.zeros(len(spans))
    v = np.array([sp[4] for sp in spans], dtype=np.float64).reshape(-1, 3)
    g = np.einsum("kij,kjl->kil", np.array([sp[5] for sp in spans], dtype=np.float64), _contractions(v, decoupled))
    overlap = np.array([max(b[2] - b[0], 0.0) if np.isfinite(b[0]) else 0.0 for b in spans[1:]])
    gap = radius * np.linalg.norm(g[1:] - g[:-1], ord=2, axis=(1, 2)) + np.linalg.norm(v[1:] - v[:-1], axis=1) * overlap
    # spans on either side of an uncut gap (spacetime/reach.py) do not meet
    gap = np.where([a[1] >= b[0] for a, b in zip(spans[:-1], spans[1:])], gap, 0.0)
    return np.maximum(np.concatenate([[0.0], gap]), np.concatenate([gap, [0.0]]))


def _proper_times(m, decoupled: bool, t) -> np.ndarray:
    """F(t) = integral of dt / gamma from the first probe along the probes' chords (held
    velocity outside them), at the lab times ``t``."""
    t = np.asarray(t, dtype=np.float64)
    speed2 = np.einsum("ij,ij->i", *(m.chord_velocities(),) * 2)
    g = np.ones_like(speed2) if decoupled else np.sqrt(np.clip(1.0 - speed2, 0.0, None))
    f = np.concatenate([[0.0], np.cumsum(g * np.diff(m.times))])
    hold = 1.0 if decoupled else float(np.sqrt(max(1.0 - float(m.hold_velocity @ m.hold_velocity), 0.0)))
    inside = np.interp(t, m.times, f)
    return np.where(t < m.times[0], (t - m.times[0]) * hold,
                    np.where(t > m.times[-1], f[-1] + (t - m.times[-1]) * hold, inside))


def _spin(m, t_o: float, velocity: np.ndarray, decoupled: bool):
    """A piece's ``Body.spin`` (``core.motion.velocity_gradient``), None when it does not
    turn: L and its rate at the middle of the probe interval holding the piece's orientation
    time t_o, (L_k + L_k+1) / 2 and (L_k+1 - L_k) / dt. For rotation about a fixed axis by
    2 delta over the interval that is omega x (x - o) times tan(delta) / delta (within
    delta^2 / 3, ~1e-5 at the probes' spacing), whatever orientation the piece holds."""
    k = int(np.clip(np.searchsorted(m.times, t_o, side="right") - 1, 0, len(m.times) - 2))
    rate = (m.linear[k + 1] - m.linear[k]) / (m.times[k + 1] - m.times[k])
    middle = 0.5 * (m.linear[k] + m.linear[k + 1])
    return velocity_gradient(middle, rate, velocity, decoupled) if np.any(rate) else None


def _held_ends(body: Body):
    """(before, after): ``body``'s pieces holding its first probe's pose before it and its
    last's after it (None where its lifetime has none)."""
    t = body.motion.times
    pieces = piece_bodies(body, ((float(t[0]),) * 3, (float(t[-1]), float(t[-1]), np.inf)))
    return (next((p for p in pieces if p.lifetime[1] <= t[0]), None),
            next((p for p in pieces if p.lifetime[0] >= t[-1]), None))


def animated_bodies(scene: Scene, cuts: tuple) -> tuple[tuple[Body, ...], np.ndarray]:
    """The bodies of ``scene`` with every animated one replaced by its pieces (in place,
    stage order kept) and each new body's index in ``scene.bodies``, (B',) int32."""
    chosen = dict(cuts)
    bodies, object_of = [], []
    for i, body in enumerate(scene.bodies):
        if i not in chosen:
            parts = [body]
        elif is_worldlines(chosen[i]):
            parts = worldline_bodies(body, chosen[i], lambda: _held_ends(body))
        else:
            parts = piece_bodies(body, chosen[i])
        bodies.extend(parts)
        object_of.extend([i] * len(parts))
    return tuple(bodies), np.array(object_of, dtype=np.int32)


def animation_report(scene: Scene, cameras, *, width: int, height: int, reach=None,
                     worldlines: bool = False) -> list[tuple[str, str]]:
    """(body prim path, one line) per animated body: its USD samples, its pivot's speed
    range and the pieces (or per-vertex worldline samples) it is rendered as for
    ``cameras`` at ``width`` x ``height`` (``reach``, ``worldlines``: as for ``animation_cuts``)."""
    cuts = dict(animation_cuts(scene, cameras, width=width, height=height, reach=reach,
                               worldlines=worldlines)) if cameras else {}
    lines = []
    for i, body in enumerate(scene.bodies):
        m = body.motion
        if m is None:
            continue
        speeds = np.linalg.norm(m.chord_velocities(), axis=1)
        turn = np.linalg.norm(np.diff(m.linear, axis=0), ord=2, axis=(1, 2)) / np.diff(m.times)
        fastest = float((speeds + body_radius(body) * turn).max())  # no body point moves faster
        samples = m.sample_times
        text = (f"animated: {len(samples)} time samples ({samples[0]:g} to {samples[-1]:g}), pivot speed "
                f"{float(speeds.min()):.4g} to {float(speeds.max()):.4g} c, body points up to {fastest:.4g} c"
                f" ({'Lorentz-decoupled' if body.decoupled else 'coupled'})")
        if i in cuts and is_worldlines(cuts[i]):
            text += (f"; per-vertex worldlines, {worldline_count(cuts[i])} sample intervals at {width} x {height}"
                     f" (tetrahedral path)")
        elif i in cuts:
            text += f"; {piece_count(cuts[i])} motion segments at {width} x {height}"
        lines.append((body.prim_path, text))
    return lines
