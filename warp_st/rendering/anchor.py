"""Where a frame's database coordinates are taken from: the geometry anchor (docs/spec.md §5).

The kernels trace in coordinates relative to an event near the camera, so that float32 keeps
its precision at any absolute time and place. Recentring the database on each frame's own
camera event costs O(database) per frame (every tetrahedron's four events; for the 0.8c
wheel 91-98 % of a frame). Instead the database is recentred on the camera event rounded
per axis to a grid of step G, a power of two: every frame whose camera event rounds to the
same anchor reuses one recentred geometry (``database_cache.Database.geometry_for``), and the
camera's own offset from it, at most G / 2 per axis, is the rays' origin.

Precision. A coordinate at distance d from the camera is at most d + 2G from the anchor (four
axes of at most G / 2 each), so its float32 rounding grows from eps d to at most eps (d + 2G).
G = the power of two at or above the database's largest finite 4D extent (its top-level
root box; c = 1) / ANCHOR_CELLS, so G < extent / 8 and the added rounding is at most
eps x extent / 4 (eps = 2^-24 relative: 0.015 ppm of the database's size), and a camera at rest in time-sampled motion
recentres once per G of lab time rather than every frame. Without a finite extent the anchor
is the camera event itself (as before 0.8.0).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["ANCHOR_CELLS", "anchor_step", "geometry_anchor"]

#: The anchor grid's step is the database's extent over this (rounded up to a power of two).
ANCHOR_CELLS = 16


def anchor_step(root_lo: np.ndarray, root_hi: np.ndarray) -> float:
    """G: the power of two at or above the root box's largest finite extent / ANCHOR_CELLS
    (0: none is finite and positive)."""
    with np.errstate(invalid="ignore"):  # an empty database's box is [+inf, +inf]: inf - inf is NaN, dropped next
        size = np.asarray(root_hi, dtype=np.float64) - np.asarray(root_lo, dtype=np.float64)
    size = size[np.isfinite(size) & (size > 0.0)]
    if not size.size:
        return 0.0
    return float(2.0 ** math.ceil(math.log2(float(size.max()) / ANCHOR_CELLS)))


def geometry_anchor(event: np.ndarray, step: float) -> np.ndarray:
    """The anchor of camera event ``event`` = (t_c, c): each coordinate rounded to a multiple
    of ``step`` (``anchor_step``); the event itself when ``step`` is 0 or the rounding is not
    finite."""
    event = np.asarray(event, dtype=np.float64)
    if not step > 0.0:
        return event.copy()
    with np.errstate(over="ignore", invalid="ignore"):  # a rounding that overflows is not finite: the event
        anchor = np.round(event / step) * step
    return anchor if np.isfinite(anchor).all() else event.copy()
