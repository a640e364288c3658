"""Lambert shading, the inverse-square law and light exposure against closed forms
(docs/spec.md §3: lights at rest in the lab, intensity × color, UsdLux exposure).

Scene (a USD stage, read by warp_st.load): a large plane y = 0 with albedo ρ
(primvars:displayColor), seen from a camera at height 10 looking straight down, lit by a
UsdLux SphereLight (a point at L) and/or a DistantLight. For the hit point x of each
pixel (the pinhole ray meets the plane at s = 10 / -n_y) the beauty is

    ρ · I_s 2^E_s c_s · cos θ / r²   (sphere light: r = |L - x|, cos θ = L_y / r)
  + ρ · I_d 2^E_d c_d · cos θ_d      (distant light: θ_d between +y and the light's +Z).

Everything is at rest, so light delay changes nothing here. Tolerance: 1e-5 relative
(float32 shading of O(1) numbers: the hit point, r² and the normalisations, each a few ulps
at coordinates ~10).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from analytic_scenes import pixel_directions

import warp_st

WIDTH, HEIGHT = 24, 18
ALBEDO = np.array([0.8, 0.6, 0.4])
CAMERA_HEIGHT = 10.0


def _usd(values) -> str:
    return "(" + ", ".join(repr(float(x)) for x in values) + ")"


def _stage(tmp_path, *, sphere=None, distant=None):
    """sphere: (intensity, exposure, colour, position); distant: (intensity, exposure, colour, tilt about x in degrees)."""
    lights = ""
    if sphere is not None:
        i, e, c, p = sphere
        lights += f"""
def SphereLight "Lamp"
{{
    float inputs:intensity = {i}
    float inputs:exposure = {e}
    color3f inputs:color = {_usd(c)}
    double3 xformOp:translate = {_usd(p)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
"""
    if distant is not None:
        i, e, c, tilt = distant
        lights += f"""
def DistantLight "Sun"
{{
    float inputs:intensity = {i}
    float inputs:exposure = {e}
    color3f inputs:color = {_usd(c)}
    float xformOp:rotateX = {tilt}
    uniform token[] xformOpOrder = ["xformOp:rotateX"]
}}
"""
    path = tmp_path / "lit.usda"
    path.write_text(f"""#usda 1.0
(
    upAxis = "Y"
)

def Camera "Cam"
{{
    float focalLength = 20
    float horizontalAperture = 24
    double3 xformOp:translate = (0, {CAMERA_HEIGHT}, 0)
    float xformOp:rotateX = -90
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
}}

def Mesh "Floor"
{{
    point3f[] points = [(-40, 0, -40), (40, 0, -40), (40, 0, 40), (-40, 0, 40)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 3, 2, 1]
    color3f[] primvars:displayColor = [{_usd(ALBEDO)}]
}}
{lights}""")
    return path


def _render_and_hits(path):
    scene = warp_st.load(str(path))
    img = warp_st.render(scene, width=WIDTH, height=HEIGHT)
    cam = scene.camera_state(scene.default_camera, 0.0)
    n = pixel_directions(cam, WIDTH, HEIGHT)
    assert np.all(n[..., 1] < 0), "every pixel must look down at the floor"
    hit = np.asarray(cam.position) + (CAMERA_HEIGHT / -n[..., 1])[..., None] * n
    assert (img.object_id == 1).all()
    return img, hit


def _sphere_term(hit, intensity, exposure, colour, position):
    to_light = np.asarray(position, dtype=np.float64) - hit
    r = np.linalg.norm(to_light, axis=-1)
    cos = to_light[..., 1] / r
    return ALBEDO * intensity * 2.0**exposure * np.asarray(colour) * (cos / r**2)[..., None]


def _distant_term(intensity, exposure, colour, tilt_deg):
    # the light's local +Z (towards the light) rotated about x by the tilt: (0, -sin t, cos t)
    cos = -math.sin(math.radians(tilt_deg))
    return ALBEDO * intensity * 2.0**exposure * np.asarray(colour) * cos


@pytest.mark.parametrize("exposure", [0.0, 1.5])
def test_sphere_light_irradiance_is_lambert_over_r_squared(tmp_path, exposure):
    """A point light 4 above the floor, off the view axis: the beauty is the closed form at
    every pixel (brightness falls with cos θ / r² away from the light's foot), and doubles
    per stop of exposure."""
    lamp = (30.0, exposure, (1.0, 0.5, 0.25), (1.5, 4.0, -0.5))
    img, hit = _render_and_hits(_stage(tmp_path, sphere=lamp))
    want = _sphere_term(hit, *lamp)
    assert want.max() / want.min() > 3, "the case must show the fall-off"
    np.testing.assert_allclose(img.rgba[..., :3], want, rtol=1e-5)


def test_distant_light_is_lambert_and_the_lights_add(tmp_path):
    """A distant light whose direction is 30 degrees from the floor's normal (its +Z rotated
    by -60 degrees about x from the horizon) lights the floor uniformly with cos θ_d =
    sin 60°; with the point light as well the beauty is the sum of the two closed forms."""
    sun = (3.0, -1.0, (0.9, 1.0, 0.7), -60.0)
    img, _ = _render_and_hits(_stage(tmp_path, distant=sun))
    np.testing.assert_allclose(img.rgba[..., :3], np.broadcast_to(_distant_term(*sun), img.rgba[..., :3].shape),
                               rtol=1e-5)
    lamp = (30.0, 0.5, (1.0, 0.5, 0.25), (-2.0, 3.0, 1.0))
    img, hit = _render_and_hits(_stage(tmp_path, sphere=lamp, distant=sun))
    np.testing.assert_allclose(img.rgba[..., :3], _sphere_term(hit, *lamp) + _distant_term(*sun), rtol=1e-5)
