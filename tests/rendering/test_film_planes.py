"""The film's planes copied into an Image's in bands of rows (``rendering.film_planes``).

Oracle: the same conversions done on whole planes with the contract's own functions
(``channels.quantize_time``, ``split_time`` / ``join_time``), written out independently
here. Every step is elementwise, so banded and whole must agree bit for bit; the film is
random (NaN backgrounds, light speed other than 1, an object table) and the bands uneven
(37 rows on 3 threads)."""
import numpy as np
import pytest

from warp_st.output.channels import LOW_TIME_CHANNELS, join_time, quantize_time, split_time
from warp_st.rendering.film_planes import copy_film
from warp_st.rendering.frame_inputs import _PLANES

H, W = 37, 11


class _Plane:
    def __init__(self, values):
        self.values = values

    def numpy(self):
        return self.values


def _film(rng):
    rel = lambda: np.where(rng.random(H * W) < 0.2, np.nan, rng.normal(size=H * W) * 10 ** rng.uniform(-3, 4, H * W))
    return dict(
        rgba=rng.random((H * W, 4)).astype(np.float32),
        event_time=rel().astype(np.float32), source_time=rel().astype(np.float32),
        object_id=rng.integers(0, 6, H * W).astype(np.int32),
        proper_time=rng.normal(size=H * W).astype(np.float32), depth=rng.random(H * W).astype(np.float32),
        doppler=rng.random(H * W).astype(np.float32), bounces=rng.integers(0, 4, H * W).astype(np.int32))


def _planes():
    return {name: np.full((H, W, count) if count > 1 else (H, W), 7, dtype) for name, dtype, count in _PLANES}


def _whole(f, origin, per_code, float64, object_of):
    """The conversion on whole planes, as the contract states it."""
    out, lows = {}, {}
    out["rgba"] = f["rgba"].reshape(H, W, 4)
    ids = f["object_id"].reshape(H, W)
    out["object_id"] = np.where(ids > 0, object_of[np.maximum(ids, 1) - 1] + 1, 0) if object_of is not None else ids
    for name, plane in (("spacetime.eventTime", "event_time"), ("spacetime.sourceTime", "source_time")):
        absolute = f[plane].reshape(H, W).astype(np.float64) / per_code + origin
        if float64:
            hi, lows[LOW_TIME_CHANNELS[name]] = split_time(absolute, origin)
            out[plane] = join_time(hi, lows[LOW_TIME_CHANNELS[name]], origin)
        else:
            out[plane] = quantize_time(absolute, origin)
    out["proper_time"] = f["proper_time"].reshape(H, W) / np.float32(per_code)
    for name in ("depth", "doppler", "bounces"):
        out[name] = f[name].reshape(H, W)
    return out, lows


@pytest.mark.parametrize("float64", [False, True])
@pytest.mark.parametrize("per_code", [1.0, 2.5])
@pytest.mark.parametrize("threads", [1, 3])
def test_banded_copy_is_the_whole_plane_conversion(float64, per_code, threads):
    rng = np.random.default_rng(int(float64) + 2 * threads + int(per_code))
    f = _film(rng)
    object_of = np.array([0, 0, 2, 1, 3, 3]) if per_code != 1.0 else None
    origin = 1234.5678
    expected, expected_lows = _whole({k: v.copy() for k, v in f.items()}, origin, per_code, float64, object_of)
    out = _planes()
    lows = copy_film(type("Film", (), {k: _Plane(v) for k, v in f.items()})(), out, H, W, origin=origin,
                     per_code=per_code, float64=float64, object_of=object_of, threads=threads)
    for name, value in expected.items():
        np.testing.assert_array_equal(out[name], np.asarray(value).astype(out[name].dtype), err_msg=name)
    assert lows.keys() == expected_lows.keys()
    for name, value in expected_lows.items():
        np.testing.assert_array_equal(lows[name], value, err_msg=name)
    assert np.isnan(out["event_time"]).any() and (out["object_id"] > 0).any()  # the film had both kinds of pixel
