"""The prism fast path (the renderer's default) against the general tetrahedral path.

A prism is one triangle moving rigidly with its body's velocity over a time segment;
it is exactly the union of the three tetrahedra the general path tests, so both must
report the same closest hits and render the same images. The tetrahedral path is
itself checked against brute force and a float64 oracle in tests/accel/test_tracing.py.
"""
from pathlib import Path

import numpy as np
import pytest
from tracing_helpers import Database, mixed_scene, random_rays, tube_windows

import warp_st


@pytest.mark.parametrize("finite", [True, False])
def test_prism_hits_equal_tetrahedron_hits(finite):
    """8,000 random null rays (aimed at world-tube events across lifetimes, and random
    ones) through a mixed scene (coupled 0.9c, decoupled 2c, at rest, finite lifetimes),
    float64, brute force over every primitive on both sides (no BVH in the comparison):
    the same rays hit, the same triangle, the same lookback s. s is the same point
    computed two ways (comoving triangle vs 4D barycentrics), so it agrees to float64
    rounding of coordinates ~10 (1e-9 is 1e5 ulps of headroom). Triangles may differ only
    where the hit is on an edge shared by two triangles (then s agrees anyway)."""
    scene = mixed_scene()
    windows = tube_windows(scene)
    prism = Database(scene, windows, precision="float64", primitive="prism", origin=(-3, 0, 0, 0))
    tet = Database(scene, windows, precision="float64", primitive="tet", origin=(-3, 0, 0, 0))
    assert prism.mesh.prim_count * 3 == tet.mesh.prim_count
    rng = np.random.default_rng(21 + finite)
    origins, dirs = random_rays(rng, 8000, tet, finite)
    p_idx, p_s, _ = prism.cast(origins, dirs, finite=finite, brute=True)
    t_idx, t_s, _ = tet.cast(origins, dirs, finite=finite, brute=True)
    hit = t_idx >= 0
    assert 0.1 < hit.mean() < 0.9
    assert np.array_equal(p_idx >= 0, hit)
    np.testing.assert_allclose(p_s[hit], t_s[hit], rtol=0, atol=1e-9)
    same_tri = prism.prim_tri[p_idx[hit]] == tet.prim_tri[t_idx[hit]]
    assert same_tri.mean() > 0.999


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_prism_bvh_equals_brute_force(precision):
    """The BVH over prisms (boxes of the widened spans) culls nothing it should not."""
    scene = mixed_scene()
    db = Database(scene, tube_windows(scene), precision=precision, primitive="prism", origin=(-3, 0, 0, 0))
    rng = np.random.default_rng(5)
    origins, dirs = random_rays(rng, 12000, db)
    b_idx, b_s, _ = db.cast(origins, dirs)
    f_idx, f_s, _ = db.cast(origins, dirs, brute=True)
    assert np.array_equal(b_idx >= 0, f_idx >= 0)
    hit = f_idx >= 0
    np.testing.assert_allclose(b_s[hit], f_s[hit], rtol=0, atol=2e-4 if precision == "float32" else 1e-10)


def test_extrusion_ends_are_exact_on_the_prism_path():
    """Segments overlap their neighbours (extrude.PRISM_OVERLAP) but the extrusion's first
    and last times (here lifetime ends) stay exact: rays aimed at surface events 1e-9
    before and after each end, and at every slice time, get the same closest hit as the
    tetrahedral path (whose ends are the slice events themselves), float64."""
    from tracing_helpers import cube_body, scene_of

    body = cube_body("/C", (0, 0, -5), 2.0, (0.6, 0.2, 0), lifetime=(-10.0, -2.0))
    windows = [(-10.0, -2.0)]
    prism = Database(scene_of(body), windows, precision="float64", primitive="prism")
    tet = Database(scene_of(body), windows, precision="float64", primitive="tet")
    spans = np.unique(prism.mesh.prism_span, axis=0)
    assert len(spans) > 1 and spans[:, 0].min() == -10.0 and spans[:, 1].max() == -2.0
    rng = np.random.default_rng(2)
    times = np.concatenate([[-10.0, -2.0], np.unique(tet.mesh.vertices[:, 0])])
    times = np.concatenate([times - 1e-9, times + 1e-9])
    # Events on the cube's faces at those times, seen from 3-6 units away in random directions.
    pts = body.surfaces[0].points
    tris = body.surfaces[0].triangles
    n = 4000
    tri = tris[rng.integers(0, len(tris), n)]
    lam = rng.dirichlet(np.ones(3), n)
    t_ev = times[rng.integers(0, len(times), n)]
    from warp_st.core.lorentz import contraction_matrix

    A = contraction_matrix(body.velocity, False)
    local = (pts - body.origin) @ A.T + body.origin
    x_ev = np.einsum("nk,nkj->nj", lam, local[tri]) + np.outer(t_ev, body.velocity)
    view = rng.normal(size=(n, 3))
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    dist = rng.uniform(3.0, 6.0, n)
    origins = np.column_stack([t_ev + dist, x_ev + dist[:, None] * view])
    p_idx, p_s, _ = prism.cast(origins, -view, brute=True)
    t_idx, t_s, _ = tet.cast(origins, -view, brute=True)
    assert np.array_equal(p_idx >= 0, t_idx >= 0)
    hit = t_idx >= 0
    assert 0.2 < hit.mean() < 0.95
    np.testing.assert_allclose(p_s[hit], t_s[hit], rtol=0, atol=1e-9)


ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("stage", ["relativistic_parade.usda", "mirrors/flanges_coupled.usda", "thesis/aberration.usda"])
def test_prism_and_tet_renders_agree(stage):
    """Whole renders (shading, shadows, mirrors, every AOV) in float64: identical object
    ids and bounces per pixel, AOVs equal to 1e-9 relative (the same events computed two
    ways), colour to 1e-9 (interpolated normals from 3 vs 4 barycentrics)."""
    scene = warp_st.load(str(ROOT / "usd_scenes" / stage))
    images = [warp_st.render(scene, width=96, height=54, precision="float64", primitive=p) for p in ("prism", "tet")]
    a, b = images
    assert (a.object_id > 0).mean() > 0.05
    assert np.array_equal(a.object_id, b.object_id)
    assert np.array_equal(a.channel("spacetime.bounces"), b.channel("spacetime.bounces"))
    hit = a.object_id > 0
    for name in ("Z", "spacetime.eventTime", "spacetime.properTime", "spacetime.doppler"):
        x, y = a.channel(name)[hit].astype(np.float64), b.channel(name)[hit].astype(np.float64)
        np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-9, err_msg=name)
    np.testing.assert_allclose(a.rgba, b.rgba, rtol=0, atol=1e-9)
