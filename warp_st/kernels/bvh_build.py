"""Binned SAH build of BVHs over 4D boxes (device code, one thread per subtree).

A thread builds a whole subtree depth first (``sah_tree``, one launch per tree or per
batch of subtrees, not one per level: docs/design/two-level.md). Each node's split
(C++ on clang's vector types since 0.10.4, ``sah_split.inc``: the trees of its
Warp-language twin, tests/accel/sah_twin.py, bit for bit, in two thirds of the time)
takes the node's contiguous range of the primitive order, bins the
primitive centres along each of the four axes (t, x, y, z) in one pass (the trees are
the same as binning axis by axis; the build of a 65k-triangle bottom level is 25 %
faster: 71-76 ms against 95-101, medians of 7, alternated), evaluates the surface-area
heuristic at every bin boundary and partitions its range in place: the order and the
primitives' centres and boxes with it, so every pass reads them in sequence, not through
the order (the same trees). The 4D analogue of
a box's surface area is the sum of its 3-volumes, e_t (e_x e_y + e_y e_z + e_z e_x) +
e_x e_y e_z: for boxes sharing one time extent (bodies at rest) it orders splits like
the 3D surface area does. With ``oriented`` (the bottom levels) a node also weighs the
split of its primitives by their boxes' longest spatial axis, which separates crossing
thin triangles whose centres coincide (docs/design/two-level.md, "The orientation split").
A second kernel of the same module reduces every node's box from the partitioned
primitives (float32 boxes: the bottom levels, ``accel/blas.py``).
"""
from typing import Any

import warp as wp

from warp_st.kernels.layout import MAX_DEPTH, SAH_FREE_DEPTH
from warp_st.kernels.native import snippet

__all__ = ["BINS", "make_sah_build"]

#: Bins per axis.
BINS = 16
#: A bin box's empty corners, and the orientation split's axis code base (``ORIENTED`` + the
#: axis of the primitives' longest side).
BIG = 3.0e38
ORIENTED = 8
#: Depth bound of a tree (its nodes on the build's stack, one more than the depth).
STACK = MAX_DEPTH + 2


