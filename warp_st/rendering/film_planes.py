"""A rendered film's planes copied into an Image's, in bands of rows on the render's thread pool.

The film is reused by the next render, so every plane is copied out (and the kernels'
relative float32 times become absolute, quantised as the EXR stores them: channels.py).
Each step is elementwise, so a band gives the rows the whole plane would, bit for bit;
NumPy releases the GIL on arrays, so bands on two threads take about half the time.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.thread_pool import thread_pool
from warp_st.output.channels import LOW_TIME_CHANNELS, join_time, split_time
from warp_st.output.film import quantize_relative

__all__ = ["copy_film"]

_TIMES = (("spacetime.eventTime", "event_time"), ("spacetime.sourceTime", "source_time"))


def copy_film(film, out: dict, height: int, width: int, *, origin: float, per_code: float, float64: bool,
              object_of=None, threads: int = 1) -> dict:
    """Fill ``out``'s planes (``frame_inputs.image_planes``) from ``film``: times in time
    codes (lab / ``per_code``) about ``origin``; ``object_of`` maps bodies to objects
    (an animated body's pieces). Returns the float64 times' float32 residual planes
    (channels.LOW_TIME_CHANNELS; empty in float32)."""
    h, w = height, width
    src = {name: getattr(film, name).numpy().reshape(h, w) for name in
           ("event_time", "source_time", "object_id", "proper_time", "depth", "doppler", "bounces")}
    rgba = film.rgba.numpy().reshape(h, w, 4)
    lows = {LOW_TIME_CHANNELS[name]: np.empty((h, w), np.float32) for name, _ in _TIMES} if float64 else {}

    def band(rows: slice) -> None:
        np.copyto(out["rgba"][rows], rgba[rows], casting="unsafe")
        object_id = src["object_id"][rows]
        if object_of is not None:
            object_id = np.where(object_id > 0, object_of[np.maximum(object_id, 1) - 1] + 1, 0)
        np.copyto(out["object_id"][rows], object_id, casting="unsafe")
        for name, plane in _TIMES:
            rel = src[plane][rows]
            if per_code != 1.0:
                rel = rel.astype(np.float64) / per_code
            if float64:
                low = lows[LOW_TIME_CHANNELS[name]]
                hi, low[rows] = split_time(rel.astype(np.float64) + origin, origin)
                np.copyto(out[plane][rows], join_time(hi, low[rows], origin))
            else:  # the film's float32 plane serves as the rounding's scratch (the kernel rewrites it)
                quantize_relative(rel, origin, out=out[plane][rows], scratch=rel if rel.dtype == np.float32 else None)
        np.divide(src["proper_time"][rows], np.float32(per_code), out=out["proper_time"][rows], casting="unsafe")
        for name in ("depth", "doppler", "bounces"):
            np.copyto(out[name][rows], src[name][rows], casting="unsafe")

    n = max(1, min(int(threads), h))
    bands = [slice(h * i // n, h * (i + 1) // n) for i in range(n)]
    if n == 1:
        band(bands[0])
    else:
        list(thread_pool(n).map(band, bands))
    return lows
