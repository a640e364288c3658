"""A bottom level's build steps around its SAH tree (device code, accel/blas.py).

- ``tri_boxes``: each triangle's float32 box and centre, the SAH builder's inputs, from
  the shape's points and vertex indices (one thread a triangle).
- ``quantise``: each wide node's four child boxes, one float32 step outward, as a byte
  per coordinate in the node's frame (one thread a wide node, C++: ``quantise.inc``).
  Every step is the float64 arithmetic of the rule ``accel/blas.quantised_boxes`` states,
  so the bytes and frames are those of its NumPy twin (tests/accel/test_blas.py), bit for
  bit; the float32 neighbours and gaps come from the values' bits (the Warp-language
  version searched the exponent by products: 3.4 ms against 1.3 for a 65k-triangle shape).
"""
import warp as wp

from warp_st.kernels.native import snippet

__all__ = ["tri_boxes", "quantise", "STEPS"]

#: Quantisation steps of a child box coordinate within its wide node (one byte).
STEPS = 255


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


@wp.func_native(snippet("quantise.inc", STEPS=STEPS))
def native_quantise(node_lo: wp.array(dtype=wp.vec4), node_hi: wp.array(dtype=wp.vec4),
                    slot_node: wp.array2d(dtype=wp.int32), q: wp.array2d(dtype=wp.uint8),
                    frame: wp.array2d(dtype=wp.float32), w: int):
    """Wide node ``w``'s bytes and frame (``quantise.inc``)."""


@wp.kernel(enable_backward=False)
def quantise(node_lo: wp.array(dtype=wp.vec4), node_hi: wp.array(dtype=wp.vec4), slot_node: wp.array2d(dtype=wp.int32),
             q: wp.array2d(dtype=wp.uint8), frame: wp.array2d(dtype=wp.float32)):
    """Wide node w's slots' binary nodes ``slot_node[w]`` (-1: empty; boxes (t, x, y, z),
    the time ignored): q[w] the lower corners' bytes axis-major (x0..x3, y0..y3, z0..z3),
    then the upper ones'; frame[w] the origin and step per axis."""
    native_quantise(node_lo, node_hi, slot_node, q, frame, wp.tid())


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
