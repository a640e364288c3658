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

import dataclasses

import numpy as np

from warp_st.core.deform import PointSamples
from warp_st.core.lorentz import contract, gamma
from warp_st.core.scene import surface_keep

__all__ = ["REST_LAB_TOLERANCE", "BEND_TOLERANCE", "BEND_EDGES", "MAX_BEND_LEVELS", "MAX_LAB_ROUNDS", "lab_samples",
           "rest_speeds", "surface_edges", "bend_edges", "edge_bends", "midpoint_subdivide"]

#: Largest distance between the resampled lab worldlines and the boosted rest polylines, as
#: a fraction of the body's size (its largest rest extent).
REST_LAB_TOLERANCE = 1.0e-4
#: Bisection rounds of :func:`lab_samples` (each halves every interval still too coarse).
MAX_LAB_ROUNDS = 24
#: Largest bend of a lab-simultaneous slice of a rest edge off the drawn straight edge
#: (:func:`edge_bends`), as a fraction of the body's size: surfaces are cut (midpoint
#: subdivision, each level quartering the bend) until within it, at most MAX_BEND_LEVELS times
#: (2e-3 for a wheel of diameter 2: issue 18's bound).
BEND_TOLERANCE = 1.0e-3
MAX_BEND_LEVELS = 3


def rest_speeds(rest: PointSamples) -> np.ndarray:
    """Each point's largest chord speed |dy| / dt' over the rest samples' intervals, (N - 1,)
    (the fastest point per interval; rest times in lab units)."""
    dt = np.diff(rest.times)
    dy = np.linalg.norm(np.diff(rest.points, axis=0), axis=2)  # (N-1, P)
    return dy.max(axis=1, initial=0.0) / dt


