"""Closest hits through the 4D BVH: brute force, a float64 oracle, watertightness."""
import numpy as np
import pytest
from tracing_helpers import (
    Database,
    mixed_scene,
    random_rays,
    scene_of,
    solve_tets_f64,
    sphere_body,
    tube_windows,
)


@pytest.mark.parametrize("primitive", ["prism", "tet"])
@pytest.mark.parametrize("precision", ["float32", "float64"])
@pytest.mark.parametrize("finite", [True, False])
def test_bvh_closest_hit_equals_brute_force(precision, finite, primitive):
    """The BVH is an acceleration only: on 6,000 random null rays (from events inside and
    around the bodies' lifetimes, hits and misses) it returns the same closest hit as
    testing every tetrahedron. Same intersection routine on both sides, so hit/miss must
    agree exactly; the lookback s may differ only where two tetrahedra share the hit
    point (a shared face), by float rounding of the barycentric interpolation: 2e-5 of
    the scene scale (~10) in float32."""
    scene = mixed_scene()
    db = Database(scene, tube_windows(scene), precision=precision, origin=(-3, 0, 0, 0), primitive=primitive)
    rng = np.random.default_rng(7 + finite)
    origins, dirs = random_rays(rng, 6000, db, finite)
    tet_b, s_b, visits = db.cast(origins, dirs, finite=finite)
    tet_f, s_f, _ = db.cast(origins, dirs, finite=finite, brute=True)
    assert np.array_equal(tet_b >= 0, tet_f >= 0)
    hit = tet_f >= 0
    assert 0.1 < hit.mean() < 0.9, "the ray set must contain both hits and misses"
    tol = 2e-4 if precision == "float32" else 1e-10
    np.testing.assert_allclose(s_b[hit], s_f[hit], rtol=0, atol=tol)
    assert visits.mean() < 0.2 * db.bvh.node_count_total, "the BVH must cull most nodes"


def test_kernel_hits_match_float64_oracle():
    """Every hit the float32 kernel reports solves O + s d = sum lam_i V_i in float64 with
    lam >= 0 (up to 1e-4, float32 rounding of coordinates ~10 units), and no float64 hit
    that is robustly inside a tetrahedron (all lam > 1e-4) lies nearer than the kernel's."""
    scene = mixed_scene()
    db = Database(scene, tube_windows(scene))
    events = db.mesh.tet_events()
    rng = np.random.default_rng(3)
    origins, dirs = random_rays(rng, 200, db)
    tet, s, _ = db.cast(origins, dirs)
    for i in range(len(origins)):
        s64, lam = solve_tets_f64(events, origins[i], dirs[i])
        if tet[i] >= 0:
            j = tet[i]
            assert lam[j].min() > -1e-4 and abs(s64[j] - s[i]) < 1e-3 * (1 + s[i])
        robust = (lam.min(axis=1) > 1e-4) & (s64 > 1e-3)
        if robust.any():
            nearest = s64[robust].min()
            assert tet[i] >= 0 and s[i] <= nearest + 1e-3 * (1 + nearest)


@pytest.mark.parametrize("primitive", ["prism", "tet"])
@pytest.mark.parametrize("velocity", [(0, 0, 0), (0.8, 0, 0), (0.3, 0.5, -0.6)])
def test_watertight_at_shared_edges_and_vertices(velocity, primitive):
    """A closed sphere extruded (several time segments when moving) is a watertight
    world-tube: rays aimed exactly at its vertex events and at the midpoints of its
    tetrahedron edges, at the slice times where prisms meet, all hit it. Each ray is
    kept only if it really enters the body there: in comoving coordinates x - v t the
    body is a fixed convex polyhedron and the ray a straight line with direction n + v,
    so we require the point just past the target to lie inside every face plane
    (rays through a vertex of a convex polyhedron that only graze it touch it at a
    single point and may legitimately miss). Any miss would be a ray slipping between
    tetrahedra that share a face (or prisms that share an edge); shared faces and edges
    are evaluated bit-identically on both sides, so the required count of misses is
    zero, not 'few'."""
    from warp_st.core.lorentz import contraction_matrix

    v = np.asarray(velocity, float)
    centre = np.array([0, 0, -6.0])
    body = sphere_body("/S", centre, 1.5, velocity, segments=16)
    db = Database(scene_of(body), [(-40.0, 0.0)], primitive=primitive)
    verts = db.mesh.vertices  # (V, 4): every slice of every point
    edges = np.concatenate([db.mesh.tets[:, [a, b]] for a in range(4) for b in range(a + 1, 4)])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    targets = np.concatenate([verts, 0.5 * (verts[edges[:, 0]] + verts[edges[:, 1]])])
    targets = targets[(targets[:, 0] > -39.0) & (targets[:, 0] < -1.0)]

    # The contracted polyhedron in comoving coordinates (x - v t) and its face planes.
    surf = body.surfaces[0]
    A = contraction_matrix(v, False)
    poly = (surf.points - centre) @ A.T + centre
    tri = surf.triangles
    normal = np.cross(poly[tri[:, 1]] - poly[tri[:, 0]], poly[tri[:, 2]] - poly[tri[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal *= np.sign(np.einsum("ij,ij->i", normal, poly[tri[:, 0]] - centre))[:, None]
    offset = np.einsum("ij,ij->i", normal, poly[tri[:, 0]])

    rng = np.random.default_rng(11)
    como = targets[:, 1:] - v * targets[:, 0:1]
    view = como - centre + rng.normal(scale=0.4, size=como.shape)
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    step = -view + v  # comoving ray direction n + v
    past = como + 0.02 * step
    enters = (past @ normal.T - offset).max(axis=1) < -1e-4
    targets, view = targets[enters], view[enters]
    assert len(targets) > 300

    dist = 4.0
    cams = np.column_stack([targets[:, 0] + dist, targets[:, 1:] + dist * view])
    tet, s, _ = db.cast(cams, -view)
    misses = int((tet < 0).sum())
    assert misses == 0, f"{misses} of {len(targets)} rays slipped through shared faces"
    # They hit at the aimed event, or earlier on the ray where another face is nearer.
    late = s > dist + 1e-3
    assert not late.any(), f"{late.sum()} rays passed the aimed event (s up to {s.max():.4f})"


def test_traversal_stack_holds_the_deepest_tree():
    """The fixed traversal stack (zero-initialised per ray) must hold the BVH's depth
    bound, and a built tree must respect that bound (an overflow would be reported as an
    error at render time, never silent)."""
    from warp_st.accel.bvh import MAX_DEPTH, build_bvh
    from warp_st.accel.bvh_wide import MAX_WIDE_DEPTH, WIDTH, collapse
    from warp_st.kernels.trace import STACK_SIZE

    # The kernel walks the 4-wide tree: a visit leaves at most WIDTH - 1 children on
    # the stack, so WIDTH - 1 entries per wide level.
    assert 2 * MAX_WIDE_DEPTH >= MAX_DEPTH
    assert STACK_SIZE >= (WIDTH - 1) * MAX_WIDE_DEPTH
    rng = np.random.default_rng(2)
    # A badly clustered set: geometric spacing drives the SAH to lopsided splits.
    c = np.column_stack([np.zeros(20000), 2.0 ** -np.arange(20000) % 1, rng.random((20000, 2))])
    bvh = build_bvh(c - 1e-3, c + 1e-3)
    assert bvh.depth <= MAX_DEPTH
    assert collapse(bvh).depth <= MAX_WIDE_DEPTH
