"""The 4-wide BVH the kernel traces (warp_st/bvh_wide.py) against the binary tree it
collapses: the same leaves, each reachable exactly once, with the binary boxes."""
import numpy as np
import pytest

from warp_st.accel.bvh import SPLIT_MIN, build_bvh
from warp_st.accel.bvh_wide import LINK_MASK, LINK_SHIFT, MAX_WIDE_DEPTH, WIDTH, collapse, wide_boxes


def _boxes(n, seed):
    rng = np.random.default_rng(seed)
    c = rng.random((n, 4)) * [10.0, 5.0, 5.0, 5.0]
    half = rng.random((n, 4)) * 0.2
    return c - half, c + half


def _walk(wide):
    """Every leaf (first, count) reachable from the root, and the wide nodes visited."""
    leaves, seen, todo = [], [], [0]
    while todo:
        j = todo.pop()
        seen.append(j)
        for link in wide.link[j]:
            if link < 0:
                continue
            first, count = int(link) >> LINK_SHIFT, int(link) & LINK_MASK
            if count:
                leaves.append((first, count))
            else:
                todo.append(first)
    return leaves, seen


@pytest.mark.parametrize("n", [1, 3, 4, 5, 17, 1000, 20000])
def test_wide_tree_has_the_binary_leaves_once(n):
    lo, hi = _boxes(n, n)
    bvh = build_bvh(lo, hi, primitive="prism")
    wide = collapse(bvh)
    leaves, seen = _walk(wide)
    binary = sorted((int(f), int(c)) for f, c in zip(bvh.node_first, bvh.node_count) if c > 0)
    assert sorted(leaves) == binary
    assert sorted(seen) == list(range(wide.node_count)), "every wide node reachable exactly once"
    # The leaves partition the primitive order.
    covered = np.zeros(n, int)
    for first, count in leaves:
        covered[first:first + count] += 1
    assert (covered == 1).all()
    # Two binary levels per wide level: the traversal stack is sized by this bound.
    assert wide.depth <= (bvh.depth + 1) // 2


def _area(bvh):
    e = np.maximum(bvh.node_hi[:, 1:].astype(np.float64) - bvh.node_lo[:, 1:], 0.0)
    return e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]


def _open_largest_rule(bvh, area):
    """The rule of ``collapse(bvh, area)`` in plain Python: each wide node's slots (by its
    binary node), its two children with the inner slot of largest area (the first of
    equals) replaced by its two children, twice."""
    first, count = bvh.node_first.astype(int), bvh.node_count.astype(int)
    out, todo = {}, [0]
    while todo:
        b = todo.pop()
        slots = [first[b], first[b] + 1]
        for _ in range(2):
            inner = [x for x in slots if count[x] == 0]
            if inner:
                s = max(inner, key=lambda x: area[x])
                i = slots.index(s)
                slots[i:i + 1] = [first[s], first[s] + 1]
        out[b] = slots + [-1] * (WIDTH - len(slots))
        todo += [x for x in slots if count[x] == 0]
    return out


@pytest.mark.parametrize("n", [1, 5, 17, 1000, 20000])
def test_a_collapse_opening_the_largest_boxes_keeps_every_leaf_once(n):
    """Law: the collapse that fills a wide node by opening its largest inner slots
    (``collapse(bvh, area)``, the bottom levels') holds every binary leaf exactly once,
    reaches every wide node once, has the slots of the plain-Python rule (the same rows,
    each under its binary node's wide node) and stays within the traversal stack's depth
    bound (``MAX_WIDE_DEPTH``)."""
    lo, hi = _boxes(n, n + 1)
    lo[:, 0], hi[:, 0] = 0.0, 1.0e3
    bvh = build_bvh(lo, hi, "tri", leaf_size=4, uniform_t=True)
    area = _area(bvh)
    wide = collapse(bvh, area)
    leaves, seen = _walk(wide)
    binary = sorted((int(f), int(c)) for f, c in zip(bvh.node_first, bvh.node_count) if c > 0)
    assert sorted(leaves) == binary
    assert sorted(seen) == list(range(wide.node_count))
    assert wide.depth <= MAX_WIDE_DEPTH
    if bvh.node_count[0] == 0:
        rule = _open_largest_rule(bvh, area)
        assert sorted(map(tuple, wide.slot_node.tolist())) == sorted(map(tuple, rule.values()))
        assert len(rule) == wide.node_count


