"""The binned SAH builder (accel/bvh.py, kernels/bvh_build.py) against a float64 NumPy
twin of its rule: every split is the cheapest bin boundary of the node's primitives, and
every leaf of more than the smallest size is no dearer than its cheapest split."""
import numpy as np
import pytest

from warp_st.accel.bvh import SAH_COST_INTERSECT, SAH_COST_TRAVERSE, SAH_MAX_LEAF, SPLIT_MIN, build_bvh
from warp_st.kernels.bvh_build import BINS

#: The kernel sums areas in float32 and the twin in float64, and a centre on a bin
#: boundary may fall into the neighbouring bin after the kernel's float32 rounding, so a
#: chosen split may cost a few float32 ulps of the parent's area more than the twin's
#: best (1e-4 relative is 800 ulps; a missed axis or a wrong sweep costs per cent).
RTOL = 1.0e-4


def _area4(lo, hi):
    e = np.maximum(hi - lo, 0.0)
    t, x, y, z = e[..., 0], e[..., 1], e[..., 2], e[..., 3]
    return t * (x * y + y * z + z * x) + x * y * z


def _cost(lo, hi, left, c_i, parent_area):
    """The SAH cost of splitting the boxes ``lo``/``hi`` into ``left`` and the rest."""
    right = ~left
    a_l = _area4(lo[left].min(0), hi[left].max(0))
    a_r = _area4(lo[right].min(0), hi[right].max(0))
    return SAH_COST_TRAVERSE + c_i * (a_l * left.sum() + a_r * right.sum()) / parent_area


def _best_cost(lo, hi, centre, c_i, oriented=False):
    """The twin: the cheapest split at a boundary of 16 bins per axis (the kernel's bin
    of a centre, in float32), over every axis whose centres spread; with ``oriented`` (3D
    builds) also the orientation splits: the boxes longest along one spatial axis (their
    float32 extents, the first of equal ones) against the rest."""
    parent = max(_area4(lo.min(0), hi.max(0)), 1.0e-30)
    best = np.inf
    if oriented:
        longest = np.argmax((hi.astype(np.float32) - lo.astype(np.float32))[:, 1:], axis=1)
        for axis in range(3):
            left = longest == axis
            if left.any() and not left.all():
                best = min(best, _cost(lo, hi, left, c_i, parent))
    for axis in range(4):
        c = centre[:, axis]
        lo_c, extent = c.min(), c.max() - c.min()
        if extent <= 0:
            continue
        scale = np.float32(BINS) / extent
        b = np.clip(((c - lo_c) * scale).astype(np.int64), 0, BINS - 1)
        for j in range(BINS - 1):
            left = b <= j
            if left.any() and not left.all():
                best = min(best, _cost(lo, hi, left, c_i, parent))
    return best, parent


def _ranges(bvh):
    """Each node's primitive range [s0, s1) and its children (None for a leaf)."""
    f, c = bvh.node_first, bvh.node_count
    ranges = {}

    def walk(j):
        if c[j] > 0:
            ranges[j] = (int(f[j]), int(f[j] + c[j]), None)
        else:
            a, b = walk(f[j]), walk(f[j] + 1)
            ranges[j] = (a[0], b[1], (int(f[j]), int(f[j] + 1)))
        return ranges[j]

    walk(0)
    return ranges


def _clustered(n, uniform_t):
    """Clustered boxes of several sizes, so the axes and bins matter."""
    rng = np.random.default_rng(n)
    centres = rng.normal(size=(8, 4)) * [3.0, 4.0, 2.0, 1.0]
    c = centres[rng.integers(0, 8, n)] + rng.normal(size=(n, 4)) * [0.5, 1.0, 0.3, 0.2]
    half = rng.random((n, 4)) ** 3 * [0.4, 0.5, 0.8, 0.2]
    lo, hi = c - half, c + half
    if uniform_t:
        lo[:, 0], hi[:, 0] = 0.0, 1.0e3
    return lo, hi


