"""A 4D bounding volume hierarchy over the primitives of the database (prisms or tetrahedra).

``wp.Bvh`` is 3D only, so the hierarchy over (t, x, y, z) boxes is ours: a binned
surface-area heuristic over 4D boxes, built depth first by a Warp kernel (one thread per
subtree, see ``kernels/bvh_build.py``). Every node is a contiguous range of a primitive
order and the two children of a node are stored next to each other, after it, so a node
needs only its first child. The kernel traces its 4-wide form (bvh_wide.py). (A Morton-code
linear BVH built 2x faster but traced 2-3x slower on the benchmark scenes, so it was
dropped.)
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from warp_st.core.thread_pool import thread_pool
from warp_st.kernels.layout import MAX_DEPTH

__all__ = ["FlatBVH", "build_bvh", "load_builder", "LEAF_SIZE", "MAX_DEPTH"]

#: Ranges this small always become leaves.
LEAF_SIZE = 4
#: Builds of this many primitives or more make their top TOP_DEPTH levels first and
#: then the subtrees under them, which can run on two threads.
SPLIT_MIN = 4096
TOP_DEPTH = 3
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
              uniform_t: bool = False, oriented: bool = False, threads: int = 2, float32_boxes: bool = False,
              centre=None) -> FlatBVH:
    """Build the BVH over primitive boxes ``prim_lo``/``prim_hi`` of shape (N, 4);
    ``primitive`` picks the SAH intersection cost; ranges of ``leaf_size`` primitives or
    fewer always become leaves (larger ones when the SAH says so). ``uniform_t``: every
    box has the same time extent (a 3D build: the same tree, built faster).
    ``oriented``: each node also weighs the split of its boxes by their longest spatial axis
    (``kernels/bvh_build``; the bottom levels' builds: crossing thin triangles).
    ``threads``: 2 builds the subtrees of a large build on two threads, 1 on the calling
    thread alone (for builds that already run side by side: the same tree).
    ``float32_boxes``: the boxes are float32 numbers (a bottom level's triangles), so are
    the node boxes, reduced in a Warp kernel (the same values, without float64 copies).
    ``centre``: the boxes' float32 centres, a Warp vec4 array on the CPU, with ``prim_lo``
    / ``prim_hi`` Warp arrays too (a bottom level's, made by
    ``kernels/blas_build.tri_boxes``; with ``float32_boxes``); the arrays are reordered
    into leaf order in place."""
    start_clock = time.perf_counter()
    n = len(prim_lo)
    if n == 0:
        # No primitives: one leaf whose box lies at t = +inf, which no null ray on a
        # past (or infinite-c) lightcone enters (the kernels test the root's box before
        # anything else; bvh_wide.collapse gives one empty wide node).
        far = np.array([[np.inf, 0.0, 0.0, 0.0]])
        return FlatBVH(far, far.copy(), np.zeros(1, np.int32), np.zeros(1, np.int32), np.zeros(0, np.int64), 0, 0.0)
    import warp as wp

    if centre is None:
        plo, phi = (wp.array(b.astype(np.float32), dtype=wp.vec4, device="cpu") for b in (prim_lo, prim_hi))
        centre = wp.array((0.5 * (prim_lo + prim_hi)).astype(np.float32), dtype=wp.vec4, device="cpu")
    else:
        plo, phi = prim_lo, prim_hi
    kernels = _sah_kernel(SAH_COST_INTERSECT[primitive], leaf_size, uniform_t, oriented)
    first, count, order, depth, plo, phi = _sah_topology(plo, phi, centre, kernels[0], threads)
    if float32_boxes:
        lo, hi = _bounds32(kernels[1], first, count, plo, phi)
    else:
        lo, hi = _bounds64(kernels[2], first, count, order, prim_lo, prim_hi)
    return FlatBVH(
        node_lo=lo,
        node_hi=hi,
        node_first=first.astype(np.int32),
        node_count=count.astype(np.int32),
        order=order,
        depth=depth,
        build_seconds=time.perf_counter() - start_clock,
    )


def load_builder(primitive: str = "tet", *, leaf_size: int = LEAF_SIZE, uniform_t: bool = False,
                 oriented: bool = False) -> None:
    """Make and load the tree kernel ``build_bvh`` uses with these arguments (and the
    node-box kernels, in its module), on the calling thread, so that builds on other
    threads only launch them (Warp's code generation parses Python with ``ast``, which
    CPython 3.11 does not allow on two threads at once: docs/design/two-level.md)."""
    import warp as wp

    wp.load_module(_sah_kernel(SAH_COST_INTERSECT[primitive], leaf_size, uniform_t, oriented)[0].module, device="cpu")


def _sah_topology(plo, phi, centre, kernel, threads: int):
    """Node ranges by binned SAH (``kernels/bvh_build.sah_tree``): the node slots' first
    child or primitive and count (children after their parent, side by side, the left
    subtree before the right one), the order, the tree's depth and the primitive boxes
    in leaf order. A build of ``SPLIT_MIN`` primitives or more makes its top
    ``TOP_DEPTH`` levels first, then the subtrees under them, on ``threads`` threads (up
    to 2): the slots are the same for any thread count."""
    import warp as wp

    n = len(plo)
    order_w = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device="cpu")
    split = n >= SPLIT_MIN
    cap = 2 * n + (2 << TOP_DEPTH if split else 0)
    first = wp.empty(cap, dtype=wp.int32, device="cpu")
    count = wp.empty(cap, dtype=wp.int32, device="cpu")
    depth = wp.empty(cap, dtype=wp.int32, device="cpu")

    def grow(roots, starts, ends, depths, bases, stop):
        used = wp.empty(len(roots), dtype=wp.int32, device="cpu")
        ints = [wp.array(np.asarray(a, np.int32), dtype=wp.int32, device="cpu") for a in (roots, starts, ends, depths,
                                                                                           bases)]
        wp.launch(kernel, dim=len(roots), inputs=[centre, plo, phi, order_w, *ints, stop, first, count, depth, used],
                  device="cpu")
        return used.numpy()

    top = 1 + int(grow([0], [0], [n], [0], [1], TOP_DEPTH if split else MAX_DEPTH + 1)[0])
    f, c, d = first.numpy(), count.numpy(), depth.numpy()
    held = np.nonzero(c[:top] < 0)[0]  # the open nodes at the top's last level
    if len(held) == 0:
        f, c, d = f[:top], c[:top], d[:top]
    else:
        starts = f[held].astype(np.int64)
        ends = starts - c[held]
        bases = top + 2 * starts  # a subtree of m primitives takes at most 2 m - 2 slots
        args = (held, starts, ends, d[held], bases, MAX_DEPTH + 1)
        if threads >= 2 and len(held) > 1:
            # One launch per subtree, largest first, taken by the two threads as they
            # come free.
            big = np.argsort(starts - ends, kind="stable")
            used = np.empty(len(held), np.int64)
            done = thread_pool(2, "warp-st-bvh").map(lambda k: grow(*(a[k:k + 1] for a in args[:5]), args[5]), big)
            for k, u in zip(big, done):
                used[k] = u[0]
        else:
            used = grow(*args)
        # Drop the slots the subtrees left free.
        keep = np.zeros(cap, bool)
        keep[:top] = True
        taken = np.repeat(bases - np.cumsum(np.r_[0, used[:-1]]), used) + np.arange(int(used.sum()))
        keep[taken] = True
        slot = np.cumsum(keep) - 1
        f, c, d = f[keep], c[keep], d[keep]
        f = np.where(c == 0, slot[f], f)
    return f.astype(np.int64), c.astype(np.int64), order_w.numpy().astype(np.int64), int(d.max()) + 1, plo, phi


_SAH_KERNELS: dict = {}


def _sah_kernel(cost_intersect: float, leaf_size: int, uniform_t: bool = False, oriented: bool = False):
    """The tree kernel and the node-box kernels (one module, ``kernels/bvh_build``) for one
    intersection cost and leaf size, made once per process."""
    from warp_st.kernels.bvh_build import make_sah_build

    key = (cost_intersect, leaf_size, uniform_t, oriented)
    if key not in _SAH_KERNELS:
        _SAH_KERNELS[key] = make_sah_build(leaf_size, SAH_MAX_LEAF, SAH_COST_TRAVERSE, cost_intersect, uniform_t, oriented)
    return _SAH_KERNELS[key]


def _bounds32(node_boxes, first, count, plo, phi):
    """Node boxes in float32 by ``node_boxes`` (``kernels.bvh_build``) from the
    primitives' boxes in leaf order (``plo``/``phi``, as the tree kernel leaves them)."""
    import warp as wp

    m = len(first)
    lo = wp.empty(m, dtype=wp.vec4, device="cpu")
    hi = wp.empty(m, dtype=wp.vec4, device="cpu")
    wp.launch(node_boxes, dim=1, inputs=[wp.array(first.astype(np.int32), dtype=wp.int32, device="cpu"),
                                         wp.array(count.astype(np.int32), dtype=wp.int32, device="cpu"), plo, phi, lo,
                                         hi], device="cpu")
    return lo.numpy(), hi.numpy()


def _bounds64(node_boxes64, first, count, order, prim_lo, prim_hi):
    """Node boxes in float64 by ``node_boxes64`` (``kernels.bvh_build``) from the
    primitives' boxes ``prim_lo``/``prim_hi`` in their input order (the leaves' slots
    through ``order``): min and max round nothing, so these are NumPy's reductions."""
    import warp as wp

    def arr(a, dtype):
        return wp.array(np.ascontiguousarray(a, dtype=np.float64 if dtype is wp.vec4d else np.int32), dtype=dtype,
                        device="cpu")

    m = len(first)
    lo = wp.empty(m, dtype=wp.vec4d, device="cpu")
    hi = wp.empty(m, dtype=wp.vec4d, device="cpu")
    wp.launch(node_boxes64, dim=1, inputs=[arr(first, wp.int32), arr(count, wp.int32), arr(order, wp.int32),
                                           arr(prim_lo, wp.vec4d), arr(prim_hi, wp.vec4d), lo, hi], device="cpu")
    return lo.numpy(), hi.numpy()
