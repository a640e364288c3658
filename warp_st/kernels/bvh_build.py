"""Binned SAH build of BVHs over 4D boxes (pure Warp device code, one thread per subtree).

A thread builds a whole subtree depth first (``sah_tree``, one launch per tree or per
batch of subtrees, not one per level: docs/design/two-level.md). Each node's split
(``split``) takes the node's contiguous range of the primitive order, bins the
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

__all__ = ["BINS", "make_sah_build"]

#: Bins per axis.
BINS = 16
#: Depth bound of a tree (its nodes on the build's stack, one more than the depth).
STACK = MAX_DEPTH + 2


def make_sah_build(min_leaf: int, max_leaf: int, cost_traverse: float, cost_intersect: float, uniform_t: bool = False,
                   oriented: bool = False):
    """The tree kernel and the node-box kernels (float32 boxes in leaf order, float64
    ones through the order), in one module (loaded together);
    ``uniform_t``: every primitive has the same time extent (a 3D build,
    ``accel/blas.py``), so the time axis gets no bins (the same trees); ``oriented``: each
    node also weighs the orientation split (``split``)."""
    T0 = 1 if uniform_t else 0
    vec4 = wp.vec4
    bins_i = wp.types.vector(BINS, wp.int32)
    bins_f = wp.types.vector(BINS, wp.float32)
    AXES = 4 - T0  # the binned axes: t, x, y, z, or (uniform_t) x, y, z
    axes_i = wp.types.vector(AXES * BINS, wp.int32)
    axes_box = wp.types.matrix(shape=(AXES * BINS, 4), dtype=wp.float32)  # a bin box corner a row
    BIG = 3.0e38
    # The orientation split's best_axis is ORIENTED + the axis (``split``).
    ORIENT = bool(oriented)
    ORIENTED = 8

    @wp.func
    def area4(lo: vec4, hi: vec4) -> float:
        e = wp.max(hi - lo, vec4(0.0))
        return e[0] * (e[1] * e[2] + e[2] * e[3] + e[3] * e[1]) + e[1] * e[2] * e[3]

    @wp.func
    def longest(lo: vec4, hi: vec4) -> int:
        """The spatial axis (1-3: x, y, z) along which the box is longest, the first of equals."""
        e = hi - lo
        a = int(1)
        if e[2] > e[a]:
            a = 2
        if e[3] > e[a]:
            a = 3
        return a

    @wp.func
    def bin_of(c: float, lo: float, scale: float) -> int:
        return wp.clamp(int((c - lo) * scale), 0, BINS - 1)

    @wp.func
    def split(centre: wp.array(dtype=vec4), plo: wp.array(dtype=vec4), phi: wp.array(dtype=vec4),
              order: wp.array(dtype=wp.int32), s0: int, s1: int, force_median: int):
        """The split of the node of range [s0, s1): its first right primitive, its range
        partitioned in place; -1: the node is a leaf."""
        n = s1 - s0
        if n <= min_leaf:
            return -1
        # Node box and centre bounds.
        nlo = vec4(BIG)
        nhi = vec4(-BIG)
        clo = vec4(BIG)
        chi = vec4(-BIG)
        for k in range(s0, s1):
            nlo = wp.min(nlo, plo[k])
            nhi = wp.max(nhi, phi[k])
            clo = wp.min(clo, centre[k])
            chi = wp.max(chi, centre[k])
        best_cost = float(BIG)
        best_axis = int(-1)
        best_bin = int(-1)
        if force_median == 0:
            parent_area = wp.max(area4(nlo, nhi), 1.0e-30)
            # One pass over the primitives bins all four axes (independent chains of
            # min/max for the processor to overlap); the sweeps then go axis by axis.
            scales = vec4(0.0)
            for axis in range(4):
                extent = chi[axis] - clo[axis]
                if extent > 0.0:
                    scales[axis] = float(BINS) / extent
            # A bin's box corners are rows, set to the empty box, then widened by one
            # vector min and max per primitive (the time axis, unbinned with
            # ``uniform_t``, has no bins); the sweeps step over empty bins (a split at an
            # empty bin has its neighbour's sets, cost and tie order).
            count = axes_i()
            box_lo = axes_box()
            box_hi = axes_box()
            for b in range(AXES * BINS):
                box_lo[b] = vec4(BIG)
                box_hi[b] = vec4(-BIG)
            # ``oriented``: the primitives grouped by their boxes' longest axis (``longest``)
            # for the orientation split below, in the same pass.
            if wp.static(ORIENT):
                o_count = wp.vec4i(0)
                o_lo = wp.mat44f()
                o_hi = wp.mat44f()
                for a in range(4):
                    o_lo[a] = vec4(BIG)
                    o_hi[a] = vec4(-BIG)
            for k in range(s0, s1):
                cp = centre[k]
                lo = plo[k]
                hi = phi[k]
                for axis in range(T0, 4):
                    if scales[axis] > 0.0:
                        b = (axis - T0) * BINS + bin_of(cp[axis], clo[axis], scales[axis])
                        count[b] = count[b] + 1
                        box_lo[b] = wp.min(box_lo[b], lo)
                        box_hi[b] = wp.max(box_hi[b], hi)
                if wp.static(ORIENT):
                    a = longest(lo, hi)
                    o_count[a] = o_count[a] + 1
                    o_lo[a] = wp.min(o_lo[a], lo)
                    o_hi[a] = wp.max(o_hi[a], hi)
            for axis in range(T0, 4):
                if scales[axis] > 0.0:
                    o = (axis - T0) * BINS
                    # Sweep from the right: area and count of bins b..BINS-1.
                    right_area = bins_f()
                    right_count = bins_i()
                    rlo = vec4(BIG)
                    rhi = vec4(-BIG)
                    rn = int(0)
                    r_area = float(0.0)
                    for j in range(BINS - 1, 0, -1):
                        if count[o + j] > 0:
                            rlo = wp.min(rlo, box_lo[o + j])
                            rhi = wp.max(rhi, box_hi[o + j])
                            rn = rn + count[o + j]
                            r_area = area4(rlo, rhi)
                        right_area[j] = r_area
                        right_count[j] = rn
                    llo = vec4(BIG)
                    lhi = vec4(-BIG)
                    ln = int(0)
                    for j in range(BINS - 1):
                        if count[o + j] > 0:
                            llo = wp.min(llo, box_lo[o + j])
                            lhi = wp.max(lhi, box_hi[o + j])
                            ln = ln + count[o + j]
                            rn_j = right_count[j + 1]
                            if rn_j > 0:
                                cost = cost_traverse + cost_intersect * (
                                    area4(llo, lhi) * float(ln) + right_area[j + 1] * float(rn_j)
                                ) / parent_area
                                if cost < best_cost:
                                    best_cost = cost
                                    best_axis = axis
                                    best_bin = j
            if wp.static(ORIENT):
                # The orientation split: the primitives longest along one axis against the
                # rest. Crossing thin primitives (a reticle's lines, a plus sign) share
                # their centres, so no bin boundary separates them; this does.
                for a in range(1, 4):
                    if o_count[a] > 0 and o_count[a] < n:
                        rlo = vec4(BIG)
                        rhi = vec4(-BIG)
                        for b in range(1, 4):
                            if b != a:
                                rlo = wp.min(rlo, o_lo[b])
                                rhi = wp.max(rhi, o_hi[b])
                        cost = cost_traverse + cost_intersect * (
                            area4(o_lo[a], o_hi[a]) * float(o_count[a]) + area4(rlo, rhi) * float(n - o_count[a])
                        ) / parent_area
                        if cost < best_cost:
                            best_cost = cost
                            best_axis = ORIENTED + a
                            best_bin = 0
            if n <= max_leaf and cost_intersect * float(n) <= best_cost:
                return -1  # a leaf is cheaper
        mid = s0 + n / 2
        if best_axis >= 0:
            binned = best_axis < ORIENTED
            axis = wp.where(binned, best_axis, 0)
            scale = float(BINS) / wp.max(chi[axis] - clo[axis], 1.0e-30)
            lo_i = s0
            hi_i = s1 - 1
            while lo_i <= hi_i:
                left = int(0)
                if binned:
                    if bin_of(centre[lo_i][axis], clo[axis], scale) <= best_bin:
                        left = 1
                elif longest(plo[lo_i], phi[lo_i]) == best_axis - ORIENTED:
                    left = 1
                if left != 0:
                    lo_i += 1
                else:
                    tmp = order[lo_i]
                    order[lo_i] = order[hi_i]
                    order[hi_i] = tmp
                    tc = centre[lo_i]
                    centre[lo_i] = centre[hi_i]
                    centre[hi_i] = tc
                    tl = plo[lo_i]
                    plo[lo_i] = plo[hi_i]
                    plo[hi_i] = tl
                    th = phi[lo_i]
                    phi[lo_i] = phi[hi_i]
                    phi[hi_i] = th
                    hi_i -= 1
            if lo_i > s0 and lo_i < s1:
                mid = lo_i
        return mid

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
                mid = split(centre, plo, phi, order, s0, s1, wp.where(d >= SAH_FREE_DEPTH, 1, 0))
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
