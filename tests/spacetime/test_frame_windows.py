"""The visibility windows' array forms against their scalar definitions (spacetime/visibility.py).

Laws:
- ``frame_windows`` over rows equals ``frame_window`` row by row (the scalar quadratic of
  equation (1)): slow and superluminal bodies, |v| = 1, mirrors' ``extra``, infinite c;
- the shadow balls of an animated body's pieces (one clustering reused for all of them)
  hold every vertex of each piece, contracted, at its reference time.
"""
import numpy as np
import pytest

import warp_st
from warp_st.core.lorentz import contraction_matrix
from warp_st.core.scene import surface_triangles
from warp_st.spacetime.animation import animated_bodies, animation_cuts
from warp_st.spacetime.visibility import _body_pieces, frame_window, frame_windows

from animation_stages import HEADER, orbit_degrees, write

#: A tessellated cylinder along x (radius 0.3, length 4) spinning about +Y, tips at 0.7c.
SPINNING_CAN = HEADER + f'''def Xform "Rod" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double xformOp:rotateY.timeSamples = {{ 0: 0, 100: {orbit_degrees(0.7, 2.0, 100.0)!r} }}
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Cylinder "Can"
    {{
        double radius = 0.3
        double height = 4
        token axis = "X"
    }}
}}
'''


@pytest.mark.parametrize("infinite", [False, True])
def test_frame_windows_equal_frame_window_row_by_row(infinite):
    """2,000 random bodies against one camera, then one body against 2,000 cameras. The
    array form reorders no operation but the dot products (x0 y0 + x1 y1 + x2 y2 against
    NumPy's dot): equal within 1e-12 relative (and 1e-9 absolute near 0); None is NaN."""
    rng = np.random.default_rng(7)
    n = 2000
    speed = np.concatenate([rng.uniform(0.0, 0.999, n - 300), rng.uniform(1.0, 3.0, 200), np.ones(50), np.zeros(50)])
    d = rng.normal(size=(n, 3))
    v = speed[:, None] * d / np.linalg.norm(d, axis=1, keepdims=True)
    m0, rho, t_ref = rng.normal(size=(n, 3)) * 10, np.abs(rng.normal(size=n)) * 2, rng.normal(size=n) * 10
    cams_t, cams_c = rng.normal(size=n) * 10, rng.normal(size=(n, 3)) * 10
    for extra in (0.0, 3.0):
        cases = [(frame_windows(m0, rho, v, t_ref, 1.5, cams_c[0], infinite=infinite, extra=extra),
                  [frame_window(m0[i], rho[i], v[i], t_ref[i], 1.5, cams_c[0], infinite=infinite, extra=extra)
                   for i in range(n)]),
                 (frame_windows(m0[3], rho[3], v[3], t_ref[3], cams_t, cams_c, infinite=infinite, extra=extra),
                  [frame_window(m0[3], rho[3], v[3], t_ref[3], cams_t[i], cams_c[i], infinite=infinite, extra=extra)
                   for i in range(n)])]
        for (lo, hi), want in cases:
            none = np.array([w is None for w in want])
            assert np.isnan(lo[none]).all() and np.isnan(hi[none]).all()
            w = np.array([x for x in want if x is not None])
            assert len(w) > n // 2
            np.testing.assert_allclose(lo[~none], w[:, 0], rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(hi[~none], w[:, 1], rtol=1e-12, atol=1e-9)


def test_shadow_balls_of_the_pieces_hold_each_piece(tmp_path):
    """A spinning cylinder's pieces (hundreds of turned copies of one triangle set, cut
    into 16 clusters) share one clustering; each piece's balls still hold all of its
    contracted vertices (rounding room 1e-12 of the size)."""
    scene = warp_st.load(write(tmp_path, "can.usda", SPINNING_CAN))
    cam = scene.camera_state(None, 40.0)
    bodies, _ = animated_bodies(scene, animation_cuts(scene, [cam], width=96, height=72))
    assert len(bodies) > 100
    clusters: dict = {}
    for body in bodies:
        balls = _body_pieces(body, clusters)
        assert len(balls) == 16
        a = contraction_matrix(body.velocity, body.decoupled)
        tri = np.concatenate([((s.points - body.origin) @ a.T + body.origin)[surface_triangles(s)]
                              for s in body.surfaces]).reshape(-1, 3)
        dist = np.min([np.linalg.norm(tri - m, axis=1) - r for m, r in balls], axis=0)
        assert dist.max() <= 1e-12 * (1.0 + np.abs(tri).max())
    assert len(clusters) == 1
