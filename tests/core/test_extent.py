"""core/extent.py's column-by-column helpers against NumPy's row-broadcast forms.

Law: ``shifted(p, b)`` is ``p + b`` bit for bit, and ``shifted(p, -b)`` is ``p - b``
(IEEE x + (-y) is x - y, signed zeros included): the construction's boxes, balls and
rest offsets (spacetime/visibility.py, extrude.py, rigid.py) keep their bits. Oracle:
NumPy's broadcast, on drawn floats with signed zeros, infinities, subnormals and huge
magnitudes (hypothesis).
"""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from warp_st.core.extent import shifted

_floats = st.floats(allow_nan=False, width=64) | st.sampled_from([0.0, -0.0, np.inf, -np.inf, 5e-324, -1e308])


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(0, 40), st.just(3)), elements=_floats),
       arrays(np.float64, (3,), elements=_floats))
def test_shifted_is_the_broadcast_sum_and_difference_bit_for_bit(points, by):
    with np.errstate(invalid="ignore", over="ignore"):  # inf - inf: NaN on both sides
        for got, want in ((shifted(points, by), points + by), (shifted(points, -by), points - by)):
            assert got.dtype == np.float64 and got.shape == want.shape and got.flags.c_contiguous
            assert got.tobytes() == want.tobytes()


def test_shifted_takes_float32_points_as_float64():
    p = np.array([[1.0, 2.0, 3.0], [1e-8, -0.0, 7.5]], dtype=np.float32)
    assert shifted(p, (0.1, 0.2, 0.3)).tobytes() == (p.astype(np.float64) + np.array([0.1, 0.2, 0.3])).tobytes()
