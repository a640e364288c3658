"""The closed forms behind the shadow windows (warp_st/visibility.py) against direct
evaluation: the retarded-time root is a tight lower bound, the near-axis window holds
exactly the times a moving ball is within reach of the shadow rays' axis (both
vectorised over sources, checked against one call per source), and a body's pieces
hold the body."""
import numpy as np
import pytest

from warp_st.spacetime.visibility import _near_axis_windows, _retarded_roots


def _near_axis_window(m0, v, t_ref, centre, axis, radius):
    """One source's window as (lo, hi), or None for never."""
    lo, hi = _near_axis_windows(m0, v, t_ref, centre[None], axis[None], radius)
    return None if lo[0] > hi[0] else (lo[0], hi[0])


@pytest.mark.parametrize("seed", range(4))
def test_retarded_root_is_a_tight_lower_bound(seed):
    rng = np.random.default_rng(seed)
    for _ in range(2000):
        w = rng.normal(size=3) * 10 ** rng.uniform(-2, 4)
        v = rng.normal(size=3)
        v *= rng.uniform(0.0, 0.999999) / np.linalg.norm(v)
        k = rng.normal() * 10 ** rng.uniform(-2, 6)
        tau = _retarded_roots(w, v, k)[0]
        f = tau - np.linalg.norm(w + v * tau)
        assert f <= k  # a lower bound: the window never starts too late
        # ... and tight: within float64 rounding of the magnitudes, over the slope 1 - |v|.
        scale = 1.0 + abs(k) + np.linalg.norm(w) + abs(tau)
        assert k - f <= 1e-9 * scale, (w, v, k, tau)


@pytest.mark.parametrize("seed", range(4))
def test_near_axis_window_matches_sampled_distances(seed):
    rng = np.random.default_rng(100 + seed)
    for _ in range(300):
        m0, centre, axis = rng.normal(size=(3, 3)) * 5.0
        v = rng.normal(size=3)
        v *= rng.uniform(0.0, 0.99) / np.linalg.norm(v)
        t_ref, radius = rng.normal() * 10.0, rng.uniform(0.1, 4.0)
        window = _near_axis_window(m0, v, t_ref, centre, axis, radius)
        l = axis / np.linalg.norm(axis)
        t = np.linspace(t_ref - 200.0, t_ref + 200.0, 40001)
        d = m0[None] + (t - t_ref)[:, None] * v[None] - centre
        dist = np.linalg.norm(d - (d @ l)[:, None] * l[None], axis=1)
        near = dist <= radius
        if window is None:
            assert not near.any()
            continue
        inside = (t >= window[0]) & (t <= window[1])
        assert not (near & ~inside).any(), "a near time outside the window"
        # Tight: the window holds no sampled time farther than the grid's resolution allows.
        step = t[1] - t[0]
        assert (dist[inside] <= radius + np.linalg.norm(v) * step + 1e-9).all()


def test_near_axis_window_edge_cases():
    # At rest: always (within reach) or never.
    assert _near_axis_window(np.array([0.0, 1.0, 0]), np.zeros(3), 0.0, np.zeros(3), np.array([1.0, 0, 0]), 2.0) == (-np.inf, np.inf)
    assert _near_axis_window(np.array([0.0, 3.0, 0]), np.zeros(3), 0.0, np.zeros(3), np.array([1.0, 0, 0]), 2.0) is None
    # Moving along the axis: the distance never changes.
    assert _near_axis_window(np.array([0.0, 1.0, 0]), np.array([0.5, 0, 0]), 0.0, np.zeros(3), np.array([1.0, 0, 0]), 2.0) == (-np.inf, np.inf)
    # A light inside the hit ball gives no axis: no bound.
    assert _near_axis_window(np.array([9.0, 9.0, 9]), np.array([0.5, 0, 0]), 0.0, np.zeros(3), np.zeros(3), 1.0) == (-np.inf, np.inf)


