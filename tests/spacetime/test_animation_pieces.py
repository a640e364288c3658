"""Animated bodies as pieces of uniform motion (spacetime/animation.py, docs/spec.md §2.1).

Laws: every body point of the pieces stays within the tolerance of where USD puts it, at
every probe (brute force over the body's vertices); the pieces' proper time (§2's tau on
each piece) is the integral of dt / gamma along the pivot from spacetime:referenceTime
(closed form for a piecewise-uniform path); pieces meet at the pivot.
"""
import numpy as np

import warp_st
from warp_st.core.lorentz import contraction_matrix
from warp_st.spacetime.animation import _body_cuts, animation_cuts, body_radius, piece_bodies

from animation_stages import HEADER, spinning_rod, write


def _errors_at_probe(body, pieces, k: int) -> float:
    """The largest distance, over every vertex of ``body`` and every piece holding probe k's
    time, between the piece's vertex and USD's (probe k's pivot and linear part; the rod's
    pivot is at rest, so no contraction enters)."""
    m = body.motion
    t = float(m.times[k])
    points = np.concatenate([s.points for s in body.surfaces])
    truth = m.pivot[k] + (points - m.static_pivot) @ m.linear[k]
    worst = 0.0
    for piece in (p for p in pieces if p.lifetime[0] <= t <= p.lifetime[1]):
        a = contraction_matrix(piece.velocity, piece.decoupled)
        rest = np.concatenate([s.points for s in piece.surfaces]) - piece.origin
        model = piece.origin + piece.velocity * (t - piece.reference_time) + rest @ a.T
        worst = max(worst, float(np.linalg.norm(model - truth, axis=1).max()))
    return worst


def test_pieces_stay_within_the_tolerance_at_every_probe(tmp_path):
    """A coupled rod spinning with tips at 0.7c, cut for a constant tolerance of 0.05: at
    every probe (the times USD's interpolation was sampled at) every vertex of the piece
    holding it is within 0.05 of USD's (1e-9 of slack for the float64 rounding)."""
    body = warp_st.load(write(tmp_path, "rod.usda", spinning_rod(0.7))).bodies[0]
    radius = body_radius(body)
    tol = 0.05
    cuts = _body_cuts(body, np.full(len(body.motion.times), tol), radius)
    pieces = piece_bodies(body, cuts)
    assert 20 < len(cuts) < 0.6 * len(body.motion.times)  # the rotation needs cuts; the greedy merges probes
    worst = 0.0
    assert np.allclose(body.motion.pivot, 0.0)
    for k in range(len(body.motion.times)):
        worst = max(worst, _errors_at_probe(body, pieces, k))
    assert worst <= tol + 1e-9, worst
    assert worst > 0.5 * tol  # the pieces use the room they are given


def test_proper_time_integrates_along_the_pivot(tmp_path):
    """Translate samples 0: x = 0, 10: x = 3, 20: x = 10 (0.3c, then 0.7c), held outside;
    referenceTime 5. tau at the pivot: (t - 5) sqrt(1 - 0.09) on [0, 10], then
    5 sqrt(0.91) + (t - 10) sqrt(0.51); held (at rest) before 0 and after 20, where tau
    runs as t. 1e-9: float64 rounding of values ~30."""
    text = HEADER + '''def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double spacetime:referenceTime = 5
    double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (3, 0, 0), 20: (10, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "Hull"
    {
        double size = 0.5
    }
}
'''
    scene = warp_st.load(write(tmp_path, "ship.usda", text))
    (cuts,) = animation_cuts(scene, [scene.camera_state(None, 0.0)], width=64, height=64)
    pieces = piece_bodies(scene.bodies[0], cuts[1])
    a, b = np.sqrt(1.0 - 0.09), np.sqrt(1.0 - 0.49)

    def expected(t):
        if t < 0.0:
            return t - 5.0 * a
        if t <= 10.0:
            return (t - 5.0) * a
        if t <= 20.0:
            return 5.0 * a + (t - 10.0) * b
        return 5.0 * a + 10.0 * b + (t - 20.0)

    for t in (-7.0, -0.5, 0.0, 2.0, 5.0, 9.9, 10.0, 13.0, 19.5, 20.0, 31.0):
        piece = next(p for p in pieces if p.lifetime[0] <= t <= p.lifetime[1])
        v = piece.velocity
        x = piece.origin + v * (t - piece.reference_time)  # the pivot on this piece
        gamma = 1.0 / np.sqrt(1.0 - v @ v)
        tau = gamma * ((t - piece.reference_time) - v @ (x - piece.origin))  # docs/spec.md §2
        assert abs(tau - expected(t)) <= 1e-9, (t, tau, expected(t))
        assert abs(x[0] - np.interp(t, [0.0, 10.0, 20.0], [0.0, 3.0, 10.0])) <= 1e-9  # the pieces meet USD's pivot
