"""A 4D bounding volume hierarchy over the primitives of the database (prisms or tetrahedra).

``wp.Bvh`` is 3D only, so the hierarchy over (t, x, y, z) boxes is ours: a binned
surface-area heuristic over 4D boxes, split level by level by a Warp kernel (one thread
per node, see ``kernels/bvh_build.py``). Every node is a contiguous range of a primitive
order and the two children of a node are stored next to each other, so a node needs
only its first child. The kernel traces its 4-wide form (bvh_wide.py). (A Morton-code
linear BVH built 2x faster but traced 2-3x slower on the benchmark scenes, so it was
dropped.)
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from warp_st.core.thread_pool import thread_pool
from warp_st.kernels.layout import MAX_DEPTH, SAH_FREE_DEPTH

__all__ = ["FlatBVH", "build_bvh", "load_builder", "LEAF_SIZE", "MAX_DEPTH"]

#: Ranges this small always become leaves.
LEAF_SIZE = 4
#: Largest primitive count in a SAH leaf (a leaf is made when the SAH says it is cheaper).
SAH_MAX_LEAF = 4
#: SAH costs: a node visit against one primitive test, per primitive kind (tuned on the
#: benchmark scenes with the binary traversal: a float64 tetrahedron test costs about two
#: node visits, a prism's comoving triangle test about one; with the 4-wide traversal,
#: prism costs from 0.5 to 3 left the visits per ray of the parade and aberration
#: static copies unchanged).
SAH_COST_TRAVERSE = 1.0
#: A rigid body's motion segment costs a bottom-level query: a transform and a 3D BVH
#: descent of a few node visits even when it misses (the top level, accel/instances.py).
#: A bottom level's triangle (accel/blas.py) costs one watertight float32 test.
SAH_COST_INTERSECT = {"tet": 2.0, "prism": 1.0, "rigid": 8.0, "tri": 1.0}


@dataclass(frozen=True, eq=False)
class FlatBVH:
    """Node arrays of the 4D BVH, lab frame, float64.

    node_lo, node_hi: box corners (t, x, y, z), shape (M, 4) (float32 from a build
        with ``float32_boxes``).
    node_first: first child (internal) or first primitive (leaf), (M,), int32.
    node_count: 0 for internal nodes, else the leaf's primitive count, (M,), int32.
    order: the primitive permutation; primitive i of the leaves is input order[i].
    """

    node_lo: np.ndarray
    node_hi: np.ndarray
    node_first: np.ndarray
    node_count: np.ndarray
    order: np.ndarray
    depth: int
    build_seconds: float

    @property
    def node_count_total(self) -> int:
        return int(len(self.node_lo))

    @property
    def nbytes(self) -> int:
        return int(self.node_lo.nbytes // 2 + self.node_hi.nbytes // 2 + self.node_first.nbytes + self.node_count.nbytes)


def build_bvh(prim_lo: np.ndarray, prim_hi: np.ndarray, primitive: str = "tet", *, leaf_size: int = LEAF_SIZE,
              uniform_t: bool = False, level_threads: int = 2, float32_boxes: bool = False) -> FlatBVH:
    """Build the BVH over primitive boxes ``prim_lo``/``prim_hi`` of shape (N, 4);
    ``primitive`` picks the SAH intersection cost; ranges of ``leaf_size`` primitives or
    fewer always become leaves (larger ones when the SAH says so). ``uniform_t``: every
    box has the same time extent (a 3D build: the same tree, built faster).
    ``level_threads``: 2 splits a wide level's nodes on two threads, 1 on the calling
    thread alone (for builds that already run side by side: the same tree).
    ``float32_boxes``: the boxes are float32 numbers (a bottom level's triangles), so are
    the node boxes, reduced in a Warp kernel (the same values, without float64 copies)."""
    start_clock = time.perf_counter()
    n = len(prim_lo)
    if n == 0:
        # No primitives: one leaf whose box lies at t = +inf, which no null ray on a
        # past (or infinite-c) lightcone enters (the kernels test the root's box before
        # anything else; bvh_wide.collapse gives one empty wide node).
        far = np.array([[np.inf, 0.0, 0.0, 0.0]])
        return FlatBVH(far, far.copy(), np.zeros(1, np.int32), np.zeros(1, np.int32), np.zeros(0, np.int64), 0, 0.0)
    first, count, levels, order, depth, plo, phi = _sah_topology(prim_lo, prim_hi, SAH_COST_INTERSECT[primitive],
                                                                 leaf_size, uniform_t, level_threads)
    if float32_boxes:
        lo, hi = _bounds32(_sah_kernel(SAH_COST_INTERSECT[primitive], leaf_size, uniform_t)[1], first, count, plo, phi)
    else:
        lo, hi = _bounds(prim_lo, prim_hi, first, count, levels, order)
    return FlatBVH(
        node_lo=lo,
        node_hi=hi,
        node_first=first.astype(np.int32),
        node_count=count.astype(np.int32),
        order=order,
        depth=depth,
        build_seconds=time.perf_counter() - start_clock,
    )


def load_builder(primitive: str = "tet", *, leaf_size: int = LEAF_SIZE, uniform_t: bool = False) -> None:
    """Make and load the split kernel ``build_bvh`` uses with these arguments (and the
    node-box kernel, in its module), on the calling thread, so that builds on other
    threads only launch them (Warp's code generation parses Python with ``ast``, which
    CPython 3.11 does not allow on two threads at once: docs/design/two-level.md)."""
    import warp as wp

    wp.load_module(_sah_kernel(SAH_COST_INTERSECT[primitive], leaf_size, uniform_t)[0].module, device="cpu")


def _sah_topology(prim_lo, prim_hi, cost_intersect: float, leaf_size: int, uniform_t: bool, level_threads: int):
    """Node ranges by binned SAH, one Warp launch per tree level."""
    import warp as wp

    kernel = _sah_kernel(cost_intersect, leaf_size, uniform_t)[0]
    n = len(prim_lo)
    plo = wp.array(prim_lo.astype(np.float32), dtype=wp.vec4, device="cpu")
    phi = wp.array(prim_hi.astype(np.float32), dtype=wp.vec4, device="cpu")
    centre = wp.array((0.5 * (prim_lo + prim_hi)).astype(np.float32), dtype=wp.vec4, device="cpu")
    order_w = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device="cpu")
    cap = 2 * n
    first = np.zeros(cap, np.int64)
    count = np.zeros(cap, np.int64)
    levels = []
    seg_start, seg_end, seg_node = np.array([0]), np.array([n]), np.array([0])
    n_nodes, depth = 1, 0
    while len(seg_node):
        depth += 1
        mid = _launch_split(wp, kernel, centre, plo, phi, order_w, seg_start, seg_end, depth > SAH_FREE_DEPTH,
                            level_threads)
        leaf = mid < 0
        first[seg_node[leaf]] = seg_start[leaf]
        count[seg_node[leaf]] = seg_end[leaf] - seg_start[leaf]
        s0, s1, split, node = seg_start[~leaf], seg_end[~leaf], mid[~leaf], seg_node[~leaf]
        if len(node) == 0:
            break
        child = n_nodes + 2 * np.arange(len(node))
        first[node] = child
        count[node] = 0
        n_nodes += 2 * len(node)
        levels.append(node)
        seg_start = np.concatenate([s0, split])
        seg_end = np.concatenate([split, s1])
        seg_node = np.concatenate([child, child + 1])
    return first[:n_nodes], count[:n_nodes], levels, order_w.numpy().astype(np.int64), depth, plo, phi


_SAH_KERNELS: dict = {}


def _launch_split(wp, kernel, centre, plo, phi, order_w, seg_start, seg_end, force_median, threads):
    """Split one level's nodes; wide levels, with ``threads`` 2, in two halves on two
    threads (disjoint ranges)."""
    m = len(seg_start)
    mids = wp.zeros(m, dtype=wp.int32, device="cpu")
    starts = wp.array(seg_start.astype(np.int32), dtype=wp.int32, device="cpu")
    ends = wp.array(seg_end.astype(np.int32), dtype=wp.int32, device="cpu")
    flag = 1 if force_median else 0

    def run(lo, hi):
        if hi > lo:
            wp.launch(kernel, dim=hi - lo, inputs=[centre, plo, phi, order_w, starts[lo:hi], ends[lo:hi], flag, mids[lo:hi]],
                      device="cpu")

    if m < 64 or threads < 2:
        run(0, m)
    else:
        # Balance by primitive count, not node count.
        work = np.cumsum(seg_end - seg_start)
        half = int(np.searchsorted(work, work[-1] / 2))
        # Its own pool: these run inside the bottom levels' shape tasks (accel/blas.py).
        list(thread_pool(2, "warp-st-bvh").map(lambda r: run(*r), [(0, half), (half, m)]))
    return mids.numpy().astype(np.int64)


def _sah_kernel(cost_intersect: float, leaf_size: int, uniform_t: bool = False):
    """The split and node-box kernels (one module) for one intersection cost and leaf
    size, made once per process."""
    from warp_st.kernels.bvh_build import make_sah_split

    key = (cost_intersect, leaf_size, uniform_t)
    if key not in _SAH_KERNELS:
        _SAH_KERNELS[key] = make_sah_split(leaf_size, SAH_MAX_LEAF, SAH_COST_TRAVERSE, cost_intersect, uniform_t)
    return _SAH_KERNELS[key]


def _bounds32(node_boxes, first, count, plo, phi):
    """Node boxes in float32 by ``node_boxes`` (``kernels.bvh_build``) from the
    primitives' boxes in leaf order (``plo``/``phi``, the split kernel's)."""
    import warp as wp

    m = len(first)
    lo = wp.empty(m, dtype=wp.vec4, device="cpu")
    hi = wp.empty(m, dtype=wp.vec4, device="cpu")
    wp.launch(node_boxes, dim=1, inputs=[wp.array(first.astype(np.int32), dtype=wp.int32, device="cpu"),
                                         wp.array(count.astype(np.int32), dtype=wp.int32, device="cpu"), plo, phi, lo,
                                         hi], device="cpu")
    return lo.numpy(), hi.numpy()


def _bounds(prim_lo, prim_hi, first, count, levels, order):
    """Node boxes bottom-up: leaves by one reduceat each, then parents level by level."""
    n_nodes = len(first)
    lo = np.empty((n_nodes, 4))
    hi = np.empty((n_nodes, 4))
    # Leaves partition the ordered primitives, so one reduceat each.
    leaves = np.nonzero(count > 0)[0]
    leaves = leaves[np.argsort(first[leaves])]
    plo, phi = prim_lo[order], prim_hi[order]
    lo[leaves] = np.minimum.reduceat(plo, first[leaves], axis=0)
    hi[leaves] = np.maximum.reduceat(phi, first[leaves], axis=0)
    for node in reversed(levels):  # children are always on a deeper level
        c = first[node]
        lo[node] = np.minimum(lo[c], lo[c + 1])
        hi[node] = np.maximum(hi[c], hi[c + 1])
    return lo, hi