def make_sah_build(min_leaf: int, max_leaf: int, cost_traverse: float, cost_intersect: float, uniform_t: bool = False,
                   oriented: bool = False, split=None):
    """The tree kernel and the node-box kernels (float32 boxes in leaf order, float64
    ones through the order), in one module (loaded together);
    ``uniform_t``: every primitive has the same time extent (a 3D build,
    ``accel/blas.py``), so the time axis gets no bins (the same trees); ``oriented``: each
    node also weighs the orientation split (``sah_split.inc``). ``split``: a Warp function
    to split nodes with instead of the C++ one (the tests' twin, tests/accel/sah_twin.py)."""
    T0 = 1 if uniform_t else 0
    vec4 = wp.vec4

    @wp.func_native(snippet("sah_split.inc", BINS=BINS, T0=T0, BIG=BIG, MIN_LEAF=min_leaf, MAX_LEAF=max_leaf,
                            COST_T=float(cost_traverse), COST_I=float(cost_intersect), ORIENT=int(bool(oriented)),
                            ORIENTED=ORIENTED))
    def native_split(centre: wp.array(dtype=vec4), plo: wp.array(dtype=vec4), phi: wp.array(dtype=vec4),
                     order: wp.array(dtype=wp.int32), s0: int, s1: int, force_median: int) -> int:
        """The first right primitive of the node over [s0, s1), its range partitioned in
        place; -1: a leaf (``sah_split.inc``)."""

    pick = native_split if split is None else split

    stack_i = wp.types.vector(4 * STACK, wp.int32)

    @wp.kernel(enable_backward=False, module="unique")
    def sah_tree(
        centre: wp.array(dtype=vec4),
        plo: wp.array(dtype=vec4),
        phi: wp.array(dtype=vec4),
        order: wp.array(dtype=wp.int32),
        root: wp.array(dtype=wp.int32),
        root_start: wp.array(dtype=wp.int32),
        root_end: wp.array(dtype=wp.int32),
        root_depth: wp.array(dtype=wp.int32),
        base: wp.array(dtype=wp.int32),
        stop_depth: int,
        node_first: wp.array(dtype=wp.int32),
        node_count: wp.array(dtype=wp.int32),
        node_depth: wp.array(dtype=wp.int32),
        used: wp.array(dtype=wp.int32),
    ):
        """Thread r builds the subtree under node slot ``root[r]`` over the range
        [root_start, root_end) at depth ``root_depth``, depth first: a split node's two
        children take the next two free slots from ``base[r]`` on (so they are adjacent
        and after their parent), and the left one is built first. A node at depth
        ``stop_depth`` is left open: count minus its primitive count, first its start.
        ``used[r]``: the slots the thread took from ``base[r]``."""
        r = wp.tid()
        st = stack_i()
        st[0] = root[r]
        st[1] = root_start[r]
        st[2] = root_end[r]
        st[3] = root_depth[r]
        sp = int(1)
        free = base[r]
        while sp > 0:
            sp -= 1
            node = st[4 * sp]
            s0 = st[4 * sp + 1]
            s1 = st[4 * sp + 2]
            d = st[4 * sp + 3]
            node_depth[node] = d
            if d >= stop_depth:
                node_first[node] = s0
                node_count[node] = s0 - s1
            else:
                mid = pick(centre, plo, phi, order, s0, s1, wp.where(d >= SAH_FREE_DEPTH, 1, 0))
                if mid < 0:
                    node_first[node] = s0
                    node_count[node] = s1 - s0
                else:
                    node_first[node] = free
                    node_count[node] = 0
                    # The right child below the left one on the stack: the left is next.
                    st[4 * sp] = free + 1
                    st[4 * sp + 1] = mid
                    st[4 * sp + 2] = s1
                    st[4 * sp + 3] = d + 1
                    st[4 * sp + 4] = free
                    st[4 * sp + 5] = s0
                    st[4 * sp + 6] = mid
                    st[4 * sp + 7] = d + 1
                    sp += 2
                    free += 2
        used[r] = free - base[r]

    @wp.func
    def reduce_nodes(first: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32), order: wp.array(dtype=wp.int32),
                     plo: Any, phi: Any, lo: Any, hi: Any, through_order: int):
        """Every node's box, on one thread: nodes from the last to the root (a node's two
        children come after it), a leaf's from its primitives (leaf slot k: primitive k,
        or ``order[k]`` with ``through_order``), an inner node's from its children."""
        m = first.shape[0]
        for j in range(m):
            node = m - 1 - j
            f = first[node]
            c = count[node]
            if c > 0:
                p = f
                if through_order != 0:
                    p = order[f]
                a = plo[p]
                b = phi[p]
                for k in range(f + 1, f + c):
                    p = k
                    if through_order != 0:
                        p = order[k]
                    a = wp.min(a, plo[p])
                    b = wp.max(b, phi[p])
                lo[node] = a
                hi[node] = b
            else:
                lo[node] = wp.min(lo[f], lo[f + 1])
                hi[node] = wp.max(hi[f], hi[f + 1])

    @wp.kernel(enable_backward=False, module=sah_tree.module)
    def node_boxes(first: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32), plo: wp.array(dtype=vec4),
                   phi: wp.array(dtype=vec4), lo: wp.array(dtype=vec4), hi: wp.array(dtype=vec4)):
        """Float32 node boxes from the primitives in leaf order (as the tree kernel leaves them; the
        order argument is not read)."""
        reduce_nodes(first, count, first, plo, phi, lo, hi, 0)

    @wp.kernel(enable_backward=False, module=sah_tree.module)
    def node_boxes64(first: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32), order: wp.array(dtype=wp.int32),
                     plo: wp.array(dtype=wp.vec4d), phi: wp.array(dtype=wp.vec4d), lo: wp.array(dtype=wp.vec4d),
                     hi: wp.array(dtype=wp.vec4d)):
        """Float64 node boxes from the primitives in their input order (leaf slot k holds
        primitive ``order[k]``)."""
        reduce_nodes(first, count, order, plo, phi, lo, hi, 1)

    return sah_tree, node_boxes, node_boxes64
