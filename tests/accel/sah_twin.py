"""The SAH builder's node split in Warp's own language: the twin of ``kernels/bvh_build.py``'s C++.

Until 0.10.4 this was the builder's split; the C++ one (``warp_st/kernels/sah_split.inc``)
computes the same operations in the same order with a box as one 4-lane value. The tests
hold the trees of the two equal bit for bit (tests/accel/test_sah_build.py), so this file
is the oracle that the native code's bins, sweeps, ties and partition are right; the
NumPy twin of the same test checks the rule itself (every split the cheapest bin
boundary).
"""
import warp as wp

from warp_st.kernels.bvh_build import BIG, BINS, ORIENTED

__all__ = ["make_split_twin"]


def make_split_twin(min_leaf: int, max_leaf: int, cost_traverse: float, cost_intersect: float, uniform_t: bool = False,
                    oriented: bool = False):
    """``split(centre, plo, phi, order, s0, s1, force_median) -> int``, the Warp function
    ``make_sah_build(..., split=)`` takes: the node over [s0, s1)'s first right primitive,
    its range partitioned in place; -1: a leaf."""
    T0 = 1 if uniform_t else 0
    vec4 = wp.vec4
    bins_i = wp.types.vector(BINS, wp.int32)
    bins_f = wp.types.vector(BINS, wp.float32)
    AXES = 4 - T0  # the binned axes: t, x, y, z, or (uniform_t) x, y, z
    axes_i = wp.types.vector(AXES * BINS, wp.int32)
    axes_box = wp.types.matrix(shape=(AXES * BINS, 4), dtype=wp.float32)  # a bin box corner a row
    ORIENT = bool(oriented)

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

    return split
