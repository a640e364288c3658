"""core.deform.PointSamples (docs/spec.md §2.2): linear between the samples, held outside
them as USD holds values; it pickles with the scene (farm workers need no stage)."""
import pickle

import numpy as np

from warp_st.core.deform import PointSamples, deforming, surface_hull_points
from warp_st.core.scene import Body, Surface


def _samples():
    p0 = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    return PointSamples(times=np.array([2.0, 4.0, 8.0]), points=np.stack([p0, p0 + (2.0, 0, 0), p0 * 3.0]))


def test_linear_between_samples_held_outside():
    s = _samples()
    np.testing.assert_array_equal(s.at(-5.0), s.points[0])
    np.testing.assert_array_equal(s.at(2.0), s.points[0])
    np.testing.assert_allclose(s.at(3.0), s.points[0] + (1.0, 0, 0), atol=1e-15)
    np.testing.assert_allclose(s.at(6.0), 0.5 * (s.points[1] + s.points[2]), atol=1e-15)
    np.testing.assert_array_equal(s.at(8.0), s.points[2])
    np.testing.assert_array_equal(s.at(1e9), s.points[2])


def test_hull_points_and_pickling():
    s = _samples()
    surface = Surface("/M", s.points[0], np.array([[0, 1, 2]]), samples=s)
    body = Body("/M", (surface,))
    assert deforming(body) and not deforming(Body("/N", (Surface("/N", s.points[0], np.array([[0, 1, 2]])),)))
    hull = surface_hull_points(surface)
    assert hull.shape == (12, 3) and hull[:, 0].max() == 3.0  # every sampled position
    again = pickle.loads(pickle.dumps(body))
    np.testing.assert_array_equal(again.surfaces[0].samples.at(5.0), s.at(5.0))