def lab_samples(rests: list[PointSamples], origin, velocity, reference_time: float, size: float,
                tolerance: float = REST_LAB_TOLERANCE, grid=None) -> list[PointSamples]:
    """The lab samples of a body's surfaces animated in its rest frame, at common lab times.

    rests: each surface's points in S' at rest times t' (``times``, lab units; t' = 0 at the
        lab event (t_ref, o)) as world positions o + y;
    origin o, velocity v (|v| < 1), reference_time t_ref: S' (docs/spec.md §2);
    size: the body's size; the common lab times follow every point's lab polyline within
        ``tolerance`` x size;
    grid: lab times to sample at instead (no refinement: a subdivided surface is sampled at
        the lab times its vertices needed).
    Returns one ``PointSamples`` per surface, all at the same lab times, points
    o + contract(y(t'_j), v): the lab positions without the uniform motion v (t - t_ref),
    which the deforming path adds (``core.deform.PointSamples``). Before and after the rest
    samples each point is held in S' (USD holds), i.e. moves with v in the lab: the held
    samples stay constant.
    """
    o = np.asarray(origin, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    boosted = [_boosted(rest, o, v, reference_time) for rest in rests]
    if grid is None:
        grid = _lab_grid(boosted, tolerance * max(size, 1e-12), max(len(r.times) for r in rests))
    grid = np.asarray(grid, dtype=np.float64)
    return [PointSamples(times=grid, points=_at(grid, t, x)) for t, x in boosted]


#: Points per block when a body's lab positions are evaluated: bounds the arrays' size and
#: the offsets of :func:`_polylines_at` (64 x the time span: ~1e-13 of rounding at most).
_BLOCK = 64


def _boosted(rest: PointSamples, o: np.ndarray, v: np.ndarray, reference_time: float):
    """Each point's own lab knot times (N, P) and its lab positions there less the uniform
    motion, o + contract(y, v) (N, P, 3)."""
    y = np.asarray(rest.points, dtype=np.float64) - o  # (N, P, 3)
    g = rest.times[:, None] + y @ v  # (t - t_ref) / gamma at each knot, (N, P)
    if not (np.diff(g, axis=0) > 0.0).all():
        raise ValueError("rest-frame motion at or above the speed of light (t' + v.y must increase)")
    return reference_time + float(gamma(v)) * g, o + contract(y, v)


def _at(times: np.ndarray, knots: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The points' lab positions at ``times``, (M, P, 3): linear between each one's knots, held outside."""
    m = len(times)
    out = np.empty((m, knots.shape[1], 3))
    for j0 in range(0, knots.shape[1], _BLOCK):
        b = knots[:, j0:j0 + _BLOCK].shape[1]
        at = _polylines_at(np.tile(times, b), np.repeat(np.arange(b), m), knots[:, j0:j0 + b], x[:, j0:j0 + b])
        out[:, j0:j0 + b] = at.reshape(b, m, 3).transpose(1, 0, 2)
    return out


def _polylines_at(queries: np.ndarray, cols: np.ndarray, knots: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Each query's point's polyline at the query's time, (Q, 3): point ``cols[q]``'s knots
    knots[:, j] (increasing) and positions x[:, j]; held before its first knot and after its last.

    One ``np.interp`` per axis for all B points: point j's knots and queries are shifted by
    j x (the span of every time here + 1), which lays the polylines end to end on one
    increasing axis, and its queries are clamped to its own knots (the hold). The shift
    rounds the times by at most B x span x 2^-53 (~1e-13 for a block of 64 over 40 time units)."""
    lo = min(float(queries.min()), float(knots.min()))
    span = max(float(queries.max()), float(knots.max())) - lo + 1.0
    shift = np.arange(knots.shape[1]) * span - lo  # (B,)
    axis = (knots + shift).T.ravel()  # (B N,): point by point, each increasing
    s = shift[cols]
    q = np.clip(queries + s, knots[0, cols] + s, knots[-1, cols] + s)
    out = np.empty((len(q), 3))
    for c in range(3):
        out[:, c] = np.interp(q, axis, x[..., c].T.ravel())
    return out


def _lab_grid(boosted, tol: float, count: int) -> np.ndarray:
    """Common lab times, bisected until linear interpolation between them is within ``tol``
    of every point's lab polyline at each of its knots (where a polyline is farthest from a
    chord): each knot against the chord between its polyline's positions at the grid times
    around it. A round checks only the knots of the intervals the last one split (the
    others' intervals are unchanged and were within ``tol``)."""
    lo = min(float(t.min()) for t, _ in boosted)
    hi = max(float(t.max()) for t, _ in boosted)
    grid = np.linspace(lo, hi, max(2, count))
    blocks = [(knots[:, j0:j0 + _BLOCK], x[:, j0:j0 + _BLOCK]) for knots, x in boosted
              for j0 in range(0, knots.shape[1], _BLOCK)]
    active = [np.ones(t.shape, dtype=bool) for t, _ in blocks]  # (N, B): knots still to check
    for _ in range(MAX_LAB_ROUNDS):
        worst = np.zeros(len(grid) - 1)
        intervals = []
        for (t, xb), todo in zip(blocks, active):
            i, j = np.nonzero(todo)
            tk = t[i, j]
            k = np.clip(np.searchsorted(grid, tk, side="right") - 1, 0, len(grid) - 2)
            intervals.append(k)
            if not len(k):
                continue
            ends = _polylines_at(np.concatenate([grid[k], grid[k + 1]]), np.concatenate([j, j]), t, xb)
            f = np.clip((tk - grid[k]) / (grid[k + 1] - grid[k]), 0.0, 1.0)[:, None]
            chord = (1.0 - f) * ends[:len(k)] + f * ends[len(k):]
            np.maximum.at(worst, k, np.linalg.norm(chord - xb[i, j], axis=1))
        coarse = worst > tol
        if not coarse.any():
            break
        for todo, k in zip(active, intervals):
            todo[todo] = coarse[k]
        grid = np.sort(np.concatenate([grid, 0.5 * (grid[:-1] + grid[1:])[coarse]]))
    return grid


def surface_edges(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct undirected edges (E, 2) of triangles (T, 3), and each triangle's three
    edges (a-b, b-c, c-a) as indices into them, (T, 3)."""
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    pairs = np.stack([tris, np.roll(tris, -1, axis=1)], axis=2).reshape(-1, 2)
    edges, inverse = np.unique(np.sort(pairs, axis=1), axis=0, return_inverse=True)
    return edges, inverse.reshape(-1, 3)


#: Edges per surface whose bend is measured: those longest along v (the bend grows as |e| |e.v|).
BEND_EDGES = 256


def bend_edges(surface, rest: PointSamples, velocity) -> np.ndarray:
    """The BEND_EDGES edges (E, 2) of ``surface`` with the largest |e| |e.v| at its first rest sample."""
    edges, _ = surface_edges(np.asarray(surface.triangles, dtype=np.int64).reshape(-1, 3)[surface_keep(surface)])
    if not len(edges):
        return edges
    e = rest.points[0, edges[:, 1]] - rest.points[0, edges[:, 0]]
    weight = np.linalg.norm(e, axis=1) * np.abs(e @ np.asarray(velocity, dtype=np.float64))
    return edges[np.argsort(-weight, kind="stable")[:BEND_EDGES]]


def edge_bends(rests, labs, edges, origin, velocity, reference_time: float) -> list[float]:
    """Per surface: the largest distance, at the lab samples' times, between the lab position
    of the rest-frame midpoint of an edge (``edges``, per surface) and the middle of its ends'
    lab positions (``labs``): how far a lab-simultaneous slice of a straight rest edge bends
    off the straight edge the deforming path draws (0 for a still body). Only while the
    edge's ends and midpoint are all within their rest samples: where the animation starts
    or stops (USD holds the ends) a slice across the start is kinked, not bent."""
    o = np.asarray(origin, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    out = []
    for rest, lab, e in zip(rests, labs, edges):
        if not len(e):
            out.append(0.0)
            continue
        mid = PointSamples(times=rest.times, points=0.5 * (rest.points[:, e[:, 0]] + rest.points[:, e[:, 1]]))
        mid_lab = lab_samples([mid], o, v, reference_time, 1.0, grid=lab.times)[0]
        middle = 0.5 * (lab.points[:, e[:, 0]] + lab.points[:, e[:, 1]])
        first, last = (np.stack([reference_time + float(gamma(v)) * (rest.times[i] + (p[i] - o) @ v)
                                 for p in (rest.points[:, e[:, 0]], rest.points[:, e[:, 1]], mid.points)])
                       for i in (0, -1))  # (3, E): the lab times the ends and the midpoint start and stop
        inside = (lab.times[:, None] >= first.max(axis=0)) & (lab.times[:, None] <= last.min(axis=0))  # (M, E)
        bend = np.where(inside, np.linalg.norm(mid_lab.points - middle, axis=2), 0.0)
        out.append(float(bend.max()))
    return out


def midpoint_subdivide(surface, rest: PointSamples):
    """``surface`` (a ``core.scene.Surface``) and its rest samples with every triangle cut
    into four at its edges' midpoints (orientation kept; normals, st and per-face materials
    carried; degenerate index triples dropped). A straight rest edge's midpoint is the mean
    of its ends at every rest time (USD's transforms are affine, its points linear)."""
    keep = surface_keep(surface)
    tris = np.asarray(surface.triangles, dtype=np.int64).reshape(-1, 3)[keep]
    edges, tri_edges = surface_edges(tris)
    n = len(surface.points)
    m = n + tri_edges  # (T, 3): the midpoints of a-b, b-c, c-a
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    new = np.stack([np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([m[:, 0], b, m[:, 1]], 1),
                    np.stack([m[:, 2], m[:, 1], c], 1), m], axis=1).reshape(-1, 3)
    points = np.concatenate([surface.points, 0.5 * (surface.points[edges[:, 0]] + surface.points[edges[:, 1]])])
    normals = surface.normals
    if normals is not None:
        mid = normals[edges[:, 0]] + normals[edges[:, 1]]
        length = np.linalg.norm(mid, axis=1, keepdims=True)
        normals = np.concatenate([normals, np.where(length > 1e-12, mid / np.maximum(length, 1e-300),
                                                    normals[edges[:, 0]])])
    st = surface.st
    if st is not None:
        s = np.asarray(st, dtype=np.float64)[keep]
        sm = 0.5 * (s + np.roll(s, -1, axis=1))  # (T, 3, 2): st at a-b, b-c, c-a
        st = np.stack([np.stack([s[:, 0], sm[:, 0], sm[:, 2]], 1), np.stack([sm[:, 0], s[:, 1], sm[:, 1]], 1),
                       np.stack([sm[:, 2], sm[:, 1], s[:, 2]], 1), sm], axis=1).reshape(-1, 3, 2)
    material = surface.triangle_material
    if material is not None:
        material = np.repeat(np.asarray(material)[keep], 4)
    rest_points = np.concatenate([rest.points, 0.5 * (rest.points[:, edges[:, 0]] + rest.points[:, edges[:, 1]])],
                                 axis=1)
    return (dataclasses.replace(surface, points=points, triangles=new, normals=normals, st=st,
                                triangle_material=material),
            PointSamples(times=rest.times, points=rest_points))
