"""Where bottom-level queries start (``spacetime/start_boxes.py``): the rest box of the
bodies of a frame a body may touch.

Laws on random boxes (against a brute-force float64 twin: the connected components of
the overlap graph), and the property they serve: two bodies of one frame that share an
edge get the same float32 ray, so no ray through the seam passes between them.
"""
import numpy as np
import pytest

from tracing_helpers import RigidDatabase, scene_of, tube_windows
from warp_st.core.scene import Body, Material, Surface
from warp_st.spacetime import start_boxes as sb
from warp_st.spacetime.start_boxes import CLUSTER_BODIES, start_boxes


def _components(lo, hi):
    """Brute force: labels of the connected components of 'boxes overlap or touch'."""
    n = len(lo)
    adj = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
    label = -np.ones(n, int)
    for s in range(n):
        if label[s] >= 0:
            continue
        label[s], todo = s, [s]
        while todo:
            i = todo.pop()
            for j in np.flatnonzero(adj[i] & (label < 0)):
                label[j] = s
                todo.append(j)
    return label


def _random_boxes(rng, n, spread):
    lo = rng.uniform(-spread, spread, (n, 3))
    return lo, lo + rng.uniform(0.05, 1.0, (n, 3))


@pytest.mark.parametrize("seed", range(6))
def test_start_boxes_join_the_bodies_that_may_touch(seed):
    rng = np.random.default_rng(seed)
    n = 60
    lo, hi = _random_boxes(rng, n, spread=[1.5, 3.0, 6.0][seed % 3])
    frame = rng.integers(0, 3, n)
    traced = rng.random(n) > 0.1
    s_lo, s_hi = start_boxes(lo, hi, frame, traced)
    assert np.array_equal(s_lo[~traced], lo[~traced]) and np.array_equal(s_hi[~traced], hi[~traced])
    kept_own = 0
    for f in range(3):
        m = np.flatnonzero((frame == f) & traced)
        label = _components(lo[m], hi[m])
        # Every body's start box holds its own box, and bodies joined by touching boxes
        # (transitively) start at the same box: the seam's points lie in both.
        assert np.all(s_lo[m] <= lo[m]) and np.all(s_hi[m] >= hi[m])
        for c in np.unique(label):
            members = m[label == c]
            assert np.all(s_lo[members] == s_lo[members[0]]) and np.all(s_hi[members] == s_hi[members[0]])
        # Each start box is exactly the union of the rest boxes of the bodies that share
        # it (a body alone in its cluster starts at its own box), and distinct start boxes
        # are apart: clusters grow only while their boxes meet.
        keys = {(tuple(a), tuple(b)) for a, b in zip(s_lo[m], s_hi[m])}
        for a, b in keys:
            share = m[np.all(s_lo[m] == a, axis=1) & np.all(s_hi[m] == b, axis=1)]
            assert np.array_equal(lo[share].min(axis=0), a) and np.array_equal(hi[share].max(axis=0), b)
        boxes = np.array([[*a, *b] for a, b in keys])
        apart = ~np.all((boxes[:, None, :3] <= boxes[None, :, 3:]) & (boxes[None, :, :3] <= boxes[:, None, 3:]), axis=2)
        assert np.all(apart | np.eye(len(boxes), dtype=bool))
        kept_own += int((np.all(s_lo[m] == lo[m], axis=1) & np.all(s_hi[m] == hi[m], axis=1)).sum())
    assert kept_own > 0  # the union law is met by bodies alone too, not only by shared boxes


def test_a_chain_of_touching_boxes_shares_one_start_box_and_a_box_apart_keeps_its_own():
    # Unit boxes along x: body 0 on [0, 1] touches body 3 on [1, 2], which touches body 1
    # on [2, 2.5]; body 2 on [4, 5] is apart.
    lo = np.array([[0.0, 0, 0], [2, 0, 0], [4, 0, 0], [1, 0, 0]])
    hi = lo + 1.0
    hi[1, 0] = 2.5
    s_lo, s_hi = start_boxes(lo, hi, np.zeros(4, int), np.ones(4, bool))
    assert np.array_equal(s_lo[[0, 1, 3]], np.tile([0.0, 0, 0], (3, 1)))
    assert np.array_equal(s_hi[[0, 1, 3]], np.tile([2.5, 1, 1], (3, 1)))
    assert np.array_equal(s_lo[2], lo[2]) and np.array_equal(s_hi[2], hi[2])


def test_a_frame_of_more_bodies_than_the_bound_keeps_one_start_box(monkeypatch):
    monkeypatch.setattr(sb, "CLUSTER_BODIES", 3)
    lo = np.arange(4.0)[:, None] * np.array([[3.0, 0, 0]])
    s_lo, s_hi = start_boxes(lo, lo + 1, np.zeros(4, int), np.ones(4, bool))
    assert np.all(s_lo == lo.min(axis=0)) and np.all(s_hi == (lo + 1).max(axis=0))
    assert CLUSTER_BODIES > 3


def _tile(path, x0, lifetime, diagonal):
    """A unit square tile in z = 0 from x = x0 to x0 + 1, y in [0, 1], cut along one of
    its diagonals (two tiles cut alike would be instances of one shape, each in its own
    coordinates)."""
    pts = np.array([[x0, 0, 0], [x0 + 1, 0, 0], [x0 + 1, 1, 0], [x0, 1, 0]], float)
    tris = np.array([[0, 1, 2], [0, 2, 3]] if diagonal == 0 else [[0, 1, 3], [1, 2, 3]])
    origin = np.array([x0 + 0.5, 0.5, 0.0])
    return Body(path, (Surface(path, pts, tris, Material()),), origin, np.zeros(3), 0.0, lifetime, False)


@pytest.mark.parametrize("finite", [True, False])
def test_no_ray_passes_between_two_bodies_that_share_an_edge(finite):
    """Two tiles of one frame (at rest: one motion group) that share the edge x = 1, kept
    apart as two shapes (different lifetimes: not one merge class). Rays from far off,
    aimed at points of the edge itself, must all hit one of them. A start box of each
    tile's own (the ray's float32 start point rounded per tile) let 29 of these rays
    through when this test was written."""
    scene = scene_of(_tile("/A", 0.0, (-np.inf, np.inf), 0), _tile("/B", 1.0, (-1.0e6, 1.0e6), 1))
    db = RigidDatabase(scene, tube_windows(scene), origin=(0.0, 0.0, 0.0, 0.0))
    assert len(np.unique(db.shapes.body_shape)) == 2  # two shapes, two queries a ray
    assert np.array_equal(db.shapes.body_frame[0], db.shapes.body_frame[1])  # one frame
    rng = np.random.default_rng(5)
    n = 4000
    y = rng.uniform(0.02, 0.98, n)
    targets = np.column_stack([np.ones(n), y, np.zeros(n)])
    view = rng.normal(size=(n, 3))
    view[:, 2] = np.abs(view[:, 2]) + 0.3  # from above, obliquely
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    dist = rng.uniform(20.0, 60.0, n)
    origins = np.column_stack([dist if finite else np.zeros(n), targets + dist[:, None] * view])
    tri, s, _visits = db.cast(origins, -view, finite=finite)
    assert np.all(tri >= 0), f"{np.sum(tri < 0)} rays through the seam"
    # The lookback is the distance to the aimed-at edge point: float32 rounding of a
    # 20-60 unit path is ~4e-6 units (1e-7 relative); 1e-5 relative leaves room for the
    # float32 origins and directions the rays are cast with, and is far below any miss.
    assert np.allclose(s, dist, rtol=1e-5)
