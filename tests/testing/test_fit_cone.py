"""``warp_st.testing.fit_cone``: the best circle on the sky through a set of directions.

Laws: on points of an exact circle (here an arc of 120°, which biases a mean-direction
start) it returns that circle's axis and angular radius to rounding; on points that lie
on no circle it returns the least-squares circle in the angle residuals: a stationary
point (J^T r = 0) that no small move of the axis or the radius improves. The outlines the
tests and the thesis examples fit are of both kinds (coupled spheres: circles; decoupled
ones: not).
"""
from __future__ import annotations

import math

import numpy as np

from warp_st.testing import fit_cone

AXIS = np.array([0.3, -0.2, -1.0]) / np.linalg.norm([0.3, -0.2, -1.0])


def _curve(radius_of_phi, phis):
    e1 = np.cross(AXIS, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(AXIS, e1)
    rho = radius_of_phi(phis)[:, None]
    ring = np.cos(phis)[:, None] * e1 + np.sin(phis)[:, None] * e2
    return np.cos(rho) * AXIS + np.sin(rho) * ring


def _sum_of_squares(dirs, axis, rho):
    axis = axis / np.linalg.norm(axis)
    return float(np.sum((np.arccos(np.clip(dirs @ axis, -1.0, 1.0)) - rho) ** 2))


def test_an_arc_of_an_exact_circle_gives_its_axis_and_radius():
    dirs = _curve(lambda p: np.full_like(p, 0.12), np.linspace(0.0, math.radians(120.0), 40))
    a, rho, resid = fit_cone(dirs)
    assert np.linalg.norm(a - AXIS) < 1e-12 and abs(rho - 0.12) < 1e-12  # rounding of unit vectors
    assert np.abs(resid).max() < 1e-12


def test_points_on_no_circle_give_the_least_squares_circle():
    phis = np.linspace(0.0, math.radians(300.0), 200)
    dirs = _curve(lambda p: 0.1 * (1.0 + 0.2 * np.cos(2.0 * p) + 0.1 * np.sin(3.0 * p)), phis)
    a, rho, resid = fit_cone(dirs)
    assert np.std(resid) > 1e-3  # not a circle
    # stationary: the gradient of the sum of squared residuals vanishes
    e1 = np.cross(a, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    ang = np.arccos(np.clip(dirs @ a, -1.0, 1.0))
    J = np.stack([-(dirs @ e1) / np.sin(ang), -(dirs @ e2) / np.sin(ang), -np.ones_like(ang)], axis=1)
    assert np.abs(J.T @ resid).max() < 1e-12 * len(dirs)  # rounding of 200 residuals of ~1e-2
    # a minimum: every small move of the axis or the radius makes it worse
    best = _sum_of_squares(dirs, a, rho)
    for step in (1e-4, -1e-4):
        assert _sum_of_squares(dirs, a + step * e1, rho) > best
        assert _sum_of_squares(dirs, a + step * e2, rho) > best
        assert _sum_of_squares(dirs, a, rho + step) > best