def test_wide_boxes_are_the_binary_boxes_axis_major():
    lo, hi = _boxes(500, 7)
    bvh = build_bvh(lo, hi, primitive="prism")
    wide = collapse(bvh)
    wlo, whi = wide_boxes(wide, bvh.node_lo, bvh.node_hi)
    assert wlo.shape == (wide.node_count, 4 * WIDTH)
    for j in range(wide.node_count):
        for k in range(WIDTH):
            node = wide.slot_node[j, k]
            got_lo, got_hi = wlo[j, k::WIDTH], whi[j, k::WIDTH]
            if node < 0:  # an empty slot: the box t = +inf, never entered
                assert got_lo[0] == np.inf and got_hi[0] == np.inf
            else:
                np.testing.assert_array_equal(got_lo, bvh.node_lo[node])
                np.testing.assert_array_equal(got_hi, bvh.node_hi[node])


def test_empty_database_has_one_empty_wide_node():
    bvh = build_bvh(np.zeros((0, 4)), np.zeros((0, 4)))
    wide = collapse(bvh)
    assert wide.node_count == 1 and (wide.link == -1).all()


@pytest.mark.parametrize("n", [5, 40, 3000])
def test_a_3d_build_is_the_4d_build_of_the_same_boxes(n):
    """Law: with every box over the same time extent (a bottom level's triangles), the
    builder's ``uniform_t`` shortcut (bins take the time extent from the node, not per
    primitive) builds the same tree: node boxes, links and order, bit for bit."""
    lo, hi = _boxes(n, seed=n)
    lo[:, 0], hi[:, 0] = 0.0, 1.0e3
    ref = build_bvh(lo, hi, "tri", leaf_size=4)
    fast = build_bvh(lo, hi, "tri", leaf_size=4, uniform_t=True)
    assert ref.node_count_total > 1
    for name in ("node_lo", "node_hi", "node_first", "node_count", "order"):
        assert np.array_equal(getattr(ref, name), getattr(fast, name)), name


@pytest.mark.parametrize("uniform_t", [False, True])
def test_a_build_on_one_thread_is_the_build_on_two(uniform_t):
    """Law: ``threads=1`` (the bottom levels' builds that run side by side on the
    pool, accel/blas.py) builds every subtree on the calling thread, and the tree is the
    one built with the subtrees under the top levels on two threads (disjoint node
    ranges on each), bit for bit, node numbers too. 20,000 boxes are more than the
    builder's ``SPLIT_MIN``."""
    lo, hi = _boxes(20000, seed=3)
    if uniform_t:
        lo[:, 0], hi[:, 0] = 0.0, 1.0e3
    one = build_bvh(lo, hi, "tri", leaf_size=4, uniform_t=uniform_t, threads=1)
    two = build_bvh(lo, hi, "tri", leaf_size=4, uniform_t=uniform_t, threads=2)
    assert len(lo) >= SPLIT_MIN and one.node_count_total > 4 * 64
    for name in ("node_lo", "node_hi", "node_first", "node_count", "order"):
        assert np.array_equal(getattr(one, name), getattr(two, name)), name


@pytest.mark.parametrize("uniform_t", [False, True])
def test_float32_node_boxes_are_the_float64_ones(uniform_t):
    """Law: for boxes that are float32 numbers (a bottom level's triangles), the node
    boxes ``float32_boxes`` reduces in a Warp kernel (``kernels.bvh_build.node_boxes``,
    from the tree kernel's primitives in leaf order) are the float64 reduction's, every
    node, bit for bit (min and max round nothing), over the same tree."""
    lo, hi = _boxes(3000, seed=11)
    if uniform_t:
        lo[:, 0], hi[:, 0] = 0.0, 1.0e3
    lo, hi = lo.astype(np.float32), hi.astype(np.float32)
    ref = build_bvh(lo.astype(np.float64), hi.astype(np.float64), "tri", leaf_size=4, uniform_t=uniform_t)
    fast = build_bvh(lo, hi, "tri", leaf_size=4, uniform_t=uniform_t, float32_boxes=True)
    assert fast.node_lo.dtype == np.float32 and fast.node_count_total > 100
    for name in ("node_first", "node_count", "order"):
        assert np.array_equal(getattr(ref, name), getattr(fast, name)), name
    assert np.array_equal(ref.node_lo, fast.node_lo.astype(np.float64))
    assert np.array_equal(ref.node_hi, fast.node_hi.astype(np.float64))
