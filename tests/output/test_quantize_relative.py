"""``film.quantize_relative``: a render's time planes in one buffer, bit for bit what
``quantize_time(float64(relative) + origin, origin)`` (the EXR's round trip) gives.

Oracle: ``channels.quantize_time`` itself, on the same inputs; compared as bytes, so NaN
payloads and the sign of zero count.
"""
from __future__ import annotations

import numpy as np
import pytest

from warp_st.output.channels import quantize_time
from warp_st.output.film import quantize_relative


def relative_times(rng) -> np.ndarray:
    """float32 relative times of every kind a film holds: lookbacks of all scales, signed
    zeros, NaN (misses), infinities, subnormals, and values that round when an origin of
    1e9 is added in float64."""
    wide = (rng.standard_normal(4004) * 10.0 ** rng.uniform(-8, 8, 4004)).astype(np.float32)
    special = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 1e-45, -1e-45, 1.1754944e-38, 3.4e38, -3.4e38,
                        0.1, -0.1, 1.0 / 3.0], dtype=np.float32)
    return np.concatenate([wide, special]).reshape(-1, 13)


@pytest.mark.parametrize("origin", [0.0, -0.0, 1.0, -3.7, 12345.678, 1e6 + 0.25, 1e9 + 1.0 / 3.0, -2.5e12])
def test_quantize_relative_is_quantize_time(origin):
    rel = relative_times(np.random.default_rng(17))
    want = quantize_time(rel.astype(np.float64) + origin, origin)
    got = quantize_relative(rel, origin)
    assert got.dtype == np.float64 and got.shape == rel.shape
    assert got.tobytes() == want.tobytes()


def test_quantize_relative_of_float64_input():
    """The time planes divided by a light speed per time code are float64 already."""
    rel = relative_times(np.random.default_rng(5)).astype(np.float64) / 299792458.0
    want = quantize_time(rel + 1e9, 1e9)
    assert quantize_relative(rel, 1e9).tobytes() == want.tobytes()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_quantize_relative_leaves_its_input(dtype):
    rel = relative_times(np.random.default_rng(3)).astype(dtype)
    kept = rel.copy()
    quantize_relative(rel, 1e9)
    assert rel.tobytes() == kept.tobytes()


@pytest.mark.parametrize("origin", [0.0, 1e9 + 1.0 / 3.0])
@pytest.mark.parametrize("scratch", ["input", "other"])
def test_quantize_relative_into_out_with_a_scratch(origin, scratch):
    """How the renderer calls it: into an Image plane, the film's float32 plane as the
    rounding's scratch (overwritten); any float32 array of the shape serves."""
    rel = relative_times(np.random.default_rng(11))
    want = quantize_time(rel.astype(np.float64) + origin, origin)
    out = np.full(rel.shape, 7.0)
    space = rel if scratch == "input" else np.full(rel.shape, 7.0, np.float32)
    got = quantize_relative(rel, origin, out=out, scratch=space)
    assert got is out and out.tobytes() == want.tobytes()
