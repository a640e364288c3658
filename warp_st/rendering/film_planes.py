"""A rendered film's planes and the Image's.

A float32 render's kernel writes the Image's planes itself (``film_into`` points the film
at them before the launch, its times written as absolute time codes, quantised as the EXR
stores them: channels.py, ``render_kernel.time_code``); ``finish_in_place`` then maps
bodies to objects and proper times to time codes in place. A float64 render's film is its
own (float64 planes, reused by the next render), so ``copy_film`` copies every plane out,
in bands of rows on the render's thread pool (each step is elementwise, so a band gives
the rows the whole plane would, bit for bit; NumPy releases the GIL on arrays, so bands
on two threads take about half the time). ``copy_film`` of a float32 film is the test's
twin of the kernel's own time codes.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.core.thread_pool import thread_pool
from warp_st.output.channels import LOW_TIME_CHANNELS, join_time, split_time
from warp_st.output.film import quantize_relative

__all__ = ["copy_film", "film_into", "finish_in_place"]

_TIMES = (("spacetime.eventTime", "event_time"), ("spacetime.sourceTime", "source_time"))


#: The Image's planes the kernel writes through the film: (film field, Image plane).
_INTO = (("rgba", "rgba"), ("depth", "depth"), ("proper_time", "proper_time"), ("doppler", "doppler"),
         ("object_id", "object_id"), ("bounces", "bounces"), ("event_code", "event_time"),
         ("source_code", "source_time"))


def film_into(k, film, out: dict, *, origin: float, per_code: float) -> None:
    """Point ``film``'s planes (a ``take_film(into_image=True)`` film, float32 kernels ``k``)
    at ``out``'s (``frame_inputs.image_planes``) for one launch: the kernel then writes the
    Image itself, its times as time codes about ``origin`` (lab / ``per_code``). The film
    holds raw pointers: ``out`` must outlive the launch."""
    types = {"rgba": k.vec4, "depth": wp.float32, "proper_time": wp.float32, "doppler": wp.float32,
             "object_id": wp.int32, "bounces": wp.int32, "event_code": wp.float64, "source_code": wp.float64}
    for field, plane in _INTO:
        a = out[plane]
        if getattr(film, field).ptr == a.ctypes.data and getattr(film, field).shape[0] == a.shape[0] * a.shape[1]:
            continue  # the last render's planes again (a reused block)
        # object_id and bounces are uint32 planes written as int32 (ids and counts < 2^31)
        setattr(film, field, wp.array(ptr=a.ctypes.data, shape=(a.shape[0] * a.shape[1],), dtype=types[field],
                                      device="cpu"))
    film.code_origin = float(origin)
    film.per_code = float(per_code)


def finish_in_place(out: dict, *, per_code: float, object_of=None) -> None:
    """What ``copy_film`` does to the planes besides copying, done on ``out`` in place after
    a ``film_into`` launch: bodies to objects (``object_of``), proper times to time codes."""
    if object_of is not None:
        ids = out["object_id"]
        ids[...] = np.where(ids > 0, object_of[np.maximum(ids, 1) - 1] + 1, 0)
    if per_code != 1.0:  # x / 1 is x, bit for bit
        np.divide(out["proper_time"], np.float32(per_code), out=out["proper_time"])


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
