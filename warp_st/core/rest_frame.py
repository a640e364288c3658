"""Lab worldlines of motion authored in a body's own rest frame (docs/spec.md §2.1, addition 0.7.0).

A body with ``spacetime:animationFrame = "rest"`` moves, as USD animates it, in the frame
S' that moves with its ``spacetime:fourVelocity`` v; S' has its origin at the lab event
(t_ref, o) (``spacetime:referenceTime`` and the pivot o), its time t' is the animation's.
A point at y(t') (relative to o) in S' is at the lab event
(t, x) = (t_ref, o) + Lambda(v) (t', y(t')). At one lab time t each point is at its own
rest time t'_j, the one root of

    t'_j + v.y_j(t'_j) = (t - t_ref) / gamma

(the left side increases: |dy/dt'| < 1 and |v| < 1), and there

    x_j(t) = o + v (t - t_ref) + contract(y_j(t'_j), v)

(substitute t' into the boost). The rest motion is piecewise linear between its samples
(``core.deform.PointSamples``, as USD interpolates, refined by the reader), so each lab
worldline is piecewise linear too, with its knots at the point's own lab times. The
deforming path wants common lab times; :func:`lab_samples` picks them by bisection until
linear interpolation between them is within ``tolerance`` of every point's exact lab
polyline at every knot (where a polyline is farthest from its chord): an exact bound on
the resampling, not a probe.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.deform import PointSamples
from warp_st.core.lorentz import contract, gamma

__all__ = ["REST_LAB_TOLERANCE", "lab_samples", "rest_speeds", "MAX_LAB_ROUNDS"]

#: Largest distance between the resampled lab worldlines and the boosted rest polylines, as
#: a fraction of the body's size (its largest rest extent).
REST_LAB_TOLERANCE = 1.0e-4
#: Bisection rounds of :func:`lab_samples` (each halves every interval still too coarse).
MAX_LAB_ROUNDS = 24


def rest_speeds(rest: PointSamples) -> np.ndarray:
    """Each point's largest chord speed |dy| / dt' over the rest samples' intervals, (N - 1,)
    (the fastest point per interval; rest times in lab units)."""
    dt = np.diff(rest.times)
    dy = np.linalg.norm(np.diff(rest.points, axis=0), axis=2)  # (N-1, P)
    return dy.max(axis=1, initial=0.0) / dt


def lab_samples(rests: list[PointSamples], origin, velocity, reference_time: float, size: float,
                tolerance: float = REST_LAB_TOLERANCE) -> list[PointSamples]:
    """The lab samples of a body's surfaces animated in its rest frame, at common lab times.

    rests: each surface's points in S' at rest times t' (``times``, lab units; t' = 0 at the
        lab event (t_ref, o)) as world positions o + y;
    origin o, velocity v (|v| < 1), reference_time t_ref: S' (docs/spec.md §2);
    size: the body's size; the common lab times follow every point's lab polyline within
        ``tolerance`` x size.
    Returns one ``PointSamples`` per surface, all at the same lab times, points
    o + contract(y(t'_j), v): the lab positions without the uniform motion v (t - t_ref),
    which the deforming path adds (``core.deform.PointSamples``). Before and after the rest
    samples each point is held in S' (USD holds), i.e. moves with v in the lab: the held
    samples stay constant.
    """
    o = np.asarray(origin, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    scale = float(gamma(v))
    knots_t, knots_x = [], []  # per point: its own lab knot times (N,) and positions there (N, 3)
    for rest in rests:
        y = np.asarray(rest.points, dtype=np.float64) - o  # (N, P, 3)
        g = rest.times[:, None] + y @ v  # (t - t_ref) / gamma at each knot, (N, P)
        if not (np.diff(g, axis=0) > 0.0).all():
            raise ValueError("rest-frame motion at or above the speed of light (t' + v.y must increase)")
        x = o + contract(y, v)
        knots_t += list((reference_time + scale * g).T)
        knots_x += list(x.transpose(1, 0, 2))
    tol = tolerance * max(size, 1e-12)

    def at(times: np.ndarray) -> np.ndarray:
        """Every point's lab position (uniform motion left out) at lab ``times``, (M, P, 3)."""
        return np.stack([np.stack([np.interp(times, t, x[:, c]) for c in range(3)], axis=1)
                         for t, x in zip(knots_t, knots_x)], axis=1)

    lo = min(float(t[0]) for t in knots_t)
    hi = max(float(t[-1]) for t in knots_t)
    grid = np.linspace(lo, hi, max(2, max(len(r.times) for r in rests)))
    for _ in range(MAX_LAB_ROUNDS):
        values = at(grid)
        worst = np.zeros(len(grid) - 1)
        for j, (t, x) in enumerate(zip(knots_t, knots_x)):  # the chord between grid times at the point's knots
            chord = np.stack([np.interp(t, grid, values[:, j, c]) for c in range(3)], axis=1)
            k = np.clip(np.searchsorted(grid, t, side="right") - 1, 0, len(grid) - 2)
            np.maximum.at(worst, k, np.linalg.norm(chord - x, axis=1))
        coarse = worst > tol
        if not coarse.any():
            break
        grid = np.sort(np.concatenate([grid, 0.5 * (grid[:-1] + grid[1:])[coarse]]))
    values = at(grid)
    out, base = [], 0
    for rest in rests:
        n = rest.points.shape[1]
        out.append(PointSamples(times=grid, points=values[:, base:base + n]))
        base += n
    return out
