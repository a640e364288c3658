"""Jupyter: an Image shows itself (its beauty) and any channel in false colour (issue 19, deliverable 5).

Laws: ``Image._repr_png_`` is the beauty as an 8-bit sRGB PNG, one pixel per pixel: decoded,
it is the sRGB transfer of the linear beauty clipped to [0, 1], rounded to 8 bits (the
oracle below is written from the sRGB formula, not from the code); ``Image.show(name)``
draws the channel with a colour bar labelled with its units (the same figure as
``warp-st inspect --png``, tests/commands/test_inspect.py), and an unknown name fails when
asked for, not inside Jupyter's display. Jupyter calls ``_repr_png_`` on the displayed object.
"""
from __future__ import annotations

import io

import matplotlib.image as mimage
import numpy as np
import pytest

from warp_st.output.channels import channel_spec
from warp_st.output.film import Image


def _image(h=5, w=7):
    rng = np.random.default_rng(3)
    rgba = rng.uniform(-0.2, 1.3, (h, w, 4)).astype(np.float32)  # out of range on both sides
    rgba[0, 0, :3] = np.nan
    doppler = np.linspace(0.5, 2.0, h * w, dtype=np.float32).reshape(h, w)
    doppler[-1, -1] = np.nan
    return Image(rgba=rgba, doppler=doppler, camera_time=3.0, frame=3.0)


def _decode(png: bytes) -> np.ndarray:
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    return mimage.imread(io.BytesIO(png), format="png")


def test_the_image_displays_as_its_srgb_beauty():
    img = _image()
    pixels = _decode(img._repr_png_())
    assert pixels.shape[:2] == (5, 7)
    c = np.clip(np.nan_to_num(img.rgba[..., :3].astype(np.float64)), 0.0, 1.0)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    expected = np.round(srgb * 255.0)
    assert np.abs(pixels[..., :3] * 255.0 - expected).max() <= 1.0  # 8-bit rounding of either side


def test_a_channel_shows_in_false_colour_with_its_units():
    img = _image()
    view = img.show("spacetime.doppler")
    fig = view.figure()
    try:
        ax, bar = fig.axes[0], fig.axes[1]
        assert channel_spec("spacetime.doppler").units in bar.get_ylabel()
        shown = ax.get_images()[0].get_array()
        assert np.array_equal(np.ma.getmaskarray(shown), np.isnan(img.doppler))
        assert np.allclose(np.ma.filled(shown, 0.0), np.nan_to_num(img.doppler))
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    picture = _decode(view._repr_png_())
    assert picture.shape[0] > 100 and picture.shape[1] > 100  # a figure, not the 5 x 7 pixels
    assert np.array_equal(_decode(img.show()._repr_png_()), _decode(img._repr_png_()))


def test_an_unknown_channel_fails_when_asked_for():
    with pytest.raises(KeyError, match="unknown channel"):
        _image().show("spacetime.nope")
