"""The visibility window of a body (spacetime/visibility.frame_window) at any lab time.

Oracles: brute force (sampled lab times at which some point of the body's ball lies on
the camera's past lightcone must fall inside the window, and the window's ends are such
times), and invariance: a body described from a reference time 1e10 earlier (its centre
moved back along its worldline) is the same worldline, so it has the same window. The
second failed before 0.6.0: the quadratic in tau cancelled catastrophically once the
camera time was ~1e9 after the reference time (a box at distance 10 had the window
t_c +- 1.7 instead of [t_c - 11.7, t_c - 8.3]).
"""
from __future__ import annotations

import numpy as np
import pytest

from warp_st.spacetime.visibility import frame_window

RNG = np.random.default_rng(20261202)
CASES = [(RNG.uniform(-20, 20, 3), float(RNG.uniform(0.5, 3)), RNG.uniform(-0.55, 0.55, 3), float(RNG.uniform(-5, 5)),
          float(RNG.uniform(-5, 5)), RNG.uniform(-5, 5, 3)) for _ in range(12)]


def h(t, m0, v, t_ref, c):
    """|m(t) - c| + t, the lab time at which light from the ball's centre at t reaches c."""
    return np.linalg.norm(m0 + np.outer(t - t_ref, v) - c, axis=1) + t


@pytest.mark.parametrize("case", range(len(CASES)))
def test_window_holds_every_visible_time(case):
    m0, rho, v, t_ref, t_c, c = CASES[case]
    lo, hi = frame_window(m0, rho, v, t_ref, t_c, c)
    t = np.linspace(t_c - 200.0, t_c + 10.0, 400_001)
    seen = t[np.abs(h(t, m0, v, t_ref, c) - t_c) <= rho]
    assert seen.size
    step = t[1] - t[0]
    # every sampled visible time is inside; the window is no wider than the visible set
    # (h is increasing for |v| < 1, so the visible set is one interval) beyond a sample step
    assert lo <= seen.min() and seen.max() <= hi
    assert seen.min() - lo <= step and hi - seen.max() <= step


@pytest.mark.parametrize("case", range(len(CASES)))
def test_window_is_the_same_a_long_time_after_the_reference(case):
    m0, rho, v, t_ref, t_c, c = CASES[case]
    shift = 1.0e10
    near = frame_window(m0, rho, v, t_ref, t_c, c)
    far = frame_window(m0 - v * shift, rho, v, t_ref - shift, t_c, c)
    # m0 - v shift is rounded to float64 (|m0 - v shift| < 1e10: error < 1e10 * 2^-53 ~ 1e-6),
    # and the roots move by at most that over (1 - |v|) >= 0.05
    np.testing.assert_allclose(far, near, rtol=0, atol=1e-4)


def test_vectorised_windows_keep_their_precision_a_long_time_after_the_reference():
    """frame_windows (rows of bodies) must agree with the near-reference windows as well."""
    from warp_st.spacetime.visibility import frame_windows

    shift = 1.0e10
    m0 = np.array([c[0] for c in CASES])
    rho = np.array([c[1] for c in CASES])
    v = np.array([c[2] for c in CASES])
    t_ref = np.array([c[3] for c in CASES])
    t_c = np.array([c[4] for c in CASES])
    cam = np.array([c[5] for c in CASES])
    near = np.column_stack(frame_windows(m0, rho, v, t_ref, t_c, cam))
    far = np.column_stack(frame_windows(m0 - v * shift, rho, v, t_ref - shift, t_c, cam))
    np.testing.assert_allclose(far, near, rtol=0, atol=1e-4)  # as the scalar test above


def test_shadow_window_roots_keep_their_precision_a_long_time_after_the_reference():
    """The occluder windows' retarded roots: tau - |w + v tau| = k. Described from a reference
    time S earlier (w - v S), the same worldline has the roots tau + S for k + S."""
    from warp_st.spacetime.visibility import _retarded_roots

    shift = 1.0e10
    for m0, _rho, v, _t_ref, _t_c, c in CASES:
        k = np.array([-30.0, -5.0, 0.0, 12.0])
        near = _retarded_roots(m0 - c, v, k)
        far = _retarded_roots(m0 - c - v * shift, v, k + shift) - shift
        # a lower bound stepped past rounding: at 1e10 one ulp is 2e-6, and the step-down
        # may move it by a few of them; the old cancellation gave errors of ~1e4
        np.testing.assert_allclose(far, near, rtol=0, atol=1e-3)
