"""A bottom level's build steps around its SAH tree (pure Warp device code, accel/blas.py).

- ``tri_boxes``: each triangle's float32 box and centre, the SAH builder's inputs, from
  the shape's points and vertex indices (one thread a triangle).
- ``quantise``: each wide node's four child boxes, one float32 step outward, as a byte
  per coordinate in the node's frame (one thread a wide node). Every step is the float64
  arithmetic of the rule ``accel/blas.quantised_boxes`` states, so the bytes and frames
  are those of its NumPy twin (tests/accel/test_blas.py), bit for bit. Warp has no
  ``nextafter`` or ``spacing``: ``ulp32`` and ``next_down32`` give them for float32 values
  held in float64, from exact powers of two (``pow2_floor``).
"""
import warp as wp

__all__ = ["tri_boxes", "quantise", "STEPS"]

#: Quantisation steps of a child box coordinate within its wide node (one byte).
STEPS = 255
#: The smallest normal float32 and the float32 subnormal step.
TINY32 = 1.1754943508222875e-38  # 2^-126
SUB32 = 1.401298464324817e-45  # 2^-149
#: The float32 gap above 1, and the powers 2^(2^k) of the exponent search.
ULP1 = 2.0 ** -23
P128, P64, P32, P16, P8, P4, P2, P1 = (2.0 ** (1 << k) for k in range(7, -1, -1))


vec8d = wp.types.vector(8, wp.float64)
vec12d = wp.types.vector(12, wp.float64)


@wp.func
def pow2_floor(a: wp.float64):
    """The largest power of two <= a (2^-149 <= a < 2^128), exactly: a binary search of
    the exponent by exact products (with ``log2`` and ``pow`` instead, ``quantise`` took
    2.6 times as long)."""
    up = vec8d(P128, P64, P32, P16, P8, P4, P2, P1)
    p = wp.float64(1.0)
    if a >= wp.float64(1.0):
        for j in range(8):
            if a >= p * up[j]:
                p = p * up[j]
        return p
    # The smallest power of two above a, halved.
    for j in range(8):
        if p / up[j] > a:
            p = p / up[j]
    return p * wp.float64(0.5)


@wp.func
def ulp32(a: wp.float64):
    """``np.spacing`` of the float32 value a >= 0: the gap to the next float32 up."""
    if a < wp.float64(TINY32):
        return wp.float64(SUB32)
    return pow2_floor(a) * wp.float64(ULP1)


@wp.func
def next_down32(x: wp.float64):
    """``np.nextafter(x, -inf)`` of the float32 value x, exactly (held in float64)."""
    if x > wp.float64(0.0):
        if x <= wp.float64(TINY32):
            return x - wp.float64(SUB32)
        p = pow2_floor(x)
        step = p * wp.float64(ULP1)
        if p == x:
            step = step * wp.float64(0.5)  # below a power of two the gap halves
        return x - step
    if x == wp.float64(0.0):
        return -wp.float64(SUB32)
    return x - ulp32(-x)


@wp.func
def next_up32(x: wp.float64):
    """``np.nextafter(x, +inf)`` of the float32 value x, exactly."""
    return -next_down32(-x)


@wp.kernel(enable_backward=False)
def tri_boxes(points: wp.array(dtype=wp.vec3), vidx: wp.array(dtype=wp.vec3i), lo: wp.array(dtype=wp.vec4),
              hi: wp.array(dtype=wp.vec4), centre: wp.array(dtype=wp.vec4)):
    """Triangle i's box (time 0; the caller sets the extent) and its centre."""
    i = wp.tid()
    t = vidx[i]
    a = points[t[0]]
    b = points[t[1]]
    c = points[t[2]]
    bl = wp.min(wp.min(a, b), c)
    bh = wp.max(wp.max(a, b), c)
    lo[i] = wp.vec4(0.0, bl[0], bl[1], bl[2])
    hi[i] = wp.vec4(0.0, bh[0], bh[1], bh[2])
    centre[i] = (lo[i] + hi[i]) * wp.float32(0.5)


