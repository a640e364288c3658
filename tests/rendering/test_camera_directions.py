"""The float64 pinhole (``warp_st.rendering.camera.pixel_directions`` / ``ray_directions``)
is the kernel camera's twin: the rays the renderer traces, in the camera, rest and lab frames.

Laws (docs/spec.md §3):

- closed form: pixel (i, j) looks along ((x_ndc hAp/2 + hOff)/f, (y_ndc vAp/2 + vOff)/f, -1)
  in camera space, x_ndc = 2 (i + 1/2)/W - 1, y_ndc = 1 - 2 (j + 1/2)/H, with the vertical
  aperture conformed to the image (vAp = hAp H / W, whatever the stage authors); "rest"
  rotates it by lab_from_camera; "lab" aberrates it by the camera's velocity
  (cos a = (cos a' - beta)/(1 - beta cos a') in the plane of n' and v; Galilean for a
  decoupled camera: n_lab + v parallel to n');
- against the kernel: a static plane z = -D seen by a camera at (t_c, c) along lab direction
  n is hit at lookback s = (c_z + D) / (-n_z), and the renderer reports s as
  t_c - eventTime. A tilted, offset, non-square camera makes s first-order sensitive to the
  direction: a tenth of a pixel moves s by about 1e-3 of itself here.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from warp_st.core.scene import Body, CameraState, Surface
from warp_st.rendering.camera import pixel_directions, ray_directions
from warp_st.rendering.frame_inputs import lens_key
from warp_st.rendering.renderer import Renderer
from warp_st.testing import synthetic_scene

W, H = 40, 24
PLANE_Z = -10.0


def _camera(velocity=(0.0, 0.0, 0.0), decoupled=False) -> CameraState:
    """Tilted 25° about x and 15° about y, aperture offsets, an authored vertical aperture
    that the image's aspect overrides."""
    ax, ay = math.radians(25.0), math.radians(15.0)
    rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
    return CameraState("/Camera", 3.0, np.array([0.2, -0.1, 0.5]), ry @ rx, focal_length=24.0,
                       horizontal_aperture=36.0, vertical_aperture=30.0, horizontal_aperture_offset=1.5,
                       vertical_aperture_offset=-2.0, velocity=np.asarray(velocity, dtype=np.float64),
                       decoupled=decoupled)


def _plane_scene(cam: CameraState):
    side = 200.0
    pts = np.array([[-side, -side, PLANE_Z], [side, -side, PLANE_Z], [side, side, PLANE_Z], [-side, side, PLANE_Z]])
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    surf = Surface("/Plane", pts, tris)
    body = Body("/Plane", (surf,), np.zeros(3), np.zeros(3), 0.0, (-math.inf, math.inf), False)
    return synthetic_scene("plane", [body], [], cam)


def test_closed_form_in_camera_space():
    cam = _camera()
    d = pixel_directions(cam, W, H, frame="camera")
    assert d.shape == (H, W, 3)
    f, h_ap, v_ap = 24.0, 36.0, 36.0 * H / W  # conformed, not the authored 30
    i, j = 7, 19
    x_ndc, y_ndc = 2 * (i + 0.5) / W - 1, 1 - 2 * (j + 0.5) / H
    want = np.array([(x_ndc * h_ap / 2 + 1.5) / f, (y_ndc * v_ap / 2 - 2.0) / f, -1.0])
    np.testing.assert_allclose(d[j, i], want / np.linalg.norm(want), rtol=0, atol=1e-15)
    # the image's top edge at the principal column is atan((vAp/2 + vOff)/f) above the axis
    top = ray_directions(cam, W, H, W / 2 - 1.5 / h_ap * W, 0.0, frame="camera")
    np.testing.assert_allclose(top[0], 0.0, atol=1e-15)
    assert math.isclose(math.atan2(top[1], -top[2]), math.atan((v_ap / 2 - 2.0) / f), rel_tol=1e-14)
    np.testing.assert_allclose(pixel_directions(cam, W, H), d @ cam.rotation.T, rtol=0, atol=1e-15)


@pytest.mark.parametrize("decoupled", [False, True], ids=["relativistic", "galilean"])
def test_lab_frame_is_the_aberration_of_the_rest_frame(decoupled):
    v = np.array([0.6, 0.2, -0.5])
    cam = _camera(v, decoupled)
    n_rest = pixel_directions(cam, W, H, frame="rest").reshape(-1, 3)
    n_lab = pixel_directions(cam, W, H, frame="lab").reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(n_lab, axis=1), 1.0, atol=1e-14)
    if decoupled:  # Galilean velocity addition: the apparent direction is along n_lab + v
        along = n_lab + v
        np.testing.assert_allclose(along / np.linalg.norm(along, axis=1, keepdims=True), n_rest, atol=1e-13)
        return
    beta = np.linalg.norm(v)
    u = v / beta
    cos_rest, cos_lab = n_rest @ u, n_lab @ u
    np.testing.assert_allclose(cos_lab, (cos_rest - beta) / (1 - beta * cos_rest), atol=1e-13)
    # in the plane of n_rest and v
    np.testing.assert_allclose(np.einsum("ij,ij->i", np.cross(n_rest, u), n_lab), 0.0, atol=1e-13)


