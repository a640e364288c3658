"""Binned SAH split of BVH nodes over 4D boxes (pure Warp device code, one thread per node).

Each thread takes one node's contiguous range of the primitive order, bins the
primitive centres along each of the four axes (t, x, y, z) in one pass (the trees are
the same as binning axis by axis; the build of a 65k-triangle bottom level is 25 %
faster: 71-76 ms against 95-101, medians of 7, alternated), evaluates the surface-area
heuristic at every bin boundary and partitions its range in place: the order and the
primitives' centres and boxes with it, so every pass reads them in sequence, not through
the order (the same trees). The 4D analogue of
a box's surface area is the sum of its 3-volumes, e_t (e_x e_y + e_y e_z + e_z e_x) +
e_x e_y e_z: for boxes sharing one time extent (bodies at rest) it orders splits like
the 3D surface area does. A second kernel of the same module reduces every node's box
from the partitioned primitives (float32 boxes: the bottom levels, ``accel/blas.py``).
"""
import warp as wp

__all__ = ["BINS", "make_sah_split"]

#: Bins per axis.
BINS = 16


def make_sah_split(min_leaf: int, max_leaf: int, cost_traverse: float, cost_intersect: float, uniform_t: bool = False):
    """The split kernel and the node-box kernel, in one module (loaded together);
    ``uniform_t``: every primitive has the same time extent (a 3D build,
    ``accel/blas.py``), which the bins then take from the node instead of reducing it
    per primitive (the same trees)."""
    T0 = 1 if uniform_t else 0
    vec4 = wp.vec4
    bins_i = wp.types.vector(BINS, wp.int32)
    bins_f = wp.types.vector(BINS, wp.float32)
    bins4_i = wp.types.vector(4 * BINS, wp.int32)
    bins4_box = wp.types.vector(4 * BINS * 8, wp.float32)
    BIG = 3.0e38

    @wp.func
    def area4(lo: vec4, hi: vec4) -> float:
        e = wp.max(hi - lo, vec4(0.0))
        return e[0] * (e[1] * e[2] + e[2] * e[3] + e[3] * e[1]) + e[1] * e[2] * e[3]

    @wp.func
    def bin_of(c: float, lo: float, scale: float) -> int:
        return wp.clamp(int((c - lo) * scale), 0, BINS - 1)

    @wp.kernel(enable_backward=False, module="unique")
    def sah_split(
        centre: wp.array(dtype=vec4),
        plo: wp.array(dtype=vec4),
        phi: wp.array(dtype=vec4),
        order: wp.array(dtype=wp.int32),
        seg_start: wp.array(dtype=wp.int32),
        seg_end: wp.array(dtype=wp.int32),
        force_median: int,
        out_mid: wp.array(dtype=wp.int32),
    ):
        i = wp.tid()
        s0 = seg_start[i]
        s1 = seg_end[i]
        n = s1 - s0
        out_mid[i] = -1
        if n <= min_leaf:
            return
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
            # A bin's box is set by its first primitive and read only when it holds one
            # (its count), so no bin is initialised; the sweeps step over empty bins (a
            # split at an empty bin has its neighbour's sets, cost and tie order).
            count = bins4_i()
            box = bins4_box()
            for k in range(s0, s1):
                cp = centre[k]
                lo = plo[k]
                hi = phi[k]
                for axis in range(4):
                    if scales[axis] > 0.0:
                        b = axis * BINS + bin_of(cp[axis], clo[axis], scales[axis])
                        held = count[b]
                        count[b] = held + 1
                        if held == 0:
                            for c in range(T0, 4):
                                box[b * 8 + c] = lo[c]
                                box[b * 8 + 4 + c] = hi[c]
                        else:
                            for c in range(T0, 4):
                                box[b * 8 + c] = wp.min(box[b * 8 + c], lo[c])
                                box[b * 8 + 4 + c] = wp.max(box[b * 8 + 4 + c], hi[c])
            if wp.static(T0 == 1):
                # Every primitive has the node's time extent: so has every bin holding one.
                for b in range(4 * BINS):
                    box[b * 8] = nlo[0]
                    box[b * 8 + 4] = nhi[0]
            for axis in range(4):
                if scales[axis] > 0.0:
                    o = axis * BINS
                    # Sweep from the right: area and count of bins b..BINS-1.
                    right_area = bins_f()
                    right_count = bins_i()
                    rlo = vec4(BIG)
                    rhi = vec4(-BIG)
                    rn = int(0)
                    r_area = float(0.0)
                    for j in range(BINS - 1, 0, -1):
                        if count[o + j] > 0:
                            q = (o + j) * 8
                            rlo = wp.min(rlo, vec4(box[q + 0], box[q + 1], box[q + 2], box[q + 3]))
                            rhi = wp.max(rhi, vec4(box[q + 4], box[q + 5], box[q + 6], box[q + 7]))
                            rn = rn + count[o + j]
                            r_area = area4(rlo, rhi)
                        right_area[j] = r_area
                        right_count[j] = rn
                    llo = vec4(BIG)
                    lhi = vec4(-BIG)
                    ln = int(0)
                    for j in range(BINS - 1):
                        if count[o + j] > 0:
                            q = (o + j) * 8
                            llo = wp.min(llo, vec4(box[q + 0], box[q + 1], box[q + 2], box[q + 3]))
                            lhi = wp.max(lhi, vec4(box[q + 4], box[q + 5], box[q + 6], box[q + 7]))
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
            if n <= max_leaf and cost_intersect * float(n) <= best_cost:
                return  # a leaf is cheaper
        mid = s0 + n / 2
        if best_axis >= 0:
            scale = float(BINS) / (chi[best_axis] - clo[best_axis])
            lo_i = s0
            hi_i = s1 - 1
            while lo_i <= hi_i:
                if bin_of(centre[lo_i][best_axis], clo[best_axis], scale) <= best_bin:
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
        out_mid[i] = mid

    @wp.kernel(enable_backward=False, module=sah_split.module)
    def node_boxes(
        first: wp.array(dtype=wp.int32),
        count: wp.array(dtype=wp.int32),
        plo: wp.array(dtype=vec4),
        phi: wp.array(dtype=vec4),
        lo: wp.array(dtype=vec4),
        hi: wp.array(dtype=vec4),
    ):
        """Every node's box, on one thread: nodes from the last to the root (a node's two
        children come after it), a leaf's from its primitives (``plo``/``phi`` in leaf
        order, as the split kernel leaves them), an inner node's from its children."""
        m = first.shape[0]
        for j in range(m):
            node = m - 1 - j
            f = first[node]
            c = count[node]
            if c > 0:
                a = plo[f]
                b = phi[f]
                for k in range(f + 1, f + c):
                    a = wp.min(a, plo[k])
                    b = wp.max(b, phi[k])
                lo[node] = a
                hi[node] = b
            else:
                lo[node] = wp.min(lo[f], lo[f + 1])
                hi[node] = wp.max(hi[f], hi[f + 1])

    return sah_split, node_boxes
