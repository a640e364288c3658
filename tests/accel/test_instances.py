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
    """Motion classes of several bodies (spacetime/rigid.merge_plan): three bodies at 0.6c
    coupled (two of them instances of one cube), two decoupled at 2c with a lifetime, two
    at rest, and one body alone at 0.9c; each class's bodies consecutive, so the merged
    shapes number their triangles as the extrusion does."""
    from tracing_helpers import sphere_body

    return scene_of(
        cube_body("/A0", (0, 0, -4), 1.0, (0.6, 0, 0)),
        cube_body("/A1", (0, 1.2, -4.5), 1.0, (0.6, 0, 0)),
        sphere_body("/A2", (-1.5, 0, -5), 0.8, (0.6, 0, 0)),
        cube_body("/B0", (2, 1, -6), 1.5, (-2.0, 0, 0.3), decoupled=True, lifetime=(-18.0, 1.0)),
        sphere_body("/B1", (2, -1, -6), 0.6, (-2.0, 0, 0.3), decoupled=True, lifetime=(-18.0, 1.0)),
        sphere_body("/C0", (-2, -1, -5), 0.7),
        cube_body("/C1", (-2, 1.5, -5), 0.9),
        cube_body("/D", (1, -2, -3), 0.8, (0, 0.9, 0), lifetime=(-15.0, -3.0)),
    )


@pytest.mark.parametrize("finite", [True, False])
def test_merged_classes_hit_as_the_extrusion(finite):
    """Bodies of one motion class merged into one shape (one bottom level, one set of
    segments; instances copied in) give the float64 prism oracle's closest hits: the
    same rays hit, the same triangles, s within COND_TOL."""
    scene = _class_scene()
    windows = _windows(scene)
    rigid = RigidDatabase(scene, windows, origin=(-3, 0, 0, 0))
    holder = rigid.shapes.body_holder
    assert holder.tolist() == [0, 0, 0, 3, 3, 5, 5, 7], "the classes must be merged (the instances too)"
    assert len(rigid.shapes.shape_rest) == 4
    oracle = Database(scene, windows, precision="float64", primitive="prism", origin=(-3, 0, 0, 0))
    origins, dirs = _random_rays(np.random.default_rng(33 + finite), 20000, oracle, finite)
    o_idx, o_s, _ = oracle.cast(origins, dirs, finite=finite, brute=True)
    r_tri, r_s, _ = rigid.cast(origins, dirs, finite=finite)
    hit = o_idx >= 0
    assert 0.1 < hit.mean() < 0.9
    assert np.array_equal(r_tri >= 0, hit)
    assert (r_tri[hit] == oracle.prim_tri[o_idx[hit]]).mean() > 0.999
    err = _conditioned_error(oracle, o_idx[hit], r_s[hit], o_s[hit], dirs[hit], finite)
    assert err.max() < COND_TOL, err.max()