@pytest.mark.parametrize("seed", range(3))
def test_body_pieces_hold_every_triangle(seed):
    """The shadow windows bound hit events piece by piece (visibility.body_pieces): some
    one piece's ball must hold all three contracted vertices of each triangle (so every
    point of it: a ball is convex), whatever the velocity, decoupled or not. Tolerance:
    the radius is the largest distance to the same float64 points, so only the rounding
    of sqrt and sums (~1e-16 relative) separates them; 1e-12 of the coordinates."""
    from tracing_helpers import cube_body

    from warp_st.core.lorentz import contraction_matrix
    from warp_st.core.scene import Body, surface_triangles
    from warp_st.spacetime.visibility import _MAX_PIECES, body_pieces

    rng = np.random.default_rng(seed)
    for _ in range(20):
        v = rng.normal(size=3)
        v *= rng.uniform(0.0, 0.99 if seed < 2 else 1.8) / np.linalg.norm(v)
        cubes = [cube_body("/C", rng.normal(size=3) * 5.0, rng.uniform(0.1, 6.0)) for _ in range(rng.integers(1, 4))]
        body = Body("/B", tuple(c.surfaces[0] for c in cubes), rng.normal(size=3), v, 0.0, (-np.inf, np.inf), seed == 2)
        pieces = body_pieces(body)
        assert 1 <= len(pieces) <= _MAX_PIECES
        A = contraction_matrix(body.velocity, body.decoupled)
        for surf in body.surfaces:
            tri = ((surf.points - body.origin) @ A.T + body.origin)[surface_triangles(surf)]  # (T, 3, 3)
            # Per piece, how far the triangle's farthest vertex lies outside its ball.
            outside = np.stack([(np.linalg.norm(tri - m0, axis=2) - rho).max(axis=1) for m0, rho in pieces])
            assert (outside.min(axis=0) <= 1e-12 * (1.0 + np.abs(tri).max())).all()
    # A large tiled floor (8 x 8 tiles of 4 x 4, 32 x 32) is cut into 16 pieces of 2 x 2
    # tiles: radius hypot(4, 4), a quarter of the whole floor's hypot(16, 16).
    from warp_st.core.scene import Surface

    g = np.arange(9) * 4.0 - 16.0
    pts = np.array([(x, -1.5, z) for z in g for x in g])
    quads = [(9 * j + i, 9 * (j + 1) + i, 9 * (j + 1) + i + 1, 9 * j + i + 1) for j in range(8) for i in range(8)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    pieces = body_pieces(Body("/Floor", (Surface("/Floor", pts, tris),), np.zeros(3)))
    assert len(pieces) == _MAX_PIECES and max(rho for _, rho in pieces) <= 0.25 * np.hypot(16.0, 16.0) + 1e-9


def test_vectorised_bounds_match_one_source_at_a_time():
    """Many sources in one call give what each gives alone (no mixing across rows), up to
    the rounding of sums taken in another order (a few ulps; the windows' radii are
    widened by 1e-9 relative, and the root is a lower bound in either case)."""
    rng = np.random.default_rng(7)
    m0 = rng.normal(size=3) * 5.0
    v = rng.normal(size=3)
    v *= 0.9 / np.linalg.norm(v)
    centre, axis = rng.normal(size=(2, 50, 3)) * 5.0
    axis[3] = 0.0  # a light inside the hit ball: no bound
    radius = rng.uniform(0.1, 4.0, 50)
    lo, hi = _near_axis_windows(m0, v, 1.5, centre, axis, radius)
    k = rng.normal(size=50) * 100.0
    tau = _retarded_roots(m0, v, k)
    for i in range(50):
        one = _near_axis_windows(m0, v, 1.5, centre[i:i + 1], axis[i:i + 1], radius[i:i + 1])
        np.testing.assert_allclose([one[0][0], one[1][0]], [lo[i], hi[i]], rtol=1e-12)
        np.testing.assert_allclose(_retarded_roots(m0, v, k[i])[0], tau[i], rtol=1e-12)
    assert (lo[3], hi[3]) == (-np.inf, np.inf)


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere"])
def test_occluder_window_covers_shadow_rays_to_every_point_of_an_area_light(kind):
    """Shadow rays to an area light end anywhere on it (docs/spec.md §3), not at its centre: a ball
    moving under the far edge of a wide light (half-size 4) meets the rays from a hit ball to the
    light's outermost sample point only there, over 1.5 from the axis to the light's centre. Every lab time at
    which it comes within its radius of such a ray (brute force over hit points, hit times, the
    light's samples and the ray's length) lies inside the occluder window."""
    from types import SimpleNamespace

    from warp_st.core.light_samples import area_samples
    from warp_st.core.scene import Light
    from warp_st.spacetime.visibility import _occluder_windows, intervals

    centre_l = np.array([0.0, 5.0, 0.0])
    if kind == "sphere":
        light = Light("sphere", (1.0, 1.0, 1.0), position=tuple(centre_l), radius=4.0)
        samples = centre_l + 4.0 * np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 0, 1.0], [0.7, 0, 0]])
    else:
        light = Light(kind, (1.0, 1.0, 1.0), position=tuple(centre_l), direction=(0.0, 1.0, 0.0),
                      axes=((4.0, 0.0, 0.0), (0.0, 0.0, 4.0)))
        samples = area_samples(light)[0]
    hit_centre, hit_radius, t_lo, t_hi = np.array([3.4, 0.0, 0.0]), 0.2, 0.0, 2.0
    # the ball crosses the ray to the outermost sample halfway, at lab time ~ 1 - |p - C| / 2
    edge = samples[np.argmax(samples[:, 0])]
    v, t_ref, rho = np.array([0.3, 0.0, 0.0]), 0.0, 0.3
    m0 = 0.5 * (hit_centre + edge) - v * (1.0 - 0.5 * np.linalg.norm(edge - hit_centre))
    assert np.linalg.norm(np.cross(m0 - hit_centre, centre_l - hit_centre)) / np.linalg.norm(centre_l - hit_centre) \
        > 1.5, "the ball must pass far from the axis to the light's centre"
    body = SimpleNamespace(velocity=tuple(v), reference_time=t_ref)
    scene = SimpleNamespace(lights=(light,))
    window = _occluder_windows(scene, body, m0, rho, [(hit_centre, hit_radius, t_lo, t_hi)], False)
    spans = intervals(window)
    rng = np.random.default_rng(3)
    near_times = []
    for _ in range(60):
        x = hit_centre + rng.uniform(-1, 1, 3) * hit_radius / np.sqrt(3.0)
        t = rng.uniform(t_lo, t_hi)
        for p in samples:
            s = np.linspace(0.0, np.linalg.norm(p - x), 400)
            l = (p - x) / np.linalg.norm(p - x)
            times = t - s
            gap = np.linalg.norm(x + s[:, None] * l - (m0 + (times - t_ref)[:, None] * v), axis=1)
            near_times.extend(times[gap <= rho].tolist())
    assert len(near_times) > 10, "the case must put the ball across some shadow rays"
    for tn in near_times:
        assert any(lo <= tn <= hi for lo, hi in spans), (tn, spans)