@pytest.mark.parametrize("velocity, decoupled", [((0.0, 0.0, 0.0), False), ((0.15, 0.05, -0.25), False),
                                                 ((0.15, 0.05, -0.25), True)],
                         ids=["rest", "moving", "moving_decoupled"])
def test_the_kernel_traces_these_rays(velocity, decoupled):
    cam = _camera(velocity, decoupled)
    img = Renderer(_plane_scene(cam), frames=[cam.time], width=W, height=H).render(cam.time)
    assert (img.object_id > 0).all()
    n = pixel_directions(cam, W, H, frame="lab")
    want = (cam.position[2] - PLANE_Z) / -n[..., 2]
    s = cam.time - img.event_time
    # float32 kernels: the lookback of a hit ~10-40 away carries a few float32 ulps of the
    # ray/plane arithmetic (~1e-6 relative); a tenth of a pixel would be ~1e-3.
    np.testing.assert_allclose(s, want, rtol=2e-5)


def test_an_unknown_frame_is_refused():
    with pytest.raises(ValueError, match="frame must be one of"):
        pixel_directions(_camera(), W, H, frame="world")



@pytest.mark.parametrize("velocity, decoupled", [((0.0, 0.0, 0.0), False), ((0.15, 0.05, -0.25), False),
                                                 ((0.15, 0.05, -0.25), True)],
                         ids=["rest", "moving", "moving_decoupled"])
def test_one_direction_table_per_lens(velocity, decoupled):
    """The pixel kernel computes its AOV rays' directions for a lens seen once, and reads
    them from a table once the lens is seen again (rendering.camera.camera_rays, kept on
    the database by frame_inputs.lens_key): the same float64 pinhole, so the same image bit
    for bit; the table is NumPy's pinhole rounded to float32 (then aberrated in float32
    when moving), row by row. Another frame of the lens (a later time) reads the same table.
    A renderer whose planned frames share a lens makes the table at its first frame
    (``frame_inputs.directions``' ``planned``): the same image again."""
    cam = _camera(velocity, decoupled)
    r = Renderer(_plane_scene(cam), frames=[cam.time], width=W, height=H)
    computed = r.render(cam.time)
    assert not r.database.directions, "a lens seen once has no table"
    read = r.render(cam.time)
    (table,) = r.database.directions.values()
    planned = Renderer(_plane_scene(cam), frames=[cam.time, cam.time + 2.0], width=W, height=H)  # a scene of its own
    first = planned.render(cam.time)
    (planned_table,) = planned.database.directions.values()  # a lens two planned frames share: a table at the first
    for name in ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id"):
        assert getattr(computed, name).tobytes() == getattr(read, name).tobytes(), name
        assert getattr(computed, name).tobytes() == getattr(first, name).tobytes(), name
    got = table.numpy().reshape(H, W, 3)
    if not any(velocity):
        # one rounding of the float64 pinhole to float32 apart: equal but where the float64
        # normalisation's last bit (Warp's order of operations, not NumPy's) crosses a tie
        want = pixel_directions(cam, W, H, frame="lab").astype(np.float32)
        assert np.abs(got - want).max() <= np.spacing(np.float32(1.0)) and (got == want).mean() > 0.999
    else:  # aberrated in float32 (the kernel's scalar): a few float32 ulps of unit vectors
        np.testing.assert_allclose(got, pixel_directions(cam, W, H, frame="lab"), rtol=0, atol=4e-7)
    r.render(cam.time + 2.0)  # a frame outside the plan: the database widened, the table made again
    assert len(r.database.directions) == 1
    planned.render(cam.time + 2.0)
    assert list(planned.database.directions.values()) == [planned_table]
    assert len(planned.database.frame_structs) == 2  # the two frames' cameras, one table


def test_the_lens_key_holds_what_the_directions_depend_on():
    cam = _camera((0.15, 0.05, -0.25))
    key = lens_key("float32", cam, W, H)
    assert lens_key("float32", dataclasses.replace(cam, time=9.0, position=np.ones(3)), W, H) == key
    for other in (dataclasses.replace(cam, rotation=cam.rotation[[1, 0, 2]]),
                  dataclasses.replace(cam, velocity=np.zeros(3)), dataclasses.replace(cam, decoupled=True),
                  dataclasses.replace(cam, focal_length=30.0), dataclasses.replace(cam, horizontal_aperture=30.0),
                  dataclasses.replace(cam, horizontal_aperture_offset=0.0),
                  dataclasses.replace(cam, vertical_aperture_offset=0.0)):
        assert lens_key("float32", other, W, H) != key
    assert lens_key("float32", cam, W + 1, H) != key and lens_key("float64", cam, W, H) != key
    # the authored vertical aperture is not one: the image's aspect sets it
    assert lens_key("float32", dataclasses.replace(cam, vertical_aperture=10.0), W, H) == key
