"""The Doppler factor of light reflected by a moving mirror (docs/light_transport.md).

Scene: a camera at rest at the origin looks down -z at a plane mirror (normal +z) that
moves along its normal at β; behind the camera an emissive panel at rest faces it. Every
pixel sees the panel in the mirror, so the light's frequency changes only at the moving
mirror. Oracle, float64 boost -> reflect -> boost back (warp_st.core.lorentz): the photon
arriving at the camera along -n has k = (1, -n); in the mirror's rest frame
k' = boost(v) k, the mirror reflects its spatial part about the normal N (the plane is
perpendicular to v, so N is the same in both frames), and lab_from_rest(v) takes it back:
the photon the panel emitted had energy k_in,t, so D = k_t / k_in,t = 1 / k_in,t (camera
and panel at rest). Head on this is (1 + β)/(1 - β) for a mirror approaching the camera.

Laws: with --doppler-color / --searchlight the pixel is the panel's emission transformed
by that D (the float64 twin of the kernel's transform); without them it is the emission
exactly (the options are off by default).
"""
from __future__ import annotations

import numpy as np
import pytest
from analytic_scenes import EPS32, pixel_directions

from warp_st.core import lorentz
from warp_st.core.scene import Body, CameraState, Material, RenderSettings, Scene, Surface
from warp_st.core.doppler_colour import INTERPOLATION_ERROR, doppler_transform_np
from warp_st.rendering.renderer import Renderer

EMISSION = np.array([0.3, 0.45, 0.2])
WIDTH, HEIGHT = 12, 9


def _quad(path, z, half, material, velocity=(0.0, 0.0, 0.0), t_ref=0.0):
    pts = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]])
    return Body(path, (Surface(path, pts, np.array([[0, 1, 2], [0, 2, 3]]), material),), np.array([0.0, 0.0, z]),
                np.asarray(velocity, dtype=np.float64), t_ref)


def _scene(beta):
    # the mirror is at z = -5 at t = -5, when the centre ray meets it
    mirror = _quad("/Mirror", -5.0, 8.0, Material((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), 1.0), (0.0, 0.0, beta), -5.0)
    panel = _quad("/Panel", 3.0, 40.0, Material((0.0, 0.0, 0.0), tuple(EMISSION), 0.0))

    def camera_state(path, frame):
        return CameraState("/Camera", float(frame), np.zeros(3), np.eye(3), 50.0, 20.0, 15.0)

    return Scene("<mirror>", (mirror, panel), (), ("/Camera",), RenderSettings(), camera_state,
                 default_camera="/Camera"), camera_state("/Camera", 0.0)


def boost_reflect_boost(n, v, normal) -> np.ndarray:
    """D = received / emitted frequency after a mirror moving with v (normal ⊥ its plane,
    parallel to v), for camera look directions n (..., 3); camera and source at rest."""
    k = np.concatenate([np.ones(n.shape[:-1] + (1,)), -n], axis=-1)
    k_rest = np.einsum("ij,...j->...i", lorentz.boost(v), k)
    spatial = k_rest[..., 1:]
    k_rest[..., 1:] = spatial - 2.0 * (spatial @ normal)[..., None] * normal
    k_in = np.einsum("ij,...j->...i", lorentz.lab_from_rest(v), k_rest)
    return k[..., 0] / k_in[..., 0]


CASES = [  # (β, colour shift, searchlight): small β keeps the shifted lines in the visible band
    (0.05, True, False), (-0.05, True, False), (0.05, True, True), (-0.05, True, True),
    (0.3, False, True), (-0.5, False, True),
]


@pytest.mark.parametrize("beta, color_shift, searchlight", CASES)
def test_moving_mirror_doppler_is_the_boost_reflect_boost_twin(beta, color_shift, searchlight):
    """β > 0 approaches the camera (blueshift), β < 0 recedes (redshift). Tolerance:
    float32 work gives D to ~64 eps32 relative (the kernel multiplies the energy by one
    factor per reflection); the transform's sensitivity to D is at most ~4 (D^4) plus the
    colour responses' slope (< 20), hence 1024 eps32 ≈ 1.2e-4 relative; with the colour
    shift plus the table's interpolation bound times the largest component (0.45), times
    D^4 with the searchlight."""
    scene, cam = _scene(beta)
    v, normal = np.array([0.0, 0.0, beta]), np.array([0.0, 0.0, 1.0])
    d = boost_reflect_boost(pixel_directions(cam, WIDTH, HEIGHT), v, normal)
    assert abs(boost_reflect_boost(np.array([0.0, 0.0, -1.0]), v, normal) - (1 + beta) / (1 - beta)) < 1e-14
    plain = Renderer(scene, frames=[0.0], width=WIDTH, height=HEIGHT, max_depth=1).render(0.0)
    assert (plain.object_id == 1).all() and (plain.bounces == 1).all(), "every pixel must see the panel in the mirror"
    np.testing.assert_allclose(plain.rgba[..., :3], np.broadcast_to(EMISSION, plain.rgba[..., :3].shape), rtol=1e-6)
    img = Renderer(scene, frames=[0.0], width=WIDTH, height=HEIGHT, max_depth=1, doppler_color=color_shift,
                   searchlight=searchlight).render(0.0)
    want = doppler_transform_np(np.broadcast_to(EMISSION, d.shape + (3,)), d, color_shift=color_shift,
                                searchlight=searchlight)
    assert np.abs(want - EMISSION).max() > 0.01, "the case must change the colour"
    table = INTERPOLATION_ERROR * EMISSION.max() * (d.max() ** 4 if searchlight else 1.0) if color_shift else 0.0
    np.testing.assert_allclose(img.rgba[..., :3], want, rtol=1024 * EPS32, atol=1e-6 + table)
