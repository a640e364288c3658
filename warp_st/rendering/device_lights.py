"""Animated lights' worldlines -> the shading kernel's ``Track`` (kernels/light_track.py).

Times and pivots are recentred on the render origin in float64 before rounding, like every
other position (``warp_st.rendering.device``).
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.kernels import Kernels
from warp_st.kernels.light_track import make_light_track

__all__ = ["light_track"]

_DEVICE = "cpu"


def light_track(k: Kernels, lights, origin: np.ndarray):
    """The ``Track`` of ``lights`` (a light at rest: no probes) relative to ``origin`` (t, x)."""
    ns = np.float32 if k.scalar == wp.float32 else np.float64
    Track = make_light_track(k.scalar)[0]
    origin = np.asarray(origin, dtype=np.float64)
    counts = np.array([0 if l.motion is None else len(l.motion.times) for l in lights], dtype=np.int32)
    first = (np.cumsum(counts) - counts).astype(np.int32)
    moving = [l.motion for l in lights if l.motion is not None]
    # one pad row at the end: the arrays are never empty
    t = np.concatenate([m.times - origin[0] for m in moving] + [np.zeros(1)])
    o = np.concatenate([m.pivot - origin[1:] for m in moving] + [np.zeros((1, 3))])
    m33 = np.concatenate([np.transpose(m.linear, (0, 2, 1)) for m in moving] + [np.eye(3)[None]])
    trk = Track()
    trk.first = wp.array(first, dtype=wp.int32, device=_DEVICE)
    trk.count = wp.array(counts, dtype=wp.int32, device=_DEVICE)
    trk.t = wp.array(t.astype(ns), dtype=k.scalar, device=_DEVICE)
    trk.o = wp.array(o.astype(ns), dtype=k.vec3, device=_DEVICE)
    trk.m = wp.array(m33.astype(ns), dtype=wp.types.matrix((3, 3), k.scalar), device=_DEVICE)
    return trk
