"""The lab samples of rest-frame motion (``warp_st.core.rest_frame``, docs/spec.md §2.1, 0.7.0).

Law: for random piecewise-linear rest worldlines (points moving below c in S', S' moving at
a random v), the common lab samples follow every point's lab position within
REST_LAB_TOLERANCE x size at random lab times (inside, before and after the rest samples).
The oracle is brute force: the point's rest time found by bisection on the lab time of its
boosted event (``lorentz.lab_from_rest``, float64), the lab position read off that event.
"""
import numpy as np

from warp_st.core.deform import PointSamples
from warp_st.core.lorentz import lab_from_rest
from warp_st.core.rest_frame import REST_LAB_TOLERANCE, lab_samples, rest_speeds


def _random_rest(rng, n_times: int, n_points: int) -> PointSamples:
    """Points starting in a unit box, each interval a random velocity below 0.9c (S' units)."""
    times = np.cumsum(rng.uniform(0.2, 1.0, n_times)) - 3.0
    step = rng.normal(size=(n_times - 1, n_points, 3))
    step *= (rng.uniform(0.0, 0.9, (n_times - 1, n_points, 1)) / np.linalg.norm(step, axis=2, keepdims=True))
    points = np.concatenate([rng.uniform(-1, 1, (1, n_points, 3)),
                             np.diff(times)[:, None, None] * step], axis=0).cumsum(axis=0)
    return PointSamples(times=times, points=points)


def _brute(rest: PointSamples, j: int, t: float, o, v, t_ref) -> np.ndarray:
    """The lab position of point j at lab time t, less v (t - t_ref): bisection on t'."""
    boost = lab_from_rest(v)

    def event(tp):
        y = np.array([np.interp(tp, rest.times, rest.points[:, j, c]) for c in range(3)])
        return boost @ np.concatenate([[tp], y - o])

    lo, hi = -1e3, 1e3
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if t_ref + event(mid)[0] < t else (lo, mid)
    return o + event(0.5 * (lo + hi))[1:] - v * (t - t_ref)


def test_lab_samples_follow_the_boosted_worldlines():
    rng = np.random.default_rng(7)
    for trial in range(3):
        rests = [_random_rest(rng, 12, 5), _random_rest(rng, 9, 3)]  # two surfaces, their own rest times
        assert rest_speeds(rests[0]).max() < 0.9
        v = rng.normal(size=3)
        v *= rng.uniform(0.3, 0.9) / np.linalg.norm(v)
        o, t_ref = rng.uniform(-2, 2, 3), float(rng.uniform(-1, 1))
        every = np.concatenate([r.points.reshape(-1, 3) for r in rests])
        size = float(np.max(every.max(axis=0) - every.min(axis=0)))
        labs = lab_samples(rests, o, v, t_ref, size)
        assert np.array_equal(labs[0].times, labs[1].times)  # common lab times
        span = labs[0].times[[0, -1]]
        worst = 0.0
        for t in rng.uniform(span[0] - 2.0, span[1] + 2.0, 60):  # also where the points are held
            for s, (rest, lab) in enumerate(zip(rests, labs)):
                at = lab.at(float(t))
                for j in range(rest.points.shape[1]):
                    worst = max(worst, float(np.linalg.norm(at[j] - _brute(rest, j, float(t), o, v, t_ref))))
        # the bisection's 200 halvings of 2e3 and float64 rounding add ~1e-13: the bound is the tolerance
        assert worst <= REST_LAB_TOLERANCE * size * (1 + 1e-9), (trial, worst, REST_LAB_TOLERANCE * size)


def test_lab_samples_of_many_points_follow_each_point():
    """Past one block of points (the evaluation runs 64 points at a time, laid end to end on
    one time axis): 150 points, brute force at the blocks' first and last points and a few
    more, at random lab times inside and outside the samples. Same bound as above."""
    rng = np.random.default_rng(11)
    rest = _random_rest(rng, 10, 150)
    v = np.array([0.5, -0.3, 0.4])
    o, t_ref = np.array([0.3, -0.2, 0.1]), 0.7
    size = float(np.max(rest.points.reshape(-1, 3).max(axis=0) - rest.points.reshape(-1, 3).min(axis=0)))
    lab = lab_samples([rest], o, v, t_ref, size)[0]
    span = lab.times[[0, -1]]
    worst = 0.0
    for t in rng.uniform(span[0] - 1.0, span[1] + 1.0, 25):
        at = lab.at(float(t))
        for j in (0, 1, 62, 63, 64, 65, 100, 127, 128, 149):
            worst = max(worst, float(np.linalg.norm(at[j] - _brute(rest, j, float(t), o, v, t_ref))))
    assert worst <= REST_LAB_TOLERANCE * size * (1 + 1e-9), (worst, REST_LAB_TOLERANCE * size)
