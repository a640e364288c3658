"""Two-level rigid tracing (issue 17) against the 4D extrusion, its exact oracle.

Law: a body moving uniformly is static in its comoving coordinates, where the past null
ray is a straight 3D line (spacetime/rigid.py). So the closest hit of any null ray
through the two levels (one wp.Mesh per shape at rest, a 4D top level over the bodies'
motion segments) is the closest hit over the body's extruded prisms: the same rays
hit, the same triangle, the same lookback s up to float32 rounding, for finite and
infinite light speed, coupled (contracted, 0.9c and 0.99c) and decoupled bodies (also
faster than light, 2c), bounded lifetimes, several segments per window, and rays from
arbitrary events (as mirror bounces and shadow rays start anywhere). The oracle is the
prism path in float64, every primitive tested (no BVH).

Tolerance of s: float32 rounding of the ray, the triangle and the hit moves the hit
point by a few ulps of the coordinates (~1e-7 relative here) across the surface; along
the ray that is divided by cos(theta), theta the angle between the comoving ray
direction D = n + v and the surface normal (grazing rays slide far along the surface).
So |s - s_oracle| cos(theta) <= 1e-5 (1 + s): ~80 ulps, 5x what either float32 path
(rigid or the float32 prism path) shows on these rays. A wrong velocity, contraction
or anchor moves hits by 1e-2 or more.
"""
import numpy as np
import pytest
from tracing_helpers import Database, RigidDatabase, cube_body, scene_of
from tracing_helpers import mixed_scene as _mixed_scene
from tracing_helpers import random_rays as _random_rays
from tracing_helpers import tube_windows as _windows

COND_TOL = 1.0e-5


def _conditioned_error(oracle: Database, idx, s, s_ref, dirs, finite):
    """|s - s_ref| cos(theta) / (1 + s_ref) per hit ray (see the module docstring)."""
    tri = oracle.prim_tri[idx]
    v = np.array([b.velocity for b in oracle.mesh.bodies])[oracle.mesh.tri_body[tri]]
    d = dirs + (v if finite else 0.0)
    cos = np.abs(np.sum(oracle.mesh.tri_normal[tri] * d, axis=1)) / np.linalg.norm(d, axis=1)
    return np.abs(s - s_ref) * cos / (1.0 + s_ref)


@pytest.mark.parametrize("finite", [True, False])
def test_rigid_hits_equal_the_extrusion(finite):
    scene = _mixed_scene()
    windows = _windows(scene)
    oracle = Database(scene, windows, precision="float64", primitive="prism", origin=(-3, 0, 0, 0))
    rigid = RigidDatabase(scene, windows, origin=(-3, 0, 0, 0))
    assert rigid.segments.count > len(scene.bodies), "the fast bodies' windows must be cut into several segments"
    rng = np.random.default_rng(21 + finite)
    origins, dirs = _random_rays(rng, 20000, oracle, finite)
    o_idx, o_s, _ = oracle.cast(origins, dirs, finite=finite, brute=True)
    r_tri, r_s, _ = rigid.cast(origins, dirs, finite=finite)
    hit = o_idx >= 0
    assert 0.1 < hit.mean() < 0.9, "the ray set must contain both hits and misses"
    assert np.array_equal(r_tri >= 0, hit)
    # Triangles may differ only where the hit is on an edge two triangles share.
    assert (r_tri[hit] == oracle.prim_tri[o_idx[hit]]).mean() > 0.999
    err = _conditioned_error(oracle, o_idx[hit], r_s[hit], o_s[hit], dirs[hit], finite)
    assert err.max() < COND_TOL, err.max()


def test_top_level_equals_every_segment():
    """The top level is an acceleration only: the same leaf test over every segment (no
    BVH) gives bit-identical hits."""
    scene = _mixed_scene()
    rigid = RigidDatabase(scene, _windows(scene), origin=(-3, 0, 0, 0))
    oracle = Database(scene, _windows(scene), primitive="prism", origin=(-3, 0, 0, 0))
    origins, dirs = _random_rays(np.random.default_rng(3), 12000, oracle)
    b_tri, b_s, visits = rigid.cast(origins, dirs)
    f_tri, f_s, _ = rigid.cast(origins, dirs, brute=True)
    assert (f_tri >= 0).mean() > 0.1
    assert np.array_equal(b_tri, f_tri) and np.array_equal(b_s, f_s)
    assert visits.mean() < 0.5 * rigid.bvh.node_count_total, "the top level must cull"