def _reticles(copies):
    """``copies`` coincident reticles (the aberration stage's static copy): 21 lines along
    x and 21 along y, 0.12 wide and 20 long, a unit apart, and a cross of one line each way
    through the middle. Each line along x shares its centre with one along y (the cross's
    two lines share theirs exactly), so no bin boundary separates the two directions."""
    lines = []
    for k in range(-10, 11):
        lines += [((-10.0, k - 0.06), (10.0, k + 0.06)), ((k - 0.06, -10.0), (k + 0.06, 10.0))]
    lines += [((-10.0, -0.03), (10.0, 0.03)), ((-0.03, -10.0), (0.03, 10.0))]
    box = np.array([[0.0, x0, y0, -10.0, 1.0e3, x1, y1, -10.0] for (x0, y0), (x1, y1) in lines] * copies)
    return box[:, :4], box[:, 4:]


@pytest.mark.parametrize("primitive, leaf_size, uniform_t, n", [
    ("tri", 4, True, 3000), ("prism", 4, False, 2000), ("rigid", 1, False, 700), ("tri", 4, True, SPLIT_MIN + 904),
    ("tri", 4, True, -17)])
def test_every_split_is_the_cheapest_bin_boundary(primitive, leaf_size, uniform_t, n):
    """Law: at every inner node the builder's partition costs what the twin's cheapest
    split costs (to RTOL), and every leaf over ``leaf_size`` primitives costs no more than
    its cheapest split. Clustered boxes (``_clustered``); the fourth case is large enough
    for the top levels and the subtrees to be built in two launches; the last (n < 0) is
    -n coincident reticles (``_reticles``), where only the orientation split of a 3D build
    separates the crossing lines (without it, a node of both directions fails the law)."""
    lo, hi = _reticles(-n) if n < 0 else _clustered(n, uniform_t)
    n = len(lo)
    bvh = build_bvh(lo, hi, primitive, leaf_size=leaf_size, uniform_t=uniform_t, oriented=uniform_t)
    c_i = SAH_COST_INTERSECT[primitive]
    # The kernel's inputs: float32 boxes and centres.
    lo32, hi32 = lo.astype(np.float32), hi.astype(np.float32)
    centre32 = (0.5 * (lo + hi)).astype(np.float32)
    checked = 0
    for s0, s1, children in _ranges(bvh).values():
        prims = bvh.order[s0:s1]
        if s1 - s0 <= leaf_size:
            assert children is None
            continue
        blo, bhi = lo32[prims].astype(np.float64), hi32[prims].astype(np.float64)
        best, parent = _best_cost(blo, bhi, centre32[prims], c_i, oriented=uniform_t)
        if children is None:
            assert s1 - s0 <= SAH_MAX_LEAF and c_i * (s1 - s0) <= best * (1 + RTOL), (s0, s1)
        else:
            left = np.zeros(s1 - s0, bool)
            left[:_ranges_end(bvh, children[0]) - s0] = True
            got = _cost(blo, bhi, left, c_i, parent)
            assert got <= best * (1 + RTOL), (s0, s1, got, best)
        checked += 1
    assert checked > n // 8


def _ranges_end(bvh, j):
    """The end of node ``j``'s primitive range."""
    while bvh.node_count[j] == 0:
        j = bvh.node_first[j] + 1
    return int(bvh.node_first[j] + bvh.node_count[j])


@pytest.mark.parametrize("float32_boxes", [False, True])
def test_node_boxes_are_their_primitives_bounds(float32_boxes):
    """Law: every node's box (``kernels/bvh_build.node_boxes64`` in float64,
    ``node_boxes`` in float32) is the NumPy min and max of its primitives' boxes, bit for
    bit (min and max round nothing). A build large enough for two launches."""
    rng = np.random.default_rng(17)
    n = SPLIT_MIN + 1000
    c = rng.random((n, 4)) * [10.0, 5.0, 5.0, 5.0]
    half = rng.random((n, 4)) * 0.2
    lo, hi = c - half, c + half
    if float32_boxes:
        lo[:, 0], hi[:, 0] = 0.0, 1.0e3
        lo, hi = lo.astype(np.float32), hi.astype(np.float32)
    bvh = build_bvh(lo, hi, "tri", leaf_size=4, uniform_t=float32_boxes, float32_boxes=float32_boxes)
    assert bvh.node_lo.dtype == (np.float32 if float32_boxes else np.float64)
    ranges = _ranges(bvh)
    assert len(ranges) == bvh.node_count_total
    for j, (s0, s1, _children) in ranges.items():
        prims = bvh.order[s0:s1]
        assert np.array_equal(bvh.node_lo[j], lo[prims].min(0)), j
        assert np.array_equal(bvh.node_hi[j], hi[prims].max(0)), j


