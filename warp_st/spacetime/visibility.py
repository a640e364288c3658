"""Which lab times of each body the requested frames can see.

Unbounded lifetimes must be clipped to a finite window before extrusion. A camera
event (t_c, c) sees a body at lab time t only if some point of the body at t lies on
the past lightcone, i.e. at distance t_c - t from c. With the body inside a ball of
radius rho about m(t) = m0 + v (t - t_ref), that needs

    t_c - rho <= |m(t) - c| + t <= t_c + rho.                          (1)

h(t) = |m(t) - c| + t is convex; for |v| < 1 it is strictly increasing, so (1) is
one interval whose ends solve |w + v tau| = K - tau (a quadratic in tau = t - t_ref).
For |v| >= 1 (decoupled, superluminal) we keep the convex set {h <= t_c + rho}, the
interval between the quadratic's roots. Shadow rays start at hit events, so with
lights the window also covers everything the hit events' shadow rays can reach,
bounded per frame (within a budget) and per piece of each visible body: the swept ball
of each piece over the times the frames see it stands for its hit events
(``body_pieces``, ``_extend_for_shadows``).

The windows are conservative: a wider window only adds exact geometry, so clipping
never changes an image. A body's window is a union of disjoint intervals: frames far
apart in time (a sparse frame list such as 0-1000x100) are grouped apart, each group
bounded on its own, so the database holds what each group sees instead of the whole
span between them.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.deform import deforming, surface_hull_points
from warp_st.core.extent import column_max, column_min, row_squares, shifted, transformed
from warp_st.core.lorentz import contraction_matrix
from warp_st.core.scene import Body, CameraState, Scene, surface_triangles

__all__ = ["body_ball", "body_pieces", "frame_window", "frame_windows", "hull", "intervals", "union", "intersection", "span",
           "visibility_windows"]

#: Cap on how far into the past a window may reach when the bound is unbounded
#: (only for a decoupled body at exactly |v| = 1), in multiples of the scene size.
_UNBOUNDED_REACH = 1e6


def body_ball(body: Body) -> tuple[np.ndarray, float]:
    """Centre m0 (lab, at t_ref) and radius rho of a ball holding the contracted body."""
    pts = [surface_hull_points(s) for s in body.surfaces] or [np.zeros((1, 3))]
    pts = pts[0] if len(pts) == 1 else np.concatenate(pts)
    origin = np.asarray(body.origin, dtype=np.float64)
    local = shifted(transformed(shifted(pts, -origin), contraction_matrix(body.velocity, body.decoupled)), origin)
    m0 = 0.5 * (column_min(local) + column_max(local))
    rho = float(np.sqrt(row_squares(shifted(local, -m0)).max()))
    return m0, rho


#: Most pieces a body's surface is cut into for the shadow windows (``body_pieces``).
_MAX_PIECES = 16


def body_pieces(body: Body) -> list[tuple[np.ndarray, float]]:
    """Balls (m0 in the lab at t_ref, rho) that together hold the contracted body: its
    triangles cut by repeated median splits of the widest piece into up to _MAX_PIECES
    spatial clusters, each ball holding its triangles' vertices (so their whole
    triangles). A body with an analytic sphere (re-tessellated at render time) stays
    one piece, ``body_ball``."""
    return _body_pieces(body, {})


def _body_pieces(body: Body, clusters: dict) -> list[tuple[np.ndarray, float]]:
    """``body_pieces``; the pieces of an animated body (``Body.piece_linear``: turned
    copies of one triangle set) reuse the first one's clusters (``clusters``, by prim
    path and triangle count): any clusters give balls that hold the body."""
    if not body.surfaces or any(s.sphere is not None for s in body.surfaces) or deforming(body):
        return [body_ball(body)]
    A = contraction_matrix(body.velocity, body.decoupled)
    tri = np.concatenate([((s.points - body.origin) @ A.T + body.origin)[surface_triangles(s)] for s in body.surfaces])
    if len(tri) == 0:
        return [body_ball(body)]
    key = (body.prim_path, len(tri))
    if body.piece_linear is None:
        order, starts = _clusters(tri)
    else:
        if key not in clusters:
            clusters[key] = _clusters(tri)
        order, starts = clusters[key]
    pts = tri[order].reshape(-1, 3)
    lo, hi = np.minimum.reduceat(pts, 3 * starts), np.maximum.reduceat(pts, 3 * starts)
    m0 = 0.5 * (lo + hi)
    d2 = ((pts - np.repeat(m0, 3 * np.diff(np.append(starts, len(order))), axis=0)) ** 2).sum(axis=1)
    return [(m, float(r)) for m, r in zip(m0, np.sqrt(np.maximum.reduceat(d2, 3 * starts)))]


def _clusters(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``body_pieces``' clusters of triangles ``tri`` (T, 3, 3): the triangle indices in
    cluster order and each cluster's first position in it."""
    pieces = [np.arange(len(tri))]
    while len(pieces) < _MAX_PIECES:
        extent = [float(np.ptp(tri[p].reshape(-1, 3), axis=0).max()) if len(p) > 1 else 0.0 for p in pieces]
        k = int(np.argmax(extent))
        if extent[k] == 0.0:
            break
        p = pieces.pop(k)
        centre = tri[p].mean(axis=1)
        order = p[np.argsort(centre[:, int(np.argmax(np.ptp(centre, axis=0)))], kind="stable")]
        pieces += [order[: len(order) // 2], order[len(order) // 2:]]
    return np.concatenate(pieces), np.cumsum([0] + [len(p) for p in pieces[:-1]])


def _solve_h(w: np.ndarray, v: np.ndarray, k: float) -> np.ndarray:
    """Roots tau of |w + v tau| = k - tau with k - tau >= 0 (ascending).

    Solved for the lookback u = k - tau >= 0, |w' - v u| = u with w' = w + v k (where the
    body's centre is at tau = k): (|v|^2 - 1) u^2 - 2 (w'.v) u + |w'|^2 = 0. Its
    coefficients are the size of the scene, not of k, so the roots keep their precision at
    any lab time (in tau, c = |w|^2 - k^2 cancels catastrophically once k >> |w|).
    """
    wk = w + v * k
    a = float(v @ v) - 1.0
    b = -2.0 * float(wk @ v)
    c = float(wk @ wk)
    if abs(a) < 1e-15:
        u = np.array([-c / b]) if b != 0.0 else np.zeros(0)
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            return np.zeros(0)
        sq = np.sqrt(disc)
        # Numerically stable pair of roots.
        q = -0.5 * (b + np.copysign(sq, b)) if b != 0.0 else -0.5 * sq
        u = np.array([q / a, c / q]) if q != 0.0 else np.array([0.0])
    tol = 1e-9 * (1.0 + float(np.sqrt(c)))
    return np.sort(k - u[u >= -tol])


def frame_window(m0, rho, v, t_ref, t_c, c, *, infinite=False, extra=0.0):
    """Lab-time interval [lo, hi] in which a body can meet the past lightcone of (t_c, c).

    Returns None when it never can. See the module docstring, equation (1); ``extra``
    lowers its lower bound (light that travelled up to ``extra`` further, via mirrors).
    """
    if infinite:
        pad = max(rho, 1.0)
        return (t_c - pad, t_c + pad)
    v = np.asarray(v, dtype=np.float64)
    w = np.asarray(m0, dtype=np.float64) - np.asarray(c, dtype=np.float64)
    speed = float(np.linalg.norm(v))
    if speed < 1.0:
        lo = _solve_h(w, v, t_c - rho - extra - t_ref)
        hi = _solve_h(w, v, t_c + rho - t_ref)
        lo_t = lo[-1] + t_ref if len(lo) else -np.inf
        hi_t = hi[-1] + t_ref if len(hi) else t_c
        return (float(lo_t), float(min(hi_t, t_c + rho)))
    roots = _solve_h(w, v, t_c + rho - t_ref)
    if speed == 1.0 and len(roots) == 1:
        reach = _UNBOUNDED_REACH * max(1.0, rho + float(np.linalg.norm(w)))
        return (t_c - reach, t_c + rho)
    if len(roots) == 0:
        return None
    return (float(roots[0] + t_ref), float(min(roots[-1] + t_ref, t_c + rho)))


def _largest_root(w, v, vv, k):
    """``_solve_h``'s largest root per row (NaN where none), for rows with |v| < 1; solved,
    as ``_solve_h`` is, for the lookback u = k - tau (the largest tau is the smallest u >= 0)."""
    wk = w + v * k[..., None]
    a = vv - 1.0
    b = -2.0 * (wk[..., 0] * v[..., 0] + wk[..., 1] * v[..., 1] + wk[..., 2] * v[..., 2])
    c = wk[..., 0] ** 2 + wk[..., 1] ** 2 + wk[..., 2] ** 2
    disc = b * b - 4.0 * a * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    q = np.where(b != 0.0, -0.5 * (b + np.copysign(sq, b)), -0.5 * sq)
    with np.errstate(divide="ignore", invalid="ignore"):
        u1 = q / a
        u2 = np.where(q != 0.0, c / q, u1)
    tol = 1e-9 * (1.0 + np.sqrt(c))
    u1 = np.where(u1 >= -tol, u1, np.inf)
    u2 = np.where(u2 >= -tol, u2, np.inf)
    best = np.minimum(u1, u2)
    return np.where((disc >= 0.0) & (best < np.inf), k - best, np.nan)


def frame_windows(m0, rho, v, t_ref, t_c, c, *, infinite=False, extra=0.0):
    """``frame_window`` over rows broadcast together (bodies for one camera, or cameras
    for one body): (lo, hi) arrays, NaN where it returns None."""
    m0, v, c = (np.asarray(x, dtype=np.float64) for x in (m0, v, c))
    rho, t_ref, t_c = (np.asarray(x, dtype=np.float64) for x in (rho, t_ref, t_c))
    n = np.broadcast_shapes(m0.shape[:-1], v.shape[:-1], c.shape[:-1], rho.shape, t_ref.shape, t_c.shape)
    m0, v, c = (np.broadcast_to(x, n + (3,)) for x in (m0, v, c))
    rho, t_ref, t_c = (np.broadcast_to(x, n) for x in (rho, t_ref, t_c))
    if infinite:
        pad = np.maximum(rho, 1.0)
        return t_c - pad, t_c + pad
    w = m0 - c
    vv = v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1] + v[..., 2] * v[..., 2]
    lo = _largest_root(w, v, vv, t_c - rho - extra - t_ref)
    hi = _largest_root(w, v, vv, t_c + rho - t_ref)
    lo = np.where(np.isnan(lo), -np.inf, lo + t_ref)
    hi = np.minimum(np.where(np.isnan(hi), t_c, hi + t_ref), t_c + rho)
    # |v| >= 1 (or within rounding of it): the scalar rule, row by row (rare).
    for i in zip(*np.nonzero((vv >= 1.0) | (np.abs(vv - 1.0) < 1e-12))):
        win = frame_window(m0[i], rho[i], v[i], t_ref[i], t_c[i], c[i], extra=extra)
        lo[i], hi[i] = (np.nan, np.nan) if win is None else win
    return lo, hi


def hull(a, b):
    """The smallest interval holding windows a and b (None: no window)."""
    if a is None:
        return b
    if b is None:
        return a
    return (min(a[0], b[0]), max(a[1], b[1]))


def intervals(window) -> list[tuple[float, float]]:
    """A window as a list of (lo, hi) intervals: None -> [], (lo, hi) -> [(lo, hi)],
    a tuple of intervals -> those."""
    if window is None:
        return []
    if len(window) == 2 and np.ndim(window[0]) == 0:
        return [(float(window[0]), float(window[1]))]
    return [(float(a), float(b)) for a, b in window]


def union(a, b):
    """Union of two windows as a tuple of disjoint ascending intervals (None if empty)."""
    merged: list[list[float]] = []
    for lo, hi in sorted(intervals(a) + intervals(b)):
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return tuple((lo, hi) for lo, hi in merged) or None


def intersection(a, b):
    """Intersection of two windows as a tuple of disjoint ascending intervals (None if
    empty)."""
    out = []
    for lo_a, hi_a in intervals(a):
        for lo_b, hi_b in intervals(b):
            lo, hi = max(lo_a, lo_b), min(hi_a, hi_b)
            if lo <= hi:
                out.append((lo, hi))
    return union(None, tuple(out)) if out else None


def span(window):
    """The smallest single interval holding ``window`` (None if empty)."""
    parts = intervals(window)
    return (min(p[0] for p in parts), max(p[1] for p in parts)) if parts else None


def visibility_windows(scene: Scene, cameras: list[CameraState], *, infinite: bool, max_depth: int = 0,
                       shutter: float = 0.0) -> list:
    """Per body: the lab times the frames (through up to ``max_depth`` mirror reflections
    and, with lights, shadow rays) can see, as a tuple of disjoint intervals.

    Each camera stands for its events from t_c to t_c + ``shutter`` (motion blur): its
    window is the hull of both ends'. Intersected with the body's lifetime; None where
    a body is never visible.
    """
    balls = [body_ball(b) for b in scene.bodies]
    clusters: dict = {}
    pieces = [_body_pieces(b, clusters) for b in scene.bodies] if scene.lights else None
    ends = [[cam, cam.advanced(shutter)] if shutter > 0.0 else [cam] for cam in cameras]
    m0s = np.array([m for m, _ in balls], dtype=np.float64).reshape(-1, 3)
    rhos = np.array([r for _, r in balls], dtype=np.float64)
    vs = np.array([b.velocity for b in scene.bodies], dtype=np.float64).reshape(-1, 3)
    t_refs = np.array([b.reference_time for b in scene.bodies], dtype=np.float64)
    # direct[c, i]: (lo, hi) of body i seen by camera c, NaN where never (hulls: fmin / fmax).
    direct = np.full((len(ends), len(scene.bodies), 2), np.nan)
    for c, cam_ends in enumerate(ends):
        for cam in cam_ends:
            lo, hi = frame_windows(m0s, rhos, vs, t_refs, cam.time, cam.position, infinite=infinite)
            direct[c, :, 0], direct[c, :, 1] = np.fmin(direct[c, :, 0], lo), np.fmax(direct[c, :, 1], hi)
    out = [None] * len(scene.bodies)
    for group in _camera_groups(cameras, direct):
        for part in _extension_parts(scene, group):
            lo, hi = np.fmin.reduce(direct[part, :, 0], axis=0), np.fmax.reduce(direct[part, :, 1], axis=0)
            windows = [None if a != a else (a, b) for a, b in zip(lo.tolist(), hi.tolist())]
            part_cams = [cam for c in part for cam in ends[c]]
            for i, win in enumerate(_extended(scene, balls, pieces, windows, part_cams, infinite, max_depth)):
                out[i] = union(out[i], win)
    return out


#: Largest cameras x bodies x lights for which shadow (and mirror) windows are widened
#: frame by frame rather than once per group of frames.
_PER_FRAME_BUDGET = 20000


def _extension_parts(scene, group) -> list[list[int]]:
    """How a group's windows are widened for shadows and mirrors: frame by frame, or
    all at once. The widening grows with the hit events' span in time and space, and a
    body seen in every frame (a floor) links the group's frames: widened all at once, a
    lit group of frames 100 apart would extrude everything in between. Frame by frame
    each gets what its own hit events can reach (a subset of the group's: the
    widening is monotone), at the cost of one widening per frame; past
    _PER_FRAME_BUDGET the group is widened at once."""
    if len(group) == 1 or not (scene.lights or _mirror_bodies(scene)):
        return [group]
    if len(group) * len(scene.bodies) * max(1, len(scene.lights)) > _PER_FRAME_BUDGET:
        return [group]
    return [[c] for c in group]


def _camera_groups(cameras, direct) -> list[list[int]]:
    """Cameras in time order, split where a frame's windows overlap none of the previous
    group's (no body is visible in both): each group's windows are bounded on their own.
    ``direct``: (cameras, bodies, 2) windows, NaN where none (``visibility_windows``)."""
    order = sorted(range(len(cameras)), key=lambda c: cameras[c].time)
    groups: list[list[int]] = []
    lo = hi = None
    for c in order:
        d_lo, d_hi = direct[c, :, 0], direct[c, :, 1]
        with np.errstate(invalid="ignore"):
            overlap = lo is not None and bool(np.any((d_lo <= hi) & (lo <= d_hi)))
        if overlap:
            groups[-1].append(c)
            lo, hi = np.fmin(lo, d_lo), np.fmax(hi, d_hi)
        else:
            groups.append([c])
            lo, hi = d_lo.copy(), d_hi.copy()
    return groups


def _extended(scene, balls, pieces, windows, cameras, infinite, max_depth) -> list:
    """One group's windows widened for mirrors and shadows, padded, clipped to lifetimes."""
    mirrors = _mirror_bodies(scene)
    extra = 0.0  # how much earlier than directly the frames may see a body, via mirrors
    if mirrors and max_depth > 0 and not infinite and any(w is not None for w in windows):
        extra = 2.0 * max_depth * _mirror_reach(scene, balls, windows, cameras, mirrors)
        if extra > 0.0:
            windows = [_seen(body, m0, rho, win, cameras, infinite, extra)
                       for body, (m0, rho), win in zip(scene.bodies, balls, windows)]

    if scene.lights and any(w is not None for w in windows):
        windows = _extend_for_shadows(scene, balls, pieces, windows, cameras, infinite, extra)

    out = []
    for body, win in zip(scene.bodies, windows):
        parts = None
        for w_lo, w_hi in intervals(win):
            # Rounding room only: float64 keeps 1e-16 relative, so 1e-12 of the absolute
            # time plus 1e-6 of the window's length (a pad of 1e-6 |t| doubled the
            # database at t = 1e6).
            pad = 1e-12 * (1.0 + max(abs(w_lo), abs(w_hi))) + 1e-6 * (w_hi - w_lo)
            lo = max(w_lo - pad, body.lifetime[0])
            hi = min(w_hi + pad, body.lifetime[1])
            if lo < hi:
                parts = union(parts, (float(lo), float(hi)))
        out.append(parts)
    return out


def _mirror_bodies(scene) -> list[int]:
    """Indices of the bodies with a metallic (mirror) surface."""
    return [i for i, b in enumerate(scene.bodies) if any(s.material.metallic > 0.0 for s in b.surfaces)]


def _mirror_reach(scene, balls, windows, cameras, mirrors) -> float:
    """D_M: how far from the cameras the mirrors' visible events lie (0: none visible).

    Light that reached the camera via up to max_depth mirrors travelled a path c -> H1
    -> ... -> Hk -> O at most |O - c| + 2 k D_M long when every mirror event lies
    within D_M of the camera (each leg is bounded through c by the triangle
    inequality), so O is seen at a lab time at most 2 k D_M earlier than its direct
    lightcone crossing: equation (1) with the lower bound lowered by that. D_M is
    measured over the mirrors' directly visible windows. That is exact for mirrors at
    rest; for moving mirrors it assumes the mirror events of deeper bounces stay
    within that reach (re-measuring it after widening compounds geometrically with
    depth: a 0.5c mirror ball at depth 4 needed 17 M tetrahedra).
    """
    reach = 0.0
    for i in mirrors:
        if windows[i] is None:
            continue
        m0, rho = balls[i]
        body = scene.bodies[i]
        for t in windows[i]:
            centre = m0 + body.velocity * (t - body.reference_time)
            for cam in cameras:
                reach = max(reach, float(np.linalg.norm(centre - cam.position)) + rho)
    return reach


def _seen(body, m0, rho, win, cameras, infinite, extra):
    """``win`` widened to every time the cameras can see the ball (m0, rho) of ``body``
    at, through mirrors too (``extra``, see ``_mirror_reach``)."""
    if not cameras:
        return win
    lo, hi = frame_windows(m0, rho, body.velocity, body.reference_time, [cam.time for cam in cameras],
                           [cam.position for cam in cameras], infinite=infinite, extra=extra)
    seen = ~np.isnan(lo)
    return hull(win, (float(lo[seen].min()), float(hi[seen].max()))) if seen.any() else win


def _extend_for_shadows(scene, balls, pieces, windows, cameras, infinite, extra):
    """Widen the windows to cover shadow rays leaving any possible hit event.

    Hit events H on a body B have t_H in B's window [T_lo, T_hi] and x_H in a ball
    (C, R) holding B's swept ball over it. A shadow ray towards a distant light l
    conserves the phase t + x.l along its null line; towards a point light L it lies
    on the future lightcone of the emission event, so psi = t - |x - L| is conserved.
    An occluder is thus reachable only while its phase (or psi) is within the range
    B's hit events produce, and not after T_hi. Both are monotone in t for |v| < 1; a
    body moving at |v| >= 1 keeps the bound of a camera anywhere in the hit ball.

    The bound is taken per piece of each visible body (``body_pieces``: a floor is cut
    into tiles, each seen over a shorter time and sending its shadow rays along a
    narrower beam), over the times the frames see that piece, and per light; the
    occluder's window is the union of those intervals. Past _PAIR_BUDGET piece pairs
    the bound is per visible body, past it again the visible bodies share one ball
    (cheaper, wider).
    """
    hit_bodies = [i for i, w in enumerate(windows) if w is not None]
    pairs = len(scene.bodies) * max(1, len(scene.lights))
    if len(hit_bodies) * pairs > _PAIR_BUDGET:
        bounds = [[_hit_ball(scene, balls, windows, hit_bodies)]]
    else:
        bounds = [[_hit_ball(scene, balls, windows, [i]) for i in hit_bodies]]
        if sum(len(pieces[i]) for i in hit_bodies) * pairs <= _PAIR_BUDGET:
            bounds.append([src for i in hit_bodies
                           for src in _piece_balls(scene.bodies[i], pieces[i], windows[i], cameras, infinite, extra)])
    out = []
    for body, (m0, rho), win in zip(scene.bodies, balls, windows):
        # Each set of sources bounds the occluder's window on its own: keep what all allow.
        reach = None
        for k, sources in enumerate(bounds):
            parts = _occluder_windows(scene, body, m0, rho, sources, infinite)
            reach = parts if k == 0 else intersection(reach, parts)
        out.append(union(win, reach))
    return out


#: Largest (pieces of) visible bodies x bodies x lights for which shadow windows are
#: bounded piece by piece (or body by body).
_PAIR_BUDGET = 20000


def _piece_balls(body, pieces, window, cameras, infinite, extra):
    """``_hit_ball`` of each piece of a visible body over the times the cameras see it
    (within the body's window): (centre, radius, t_lo, t_hi) per piece seen."""
    out = []
    lo, hi = span(window)
    for m0, rho in pieces:
        seen = _seen(body, m0, rho, None, cameras, infinite, extra)
        if seen is None or seen[0] > hi or seen[1] < lo:
            continue
        t_lo, t_hi = max(seen[0], lo), min(seen[1], hi)
        out.append((*_ball_around([(body, m0, rho, (t_lo, t_hi))]), t_lo, t_hi))
    return out


def _hit_ball(scene, balls, windows, bodies):
    """(centre, radius, t_lo, t_hi): a ball holding the swept balls of ``bodies`` over
    their windows, and the windows' time span."""
    centre, radius = _ball_around([(scene.bodies[i], *balls[i], windows[i]) for i in bodies])
    return centre, radius, min(windows[i][0] for i in bodies), max(windows[i][1] for i in bodies)


def _ball_around(swept) -> tuple[np.ndarray, float]:
    """(centre, radius) of a ball holding every ball (m0, rho) of ``body`` swept over
    (t_lo, t_hi), for each (body, m0, rho, (t_lo, t_hi)) of ``swept``: the ball around
    the box of the balls at both ends (the motion is uniform)."""
    lows, highs = [], []
    for body, m0, rho, times in swept:
        for t in times:
            centre = m0 + body.velocity * (t - body.reference_time)
            lows.append(centre - rho)
            highs.append(centre + rho)
    box_lo, box_hi = np.min(lows, axis=0), np.max(highs, axis=0)
    return 0.5 * (box_lo + box_hi), 0.5 * float(np.linalg.norm(box_hi - box_lo))


def _occluder_windows(scene, body, m0, rho, sources, infinite):
    """The lab times in which ``body`` can occlude a shadow ray from a hit event in any
    of ``sources``, balls (hit_centre, hit_radius) of hit events at t in [t_lo, t_hi]
    (all sources and lights at once, as arrays), as a window (None: never)."""
    centre = np.array([src[0] for src in sources], dtype=np.float64).reshape(-1, 3)
    radius, t_lo, t_hi = (np.array([src[i] for src in sources], dtype=np.float64) for i in (1, 2, 3))
    v = np.asarray(body.velocity, dtype=np.float64)
    if infinite:
        return union(None, tuple(zip((t_lo - rho).tolist(), (t_hi + rho).tolist())))
    if float(np.linalg.norm(v)) >= 1.0:
        parts = [frame_window(m0, rho + r, v, body.reference_time, t_c, c)
                 for c, r, lo, hi in zip(centre, radius, t_lo, t_hi) for t_c in (lo, hi)]
        return union(None, tuple(p for p in parts if p is not None))
    t_ref = body.reference_time
    los, his = [], []
    for light in scene.lights:
        if light.kind == "distant" and light.motion is not None:
            # an animated direction (docs/spec.md §3.4): any unit l. A shadow ray back from t_h
            # meets the occluder at t only if t_h - t <= D + |v| |t - t_ref|, D = |C - m0| + R + rho
            speed = float(np.linalg.norm(v))
            d = np.linalg.norm(centre - m0, axis=1) + radius + rho
            lo = np.minimum((t_lo - d - speed * t_ref) / (1.0 - speed), (t_lo - d + speed * t_ref) / (1.0 + speed))
            los.append(lo - 1e-12 * (1.0 + np.abs(lo)))
            his.append(t_hi + rho)
            continue
        if light.kind == "distant":
            # phase t + x(t).l = k is linear in t: t (1 + v.l) = k - m0.l + (v.l) t_ref.
            l = np.asarray(light.direction, dtype=np.float64)
            k_lo = t_lo + centre @ l - radius - rho
            lo = (k_lo - float(m0 @ l) + float(v @ l) * t_ref) / (1.0 + float(v @ l))
            lo -= 1e-12 * (1.0 + np.abs(lo)) / (1.0 + float(v @ l))  # a lower bound past rounding
            axis = np.broadcast_to(l, centre.shape)
        else:
            # shadow rays end within the light's extent e of L: each stays within R + e of
            # the segment C L and leaves no earlier than t - |C - L| - R - e
            L, e = np.asarray(light.position, dtype=np.float64), light.extent
            k_lo = t_lo - np.linalg.norm(centre - L, axis=1) - radius - rho - e
            lo = t_ref + _retarded_roots(m0 - L, v, k_lo - t_ref)
            axis = L - centre
        near_lo, near_hi = _near_axis_windows(m0, v, t_ref, centre, axis,
                                              radius + rho + (0.0 if light.kind == "distant" else light.extent))
        los.append(np.maximum(lo, near_lo))
        his.append(np.minimum(t_hi + rho, near_hi))
    lo, hi = np.concatenate(los), np.concatenate(his)
    keep = lo <= hi  # else the body never comes near those shadow rays in time
    return union(None, tuple(zip(lo[keep].tolist(), hi[keep].tolist())))


def _near_axis_windows(m0, v, t_ref, centre, axis, radius):
    """Lab times (lo, hi) at which a ball moving as m0 + v (t - t_ref) comes within
    ``radius`` of the line through ``centre`` along ``axis``, per row of ``centre``
    (S, 3), ``axis`` (S, 3) and ``radius`` (S,), as arrays; lo > hi: never;
    (-inf, inf): always.

    A shadow ray leaves a hit event within R of the hit ball's centre C towards the
    light: along the light's direction l (distant light), or on the segment to the
    light L, which lies within R of the line C L. Every point of it is thus within R
    of the line through C along l (or towards L), and an occluder of radius rho that
    blocks it comes within R + rho of that line: the squared distance, a quadratic in
    t, is at most (R + rho)^2 between its roots.
    """
    centre = np.atleast_2d(np.asarray(centre, dtype=np.float64))
    axis = np.atleast_2d(np.asarray(axis, dtype=np.float64))
    radius = np.atleast_1d(np.asarray(radius, dtype=np.float64))
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(axis, axis=1)
    free = ~np.isfinite(n) | (n == 0.0)  # the light inside the hit ball: no direction to bound by
    l = np.where(free[:, None], 0.0, axis) / np.where(free, 1.0, n)[:, None]
    d0 = np.asarray(m0, dtype=np.float64) - centre
    p0 = d0 - np.sum(d0 * l, axis=1)[:, None] * l
    pv = v - (l @ v)[:, None] * l
    r2 = radius * radius * (1.0 + 1e-9) + 1e-12
    a, b, c = np.sum(pv * pv, axis=1), 2.0 * np.sum(p0 * pv, axis=1), np.sum(p0 * p0, axis=1) - r2
    disc = b * b - 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        q = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
        ra, rb = np.where(q != 0.0, q / a, 0.0), np.where(q != 0.0, c / q, 0.0)
    lo = np.where(disc < 0.0, np.inf, t_ref + np.minimum(ra, rb))
    hi = np.where(disc < 0.0, -np.inf, t_ref + np.maximum(ra, rb))
    # Moving along the line (or at rest): the distance never changes.
    still = a <= 1e-24
    lo = np.where(still, np.where(c <= 0.0, -np.inf, np.inf), lo)
    hi = np.where(still, np.where(c <= 0.0, np.inf, -np.inf), hi)
    return np.where(free, -np.inf, lo), np.where(free, np.inf, hi)


def _retarded_roots(w: np.ndarray, v: np.ndarray, k) -> np.ndarray:
    """The tau with tau - |w + v tau| = k, per element of ``k`` (|v| < 1: the left side
    strictly increases), as a lower bound past rounding.

    Solved for u = tau - k >= 0: |w' + v u| = u with w' = w + v k, so (|v|^2 - 1) u^2 +
    2 (w'.v) u + |w'|^2 = 0 (coefficients the size of the scene at any lab time; in tau the
    constant |w|^2 - k^2 cancels once k >> |w|), of whose roots the one that best satisfies
    the unsquared equation."""
    k = np.atleast_1d(np.asarray(k, dtype=np.float64))
    w, v = np.asarray(w, dtype=np.float64), np.asarray(v, dtype=np.float64)
    wk = w[None] + k[:, None] * v[None]
    a = float(v @ v) - 1.0
    b = 2.0 * (wk[:, 0] * v[0] + wk[:, 1] * v[1] + wk[:, 2] * v[2])  # row by row: the same sums at any batch size
    c = wk[:, 0] ** 2 + wk[:, 1] ** 2 + wk[:, 2] ** 2
    disc = np.maximum(b * b - 4.0 * a * c, 0.0)  # >= 0 in exact arithmetic
    q = -0.5 * (b + np.copysign(np.sqrt(disc), b))

    def g(u):  # (tau - |w + v tau|) - k at tau = k + u, in the scene's own scale
        return u - np.linalg.norm(wk + u[:, None] * v[None], axis=1)

    with np.errstate(divide="ignore", invalid="ignore"):
        first, second = q / a, np.where(q != 0.0, c / q, q / a)
    u = np.where(np.abs(g(second)) < np.abs(g(first)), second, first)
    # A lower bound is what the window needs: step down past any rounding (near
    # |v| = 1 the slope 1 - |v| is small and the root ill-conditioned) ...
    u = _step_down(u, 1e-12 * (1.0 + np.abs(u) + np.sqrt(c)), lambda u: g(u) > 0.0)

    def high(tau):  # ... and past the rounding of k + u, 4 ulps clear of how |.| is rounded
        dist = np.linalg.norm(w[None] + tau[:, None] * v[None], axis=1)  # (a vector's norm sums
        return tau - dist + 4.0 * np.spacing(np.abs(tau) + dist) > k  # in another order, CPU by CPU)
    return _step_down(k + u, np.spacing(np.abs(k + u)), high)


def _step_down(x: np.ndarray, step: np.ndarray, above) -> np.ndarray:
    """``x`` lowered by ``step``, doubling, where ``above(x)`` holds, until it holds nowhere."""
    high = above(x)
    while high.any():
        x = np.where(high, x - step, x)
        step = step * 2.0
        high = above(x)
    return x
