"""The closed forms behind the shadow windows (warp_st/visibility.py) against direct
evaluation: the retarded-time root is a tight lower bound, and the near-axis window
holds exactly the times a moving ball is within reach of the shadow rays' axis."""
import numpy as np
import pytest

from warp_st.visibility import _near_axis_window, _retarded_root


@pytest.mark.parametrize("seed", range(4))
def test_retarded_root_is_a_tight_lower_bound(seed):
    rng = np.random.default_rng(seed)
    for _ in range(2000):
        w = rng.normal(size=3) * 10 ** rng.uniform(-2, 4)
        v = rng.normal(size=3)
        v *= rng.uniform(0.0, 0.999999) / np.linalg.norm(v)
        k = rng.normal() * 10 ** rng.uniform(-2, 6)
        tau = _retarded_root(w, v, k)
        f = tau - np.linalg.norm(w + v * tau)
        assert f <= k  # a lower bound: the window never starts too late
        # ... and tight: within float64 rounding of the magnitudes, over the slope 1 - |v|.
        scale = 1.0 + abs(k) + np.linalg.norm(w) + abs(tau)
        assert k - f <= 1e-9 * scale, (w, v, k, tau)


@pytest.mark.parametrize("seed", range(4))
def test_near_axis_window_matches_sampled_distances(seed):
    rng = np.random.default_rng(100 + seed)
    for _ in range(300):
        m0, centre, axis = rng.normal(size=(3, 3)) * 5.0
        v = rng.normal(size=3)
        v *= rng.uniform(0.0, 0.99) / np.linalg.norm(v)
        t_ref, radius = rng.normal() * 10.0, rng.uniform(0.1, 4.0)
        window = _near_axis_window(m0, v, t_ref, centre, axis, radius)
        l = axis / np.linalg.norm(axis)
        t = np.linspace(t_ref - 200.0, t_ref + 200.0, 40001)
        d = m0[None] + (t - t_ref)[:, None] * v[None] - centre
        dist = np.linalg.norm(d - (d @ l)[:, None] * l[None], axis=1)
        near = dist <= radius
        if window is None:
            assert not near.any()
            continue
        inside = (t >= window[0]) & (t <= window[1])
        assert not (near & ~inside).any(), "a near time outside the window"
        # Tight: the window holds no sampled time farther than the grid's resolution allows.
        step = t[1] - t[0]
        assert (dist[inside] <= radius + np.linalg.norm(v) * step + 1e-9).all()


def test_near_axis_window_edge_cases():
    # At rest: always (within reach) or never.
    assert _near_axis_window(np.array([0.0, 1.0, 0]), np.zeros(3), 0.0, np.zeros(3), np.array([1.0, 0, 0]), 2.0) == (-np.inf, np.inf)
    assert _near_axis_window(np.array([0.0, 3.0, 0]), np.zeros(3), 0.0, np.zeros(3), np.array([1.0, 0, 0]), 2.0) is None
    # Moving along the axis: the distance never changes.
    assert _near_axis_window(np.array([0.0, 1.0, 0]), np.array([0.5, 0, 0]), 0.0, np.zeros(3), np.array([1.0, 0, 0]), 2.0) == (-np.inf, np.inf)
    # A light inside the hit ball gives no axis: no bound.
    assert _near_axis_window(np.array([9.0, 9.0, 9]), np.array([0.5, 0, 0]), 0.0, np.zeros(3), np.zeros(3), 1.0) == (-np.inf, np.inf)