def test_lifetime_ends_on_the_rigid_path():
    """Rays aimed at surface events just inside and just outside a lifetime's ends (1e-3,
    far above float32 rounding of these times) and at the cuts between segments: hit
    exactly where the float64 extrusion hits, at the same s."""
    from warp_st.core.lorentz import contraction_matrix

    body = cube_body("/C", (0, 0, -5), 2.0, (0.95, 0.2, 0), lifetime=(-10.0, -2.0))
    windows = [(-10.0, -2.0)]
    oracle = Database(scene_of(body), windows, precision="float64", primitive="prism")
    rigid = RigidDatabase(scene_of(body), windows)
    cuts = np.unique(rigid.segments.span)
    assert len(cuts) > 2
    times = np.concatenate([cuts - 1e-3, cuts + 1e-3])
    rng = np.random.default_rng(4)
    pts, tris = body.surfaces[0].points, body.surfaces[0].triangles
    n = 4000
    lam = rng.dirichlet(np.ones(3), n)
    t_ev = times[rng.integers(0, len(times), n)]
    local = (pts - body.origin) @ contraction_matrix(body.velocity, False).T + body.origin
    x_ev = np.einsum("nk,nkj->nj", lam, local[tris[rng.integers(0, len(tris), n)]])
    x_ev += np.outer(t_ev - body.reference_time, body.velocity)
    view = rng.normal(size=(n, 3))
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    dist = rng.uniform(3.0, 6.0, n)
    origins = np.column_stack([t_ev + dist, x_ev + dist[:, None] * view])
    o_idx, o_s, _ = oracle.cast(origins, -view, brute=True)
    r_tri, r_s, _ = rigid.cast(origins, -view)
    hit = o_idx >= 0
    assert 0.2 < hit.mean() < 0.95
    assert np.array_equal(r_tri >= 0, hit)
    err = _conditioned_error(oracle, o_idx[hit], r_s[hit], o_s[hit], -view[hit], True)
    assert err.max() < COND_TOL, err.max()


def test_hits_do_not_depend_on_the_windows():
    """A hit comes out bit-identical from a database over wider windows (other segment
    cuts, other boxes): the query's start and anchor are the body's, not the segment's
    (trace_rigid.leaf). So a cached database for more frames renders a frame exactly as
    one built for it alone. (A hit within a small distance of a segment cut may be found
    from the cut instead; those are left out, as are hits outside the narrow windows.)"""
    scene = _mixed_scene()
    narrow = RigidDatabase(scene, _windows(scene, -12.0, 0.0), origin=(-3, 0, 0, 0))
    wide = RigidDatabase(scene, _windows(scene, -400.0, 300.0), origin=(-3, 0, 0, 0))
    oracle = Database(scene, _windows(scene, -12.0, 0.0), primitive="prism", origin=(-3, 0, 0, 0))
    origins, dirs = _random_rays(np.random.default_rng(9), 12000, oracle)
    a_tri, a_s, _ = narrow.cast(origins, dirs)
    b_tri, b_s, _ = wide.cast(origins, dirs)
    cuts = np.unique(np.concatenate([narrow.segments.span.ravel(), wide.segments.span.ravel()]))
    # The wide database's closest hit must be one the narrow one holds: inside its
    # windows (else it hides the narrow one's hit, rightly), away from every cut.
    hit_t = origins[:, 0] - b_s
    keep = (b_tri >= 0) & (hit_t > -12.0 + 1e-3) & (hit_t < -1e-3)
    keep &= np.abs(hit_t[:, None] - cuts[None, :]).min(axis=1) > 1e-3
    assert keep.mean() > 0.2
    assert np.array_equal(a_tri[keep], b_tri[keep]) and np.array_equal(a_s[keep], b_s[keep])


def _class_scene():
    """Motion classes of several bodies (spacetime/merge_classes.merge_plan), each class's bodies
    overlapping or touching (so merged: their box is no larger than theirs together)
    but one: at 0.6c coupled, two instances of one cube (copied into one shape about the
    first one's pivot) and two other bodies; two decoupled at 2c with a lifetime; two at
    rest; two small cubes far apart at 0.5c (kept apart); one body alone at 0.9c; at 0.4c
    two checker meshes merged without the wall behind them. Each
    class's bodies are consecutive, so the merged shapes number their triangles as the
    extrusion does."""
    from tracing_helpers import sphere_body

    return scene_of(
        cube_body("/A0", (0, 0, -4), 1.0, (0.6, 0, 0)),
        cube_body("/A1", (0.9, 0, -4), 1.0, (0.6, 0, 0)),
        cube_body("/A2", (0, 1.2, -4.5), 1.1, (0.6, 0, 0)),
        sphere_body("/A3", (0.5, 1.2, -4.5), 0.8, (0.6, 0, 0)),
        cube_body("/B0", (2, 1, -6), 1.5, (-2.0, 0, 0.3), decoupled=True, lifetime=(-18.0, 1.0)),
        sphere_body("/B1", (2, 0.2, -6), 0.6, (-2.0, 0, 0.3), decoupled=True, lifetime=(-18.0, 1.0)),
        sphere_body("/C0", (-2, -1, -5), 0.7),
        cube_body("/C1", (-2, -0.2, -5), 0.9),
        cube_body("/E0", (-3, 2, -8), 0.5, (0, 0, 0.5)),
        cube_body("/E1", (3, 2, -8), 0.6, (0, 0, 0.5)),
        cube_body("/D", (1, -2, -3), 0.8, (0, 0.9, 0), lifetime=(-15.0, -3.0)),
        # A stage at 0.4c: two interleaved checker meshes, flat (merged: one box for
        # both) and a wall behind them (kept apart: with it the box would grow).
        _squares_body("/G0", [(x, -3.0, z) for x in range(-2, 2) for z in range(-8, -4) if (x + z) % 2 == 0]),
        _squares_body("/G1", [(x, -3.0, z) for x in range(-2, 2) for z in range(-8, -4) if (x + z) % 2]),
        _squares_body("/G2", [(x, y, -10.0) for x in range(-2, 2) for y in range(-3, 1)], normal_axis=2),
    )


