"""The shadow bound of spacetime/shadow_reach.py against brute force.

Law: S, the largest s' = (m - x).l of a surface point x within rho of the line m - s' l
(s' >= -rho), is at least what dense samples of the triangles and balls find (it may be
larger: the vertices' range cut to the plane's ellipse is a bound, not the exact range),
and for a large floor under the ball it is the ellipse's far end, not the floor's size.
"""
import numpy as np

from warp_st.spacetime.shadow_reach import _deepest


def _brute(m, rho, l, tri, balls, n=160):
    """The largest s' over points sampled on the triangles (a barycentric grid) and on the
    balls (directions on a Fibonacci sphere, at their radius and inside), -inf: none."""
    a, b = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    keep = a + b <= 1.0
    a, b = a[keep], b[keep]
    pts = [t[0] + a[:, None] * (t[1] - t[0]) + b[:, None] * (t[2] - t[0]) for t in tri]
    k = np.arange(2000) + 0.5
    phi, z = np.pi * (1 + 5 ** 0.5) * k, 1 - 2 * k / 2000
    sphere = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    for c, r in zip(balls[:, :3], balls[:, 3]):
        pts += [c + f * r * sphere for f in (1.0, 0.5)]
    pts = np.concatenate(pts) if pts else np.zeros((0, 3))
    s = (m - pts) @ l
    perp = np.linalg.norm((pts - m) + s[:, None] * l, axis=1)
    near = (perp <= rho) & (s >= -rho)
    return float(s[near].max()) if near.any() else -np.inf


def test_the_bound_holds_every_sampled_surface_point():
    rng = np.random.default_rng(7)
    met = 0
    for _ in range(40):
        m = rng.normal(size=3) * 2.0
        rho = float(rng.uniform(0.2, 1.5))
        l = rng.normal(size=3)
        l /= np.linalg.norm(l)
        tri = rng.normal(size=(3, 3, 3)) * 3.0
        balls = np.column_stack([rng.normal(size=(2, 3)) * 3.0, rng.uniform(0.1, 1.0, size=2)])
        bound = _deepest(m, rho, l, tri, balls)
        found = _brute(m, rho, l, tri, balls)
        # sampling finds at most the true maximum; the bound must not be below it
        # (1e-9: rounding of the dot products)
        assert found <= bound + 1e-9
        met += np.isfinite(found)
    assert met >= 10  # the cylinder met some surface often enough to mean something


def test_a_ball_beside_the_cylinder_counts():
    """A ball whose centre is outside the cylinder but whose surface reaches into it."""
    m, rho, l = np.zeros(3), 0.5, np.array([0.0, 1.0, 0.0])
    ball = np.array([[0.9, -5.0, 0.0, 0.6]])  # 0.9 from the axis, 5 below the ball
    found = _brute(m, rho, l, np.zeros((0, 3, 3)), ball)
    assert np.isfinite(found)
    assert found <= _deepest(m, rho, l, np.zeros((0, 3, 3)), ball) + 1e-9


def test_a_large_floor_costs_its_ellipse_not_its_size():
    m, rho = np.array([0.0, 2.0, 0.0]), 0.5
    l = np.array([0.0, np.sin(np.radians(40.0)), np.cos(np.radians(40.0))])  # towards the light
    floor = np.array([[[-60, 0, -30], [60, 0, 30], [60, 0, -30]], [[-60, 0, -30], [-60, 0, 30], [60, 0, 30]]],
                     dtype=np.float64)
    bound = _deepest(m, rho, l, floor, np.zeros((0, 4)))
    # the axis meets the floor at s0 = 2 / sin 40; the cylinder's ellipse reaches rho tan 50 further
    far = 2.0 / np.sin(np.radians(40.0)) + rho / np.tan(np.radians(40.0))
    assert abs(bound - far) < 1e-9
    assert _brute(m, rho, l, floor, np.zeros((0, 4)), n=1200) <= bound + 1e-9
