"""Where a body's bottom-level queries start: the rest box of the bodies it may touch.

A ray's query of a body starts where the ray enters that body's start box
(``kernels/trace_rigid.leaf``), in the coordinates of the body's frame (its motion group,
``spacetime.rigid``). Bodies that share a seam (the walls of a room) must see the ray as
the same float32 line from the same start, or a ray through the seam could pass
between them; so each body's start box holds every body of its frame it may touch.
A seam's points lie in both bodies' rest boxes, so bodies whose boxes are apart cannot
share one: the start box is the union over the body's *cluster*, the bodies of its frame
joined by overlapping (or touching) rest boxes, transitively. A body apart from the rest
of its frame starts at its own box (``START_OWN`` in the kernel: no second slab test),
where a ray meets it at a start nearer to it.

The clusters merge groups whose union boxes overlap until none do, which may join groups
whose members' boxes are apart (a larger start box, never a smaller one). Frames of more
than ``CLUSTER_BODIES`` bodies keep one start box for the whole frame.
"""
from __future__ import annotations

import numpy as np

__all__ = ["start_boxes", "CLUSTER_BODIES"]

#: Frames of more bodies than this keep one start box (the clustering's pairwise overlap
#: test is quadratic in them).
CLUSTER_BODIES = 2048


def start_boxes(rest_lo: np.ndarray, rest_hi: np.ndarray, frame_of: np.ndarray, traced: np.ndarray):
    """(start_lo, start_hi), (B, 3) each: every ``traced`` body's start box, the union of
    the rest boxes (``rest_lo``, ``rest_hi``, in its frame's coordinates) of its cluster
    within its frame (``frame_of``); the other bodies keep their rest boxes."""
    start_lo, start_hi = rest_lo.copy(), rest_hi.copy()
    frames, counts = np.unique(frame_of[traced], return_counts=True)
    for f in frames[counts > 1]:  # a body alone in its frame keeps its own box
        members = np.flatnonzero((frame_of == f) & traced)
        for cluster in _clusters(rest_lo[members], rest_hi[members]):
            start_lo[members[cluster]] = rest_lo[members[cluster]].min(axis=0)
            start_hi[members[cluster]] = rest_hi[members[cluster]].max(axis=0)
    return start_lo, start_hi


def _clusters(lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """Index arrays of the boxes [lo, hi] grouped until no two groups' union boxes
    overlap (touching counts as overlapping); one group when there are more than
    ``CLUSTER_BODIES``."""
    n = len(lo)
    if n > CLUSTER_BODIES:
        return [np.arange(n)]
    group = np.arange(n)
    while True:
        ids, at = np.unique(group, return_inverse=True)
        g_lo = np.full((len(ids), 3), np.inf)
        g_hi = np.full((len(ids), 3), -np.inf)
        np.minimum.at(g_lo, at, lo)
        np.maximum.at(g_hi, at, hi)
        overlap = np.all((g_lo[:, None] <= g_hi[None]) & (g_lo[None] <= g_hi[:, None]), axis=2)
        rep = np.argmax(overlap, axis=1)  # the first group each overlaps (itself at the latest)
        if np.array_equal(rep, np.arange(len(ids))):
            return [np.flatnonzero(at == k) for k in range(len(ids))]
        while not np.array_equal(rep[rep], rep):  # to the first of each chain
            rep = rep[rep]
        group = rep[at]