@wp.kernel(enable_backward=False)
def quantise(node_lo: wp.array(dtype=wp.vec4), node_hi: wp.array(dtype=wp.vec4), slot_node: wp.array2d(dtype=wp.int32),
             q: wp.array2d(dtype=wp.uint8), frame: wp.array2d(dtype=wp.float32)):
    """Wide node w's slots' binary nodes ``slot_node[w]`` (-1: empty; boxes (t, x, y, z),
    the time ignored): q[w] the lower corners' bytes axis-major (x0..x3, y0..y3, z0..z3),
    then the upper ones'; frame[w] the origin and step per axis."""
    w = wp.tid()
    lo = vec12d()
    hi = vec12d()
    for axis in range(3):
        low = wp.float64(wp.inf)
        high = wp.float64(-wp.inf)
        for k in range(4):
            s = slot_node[w, k]
            if s >= 0:
                lo[4 * axis + k] = next_down32(wp.float64(node_lo[s][1 + axis]))
                hi[4 * axis + k] = next_up32(wp.float64(node_hi[s][1 + axis]))
                low = wp.min(low, lo[4 * axis + k])
                high = wp.max(high, hi[4 * axis + k])
        top = wp.float64(wp.float32(wp.max(wp.abs(low), wp.abs(high))))  # a float32 value
        margin = wp.float64(4.0) * ulp32(top) + wp.float64(1.0e-30)
        origin = wp.float64(wp.float32(low - margin))
        if origin > low - margin:
            origin = next_down32(origin)
        step64 = (high + margin - origin) / wp.float64(STEPS)
        step = wp.float64(wp.float32(step64))
        if step < step64:
            step = next_up32(step)
        frame[w, axis] = wp.float32(origin)
        frame[w, 3 + axis] = wp.float32(step)
        for k in range(4):
            q_lo = wp.float64(0.0)
            q_hi = wp.float64(0.0)
            if slot_node[w, k] >= 0:
                q_lo = wp.clamp(wp.floor((lo[4 * axis + k] - margin - origin) / step), wp.float64(0.0),
                                wp.float64(STEPS))
                q_hi = wp.clamp(wp.ceil((hi[4 * axis + k] + margin - origin) / step), wp.float64(0.0),
                                wp.float64(STEPS))
            q[w, 4 * axis + k] = wp.uint8(int(q_lo))
            q[w, 12 + 4 * axis + k] = wp.uint8(int(q_hi))


@wp.kernel(enable_backward=False)
def open_largest(first: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32), area: wp.array(dtype=wp.float64),
                 wide: wp.array(dtype=wp.int32), slots: wp.array2d(dtype=wp.int32)):
    """On one thread: every binary inner node that is a wide node (``wide`` its wide depth,
    from 1; 0: not one; the root's set by the caller), in index order (a node's children
    come after it), gets its four slots: its two children with the inner slot of largest
    ``area`` (the first of equals) replaced by its two children, twice (-1: empty); the
    inner slots become wide nodes one level deeper."""
    m = first.shape[0]
    for b in range(m):
        if wide[b] > 0:
            s = wp.vec4i(first[b], first[b] + 1, -1, -1)
            filled = int(2)
            for _step in range(2):
                pick = int(-1)
                best = wp.float64(-1.0)
                for j in range(4):
                    if j < filled and count[s[j]] == 0 and area[s[j]] > best:
                        best = area[s[j]]
                        pick = j
                if pick >= 0:
                    c = first[s[pick]]
                    for jj in range(3):  # shift the slots after pick one place on
                        j = 3 - jj
                        if j > pick + 1:
                            s[j] = s[j - 1]
                    s[pick] = c
                    s[pick + 1] = c + 1
                    filled += 1
            for j in range(4):
                slots[b, j] = s[j]
                if s[j] >= 0 and count[s[j]] == 0:
                    wide[s[j]] = wide[b] + 1