def _twin_kernels(monkeypatch):
    """``accel.bvh``'s kernels made with the Warp-language split of tests/accel/sah_twin.py
    in place of the C++ one (a module of their own per parameter set)."""
    import warp_st.accel.bvh as bvh
    from sah_twin import make_split_twin
    from warp_st.kernels.bvh_build import make_sah_build

    made = {}

    def kernels(cost_intersect, leaf_size, uniform_t=False, oriented=False):
        key = (cost_intersect, leaf_size, uniform_t, oriented)
        if key not in made:
            args = (leaf_size, SAH_MAX_LEAF, SAH_COST_TRAVERSE, cost_intersect, uniform_t, oriented)
            made[key] = make_sah_build(*args, split=make_split_twin(*args))
        return made[key]

    monkeypatch.setattr(bvh, "_sah_kernel", kernels)


def _twin_cases():
    """Boxes that exercise every branch of the split: clustered boxes, boxes of one time
    extent (3D builds), coincident centres (no bin separates them: the orientation split
    or the median), one point repeated (no axis spreads), signed zeros (Warp's min keeps
    the first of equal zeros), extents near the 1e-30 floor, crossing reticles, and
    builds large enough for the subtree launches."""
    rng = np.random.default_rng(11)
    cases = [_clustered(3000, True), _clustered(2000, False), _reticles(3), _clustered(SPLIT_MIN + 904, True)]
    lo, hi = _clustered(900, False)
    lo[:450], hi[:450] = lo[0], hi[0]
    cases.append((lo, hi))
    cases.append((np.zeros((40, 4)), np.ones((40, 4))))
    lo, hi = _clustered(600, True)
    lo[::3, 1:] = -0.0
    hi[::5, 1:] = 0.0
    cases.append((lo, hi))
    c = rng.normal(size=(500, 4)) * 1.0e-31
    cases.append((c - 1.0e-32, c + 1.0e-32))
    # Equal sides (cubes: the first longest one is x), rods along x and rods along z, all
    # about the same centres: three orientation groups, two of them x's.
    c = rng.normal(size=(600, 4)) * 0.01
    half = np.tile([1.0e3, 0.5, 0.5, 0.5], (600, 1))
    half[200:400, 1], half[400:, 3] = 4.0, 4.0
    cases.append((c - half, c + half))
    return cases


@pytest.mark.parametrize("primitive, leaf_size, uniform_t, oriented", [
    ("tri", 4, True, True), ("tet", 2, False, False), ("rigid", 1, False, False), ("tri", 4, False, True)])
def test_the_cpp_split_builds_the_warp_twins_trees(monkeypatch, primitive, leaf_size, uniform_t, oriented):
    """Law: the builder's C++ split (``kernels/sah_split.inc``) gives the trees its Warp-language
    twin (tests/accel/sah_twin.py) gives, bit for bit: the same node ranges, children,
    depth, order and node boxes on every case of ``_twin_cases``, on one thread and two.
    Exact equality: both compute the same float32 operations in the same order, so any
    difference is a wrong bin, sweep, tie or partition (a tolerance would hide one)."""
    import warp_st.accel.bvh as bvh

    cases = _twin_cases()
    ours = [[build_bvh(lo, hi, primitive, leaf_size=leaf_size, uniform_t=uniform_t, oriented=oriented,
                       threads=threads) for threads in (1, 2)] for lo, hi in cases]
    _twin_kernels(monkeypatch)
    for (lo, hi), builds in zip(cases, ours):
        twin = build_bvh(lo, hi, primitive, leaf_size=leaf_size, uniform_t=uniform_t, oriented=oriented)
        assert twin.node_count_total > 1
        for got in builds:
            assert got.depth == twin.depth
            for name in ("node_first", "node_count", "order", "node_lo", "node_hi"):
                assert np.array_equal(getattr(got, name), getattr(twin, name)), name