def _squares_body(path, corners, normal_axis=1, velocity=(0, 0.4, 0)):
    """A body of unit squares with these lower corners, in the plane normal to axis
    ``normal_axis`` (1: y, 2: z)."""
    from warp_st.core.scene import Body, Material, Surface

    u, v = [a for a in (0, 1, 2) if a != normal_axis]
    pts, tris = [], []
    for c in corners:
        base = len(pts)
        for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)):
            p = np.array(c, float)
            p[u] += du
            p[v] += dv
            pts.append(p)
        tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    pts = np.array(pts)
    origin = pts.mean(axis=0)
    return Body(path, (Surface(path, pts, np.array(tris), Material()),), origin, np.asarray(velocity, float), 0.0,
                (-np.inf, np.inf), False)


@pytest.mark.parametrize("finite", [True, False])
def test_merged_classes_hit_as_separate_bodies_and_the_extrusion(finite, monkeypatch):
    """Bodies of one motion class merged into one shape (one bottom level, one set of
    segments), instances of one shape copied into another, a spread class kept apart, a
    class merged in part (the pair whose box does not grow): the
    same closest triangles as the same bodies traced one by one (merging off), ray for
    ray, at the same s to float32 rounding; and the float64 prism oracle's hits, s within
    COND_TOL. One ray in 20,000 here misses a sphere's silhouette in float32 on both
    rigid layouts: the masks may differ there."""
    from warp_st.spacetime import rigid as rigid_module

    scene = _class_scene()
    windows = _windows(scene)
    merged = RigidDatabase(scene, windows, origin=(-3, 0, 0, 0))
    assert merged.shapes.body_holder.tolist() == [0, 0, 2, 2, 4, 4, 6, 6, 8, 9, 10, 11, 11, 13], "merged classes"
    assert len(merged.shapes.shape_rest) == 9
    monkeypatch.setattr(rigid_module, "merge_plan", lambda bodies, *a: np.arange(len(bodies), dtype=np.int32))
    separate = RigidDatabase(scene, windows, origin=(-3, 0, 0, 0))
    assert len(separate.shapes.shape_rest) == 13  # the two instances share one
    oracle = Database(scene, windows, precision="float64", primitive="prism", origin=(-3, 0, 0, 0))
    origins, dirs = _random_rays(np.random.default_rng(33 + finite), 20000, oracle, finite)
    o_idx, o_s, _ = oracle.cast(origins, dirs, finite=finite, brute=True)
    r_tri, r_s, _ = merged.cast(origins, dirs, finite=finite)
    e_tri, e_s, _ = separate.cast(origins, dirs, finite=finite)
    assert np.array_equal(r_tri, e_tri)
    hit = o_idx >= 0
    # A copy is held about another pivot than its own, and a query may restart from
    # another point (past a member's hit before the span): float32 rounding, which a
    # grazing ray stretches along itself (COND_TOL's conditioning).
    both = hit & (r_tri >= 0)
    err = _conditioned_error(oracle, o_idx[both], r_s[both], e_s[both], dirs[both], finite)
    assert err.max() < COND_TOL and (r_s[~both] == e_s[~both]).all(), err.max()
    assert 0.1 < hit.mean() < 0.9
    assert ((r_tri >= 0) == hit).mean() >= 1.0 - 1e-4
    assert (r_tri[both] == oracle.prim_tri[o_idx[both]]).mean() > 0.999
    err = _conditioned_error(oracle, o_idx[both], r_s[both], o_s[both], dirs[both], finite)
    assert err.max() < COND_TOL, err.max()
