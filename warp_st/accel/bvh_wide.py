"""The traced form of the BVH: the binary 4D BVH collapsed into 4-wide nodes.

A wide node stands for a binary inner node at even depth; its four child slots are
that node's grandchildren (a child that is a leaf fills one slot itself, leaving the
other empty). The kernel then tests four boxes per visit as one 16-lane vector
operation and takes about half as many steps down the tree as on the binary one.

Boxes are stored per wide node structure-of-arrays, axis-major:
``(t0 t1 t2 t3 | x0 x1 x2 x3 | y0 .. y3 | z0 .. z3)`` for the low corners, likewise
for the high ones. An empty slot has the box t = +inf, which no null ray on a past
lightcone (or with infinite light speed) enters, and link -1.

A slot's link packs ``first << LINK_SHIFT | count``: a leaf's primitive range
(count > 0) or a wide node (count 0).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from warp_st.accel.bvh import SAH_MAX_LEAF, FlatBVH
from warp_st.kernels.layout import LINK_MASK, LINK_SHIFT, MAX_WIDE_DEPTH, WIDTH

__all__ = ["WideBVH", "collapse", "wide_boxes", "WIDTH", "LINK_SHIFT", "LINK_MASK", "MAX_WIDE_DEPTH"]

assert SAH_MAX_LEAF <= LINK_MASK


@dataclass(frozen=True, eq=False)
class WideBVH:
    """Topology of the 4-wide tree: ``slot_node`` (W, 4), the binary node in each
    child slot (-1: empty); ``link`` (W, 4) int32, the packed links; ``depth``."""

    slot_node: np.ndarray
    link: np.ndarray
    depth: int

    @property
    def node_count(self) -> int:
        return int(len(self.link))


def collapse(bvh: FlatBVH, area: np.ndarray | None = None) -> WideBVH:
    """The 4-wide tree of ``bvh`` (vectorised level by level). With ``area`` (M,), each
    binary node's box surface, a wide node's slots are filled by opening, twice, the
    inner slot of largest area (``_open_largest``) instead of taking the grandchildren."""
    first, count = bvh.node_first.astype(np.int64), bvh.node_count.astype(np.int64)
    if len(bvh.order) == 0:  # no primitives: one wide node with four empty slots
        return WideBVH(np.full((1, WIDTH), -1, np.int64), np.full((1, WIDTH), -1, np.int32), 1)
    if count[0] > 0:  # the root is a leaf
        slots = np.array([[0, -1, -1, -1]])
        return WideBVH(slots, _links(slots, first, count, np.zeros(1, np.int64)), 1)
    if area is not None:
        wide = _open_largest(first, count, area)
        if wide is not None:
            return wide
    # Wide nodes are the binary inner nodes at even depth, numbered in binary order.
    depth = np.full(len(first), -1, np.int64)
    level = np.array([0])
    d = 0
    while len(level):
        depth[level] = d
        inner = level[count[level] == 0]
        level = np.concatenate([first[inner], first[inner] + 1])
        d += 1
    wide = np.nonzero((count == 0) & (depth % 2 == 0))[0]
    wide_id = np.full(len(first), -1, np.int64)
    wide_id[wide] = np.arange(len(wide))
    slots = np.full((len(wide), WIDTH), -1, np.int64)
    for side in (0, 1):
        c = first[wide] + side
        opened = count[c] == 0
        slots[:, 2 * side] = np.where(opened, first[c], c)
        slots[:, 2 * side + 1] = np.where(opened, first[c] + 1, -1)
    return WideBVH(slots, _links(slots, first, count, wide_id), (int(d) + 1) // 2)


def _open_largest(first, count, area) -> WideBVH | None:
    """The 4-wide tree whose nodes hold, for a binary inner node, its two children with
    the inner one of largest ``area`` opened into its own two (the first of equals), and
    then again among the three: a slot that is a leaf never takes a place it does not
    fill, and the largest boxes, which rays enter most, are tested a level earlier (a Warp
    kernel, ``kernels/blas_build.open_largest``). Wide nodes are numbered in binary order,
    as ``collapse`` numbers them. None when the tree would be deeper than
    ``MAX_WIDE_DEPTH`` (a wide level may advance one binary level on a path, not two):
    the traversal's stack is sized by it."""
    import warp as wp

    from warp_st.kernels.blas_build import open_largest

    m = len(first)
    wide = np.zeros(m, np.int32)
    wide[0] = 1
    wide_w = wp.array(wide, dtype=wp.int32, device="cpu")
    slots_w = wp.empty((m, WIDTH), dtype=wp.int32, device="cpu")
    wp.launch(open_largest, dim=1, inputs=[wp.array(first.astype(np.int32), dtype=wp.int32, device="cpu"),
                                           wp.array(count.astype(np.int32), dtype=wp.int32, device="cpu"),
                                           wp.array(np.asarray(area, np.float64), dtype=wp.float64, device="cpu"),
                                           wide_w, slots_w], device="cpu")
    level = wide_w.numpy()
    nodes = np.nonzero(level)[0]
    depth = int(level.max())
    if depth > MAX_WIDE_DEPTH:
        return None
    wide_id = np.full(m, -1, np.int64)
    wide_id[nodes] = np.arange(len(nodes))
    slots = slots_w.numpy()[nodes].astype(np.int64)
    return WideBVH(slots, _links(slots, first, count, wide_id), depth)


def _links(slots, first, count, wide_id) -> np.ndarray:
    s = np.maximum(slots, 0)
    target = np.where(count[s] > 0, first[s], wide_id[s])
    if target.max() >= 2 ** (31 - LINK_SHIFT):
        raise ValueError("BVH too large for packed node links")  # the memory limit refuses far earlier
    link = (target << LINK_SHIFT) | np.where(count[s] > 0, count[s], 0)
    return np.where(slots >= 0, link, -1).astype(np.int32)


def wide_boxes(wide: WideBVH, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Slot boxes (W, 16) axis-major from binary node boxes ``lo``/``hi`` (M, 4), (t, x,
    y, z), with empty slots at t = +inf."""
    empty = np.array([np.inf, 0.0, 0.0, 0.0], dtype=lo.dtype)
    s = np.maximum(wide.slot_node, 0)
    out = []
    for corner in (lo, hi):
        box = np.where((wide.slot_node >= 0)[..., None], corner[s], empty)  # (W, 4 slots, 4 axes)
        out.append(np.ascontiguousarray(box.transpose(0, 2, 1).reshape(-1, 4 * WIDTH)))
    return out[0], out[1]
