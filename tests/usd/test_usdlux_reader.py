"""UsdLux lights as the reader turns them into Light (docs/spec.md §3 additions, docs/design/usdlux.md).

The law: L = intensity · 2^exposure · color · blackbody(colorTemperature) · diffuse (/ sizeFactor with
normalize); a SphereLight's radiance is I / π = L r² (r its world radius), a DistantLight's E / π, an area
light's L / π. Expected values are computed here from those formulas in float64 from the authored float32
inputs (rel 1e-12: a few float64 roundings); the blackbody colour comes from USD itself.
"""
from __future__ import annotations

import math
import textwrap
import warnings

import numpy as np
import pytest
from pxr import UsdLux

from warp_st.usd.reader import load_scene

RTOL = 1e-12


def _load(tmp_path, body):
    path = tmp_path / "lights.usda"
    path.write_text("#usda 1.0\n" + textwrap.dedent(body) + '\ndef Sphere "Ball" {}\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(str(path))
    return scene, [str(w.message) for w in caught]


def test_sphere_light_radius_scale_treat_as_point_and_normalize(tmp_path):
    scene, _ = _load(tmp_path, '''
        def SphereLight "Big" {
            float inputs:intensity = 3
            float inputs:radius = 0.5
            float3 xformOp:scale = (2, 2, 2)
            uniform token[] xformOpOrder = ["xformOp:scale"]
        }
        def SphereLight "Point" {
            float inputs:intensity = 3
            float inputs:radius = 0.5
            bool treatAsPoint = true
        }
        def SphereLight "Normalized" {
            float inputs:intensity = 3
            float inputs:radius = 0.25
            bool inputs:normalize = true
        }
        def SphereLight "NormalizedPoint" {
            float inputs:intensity = 3
            float inputs:radius = 0
            bool inputs:normalize = true
        }''')
    big, point, normalized, tiny = scene.lights
    assert big.radius == 1.0 and big.radiance == (3.0, 3.0, 3.0)  # world radius 1: L r^2 = 3
    assert point.radius == 0.0 and point.radiance == (0.75, 0.75, 0.75)  # the sphere's power, at a point
    np.testing.assert_allclose(normalized.radiance, [3.0 / (4.0 * math.pi)] * 3, rtol=RTOL)
    assert normalized.radius == 0.25
    np.testing.assert_allclose(tiny.radiance, [3.0 / (4.0 * math.pi)] * 3, rtol=RTOL)  # the r -> 0 limit


def test_a_zero_radius_sphere_light_without_normalize_warns_that_it_emits_nothing(tmp_path):
    scene, messages = _load(tmp_path, 'def SphereLight "Dot" {\n float inputs:radius = 0\n}')
    assert scene.lights[0].radiance == (0.0, 0.0, 0.0)
    assert any("/Dot: inputs:radius: a SphereLight of radius 0 without inputs:normalize emits nothing" in m
               for m in messages), messages


def test_colour_temperature_exposure_and_diffuse_multiply_the_emission(tmp_path):
    scene, messages = _load(tmp_path, '''
        def SphereLight "Warm" {
            float inputs:intensity = 2
            float inputs:exposure = 1.5
            float inputs:diffuse = 0.5
            float inputs:radius = 1
            bool inputs:normalize = true
            color3f inputs:color = (1, 0.5, 0.25)
            bool inputs:enableColorTemperature = true
            float inputs:colorTemperature = 3000
        }''')
    blackbody = np.array(UsdLux.BlackbodyTemperatureAsRgb(3000.0), dtype=np.float64)
    want = 2.0 * 2.0**1.5 * 0.5 * np.array([1.0, 0.5, 0.25]) * blackbody / (4.0 * math.pi)  # normalized, r = 1
    np.testing.assert_allclose(scene.lights[0].radiance, want, rtol=RTOL)
    assert not [m for m in messages if "/Warm" in m], messages  # all honoured: no warning


def test_distant_light_defaults_angle_and_normalize(tmp_path):
    scene, _ = _load(tmp_path, '''
        def DistantLight "Default" {
        }
        def DistantLight "Wide" {
            float inputs:intensity = 2
            float inputs:angle = 200
        }
        def DistantLight "Parallel" {
            float inputs:intensity = 2
            float inputs:angle = 0
        }
        def DistantLight "Normalized" {
            float inputs:intensity = 2
            float inputs:angle = 10
            bool inputs:normalize = true
        }''')
    default, wide, parallel, normalized = (light.radiance[0] for light in scene.lights)
    half = math.radians(float(np.float32(0.53))) / 2.0
    np.testing.assert_allclose(default, 50000.0 * math.sin(half) ** 2, rtol=RTOL)  # E / pi = L sin^2
    # past a hemisphere (theta_max > pi / 2): sizeFactor = pi (2 - sin^2 theta_max)
    np.testing.assert_allclose(wide, 2.0 * (2.0 - math.sin(math.radians(100.0)) ** 2), rtol=RTOL)
    np.testing.assert_allclose(parallel, 2.0 / math.pi, rtol=RTOL)
    np.testing.assert_allclose(normalized, 2.0 / math.pi, rtol=RTOL)  # intensity is the irradiance


def test_rect_and_disk_lights_carry_their_world_frame_and_area(tmp_path):
    scene, _ = _load(tmp_path, '''
        def RectLight "Panel" {
            float inputs:intensity = 6
            float inputs:width = 2
            float inputs:height = 3
            bool inputs:normalize = true
            double3 xformOp:translate = (1, 2, 3)
            float3 xformOp:scale = (1, 2, 1)
            uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        }
        def DiskLight "Spot" {
            float inputs:intensity = 6
            float inputs:radius = 0.5
            float xformOp:rotateX = 90
            uniform token[] xformOpOrder = ["xformOp:rotateX"]
        }''')
    panel, spot = scene.lights
    assert panel.kind == "rect" and panel.position == (1.0, 2.0, 3.0) and panel.direction == (0.0, 0.0, 1.0)
    assert panel.axes == ((1.0, 0.0, 0.0), (0.0, 3.0, 0.0))  # half-extents, the Y scale included
    np.testing.assert_allclose(panel.radiance, [6.0 / 12.0 / math.pi] * 3, rtol=RTOL)  # world area 2 x 6
    assert spot.kind == "disk"
    np.testing.assert_allclose(spot.direction, [0.0, -1.0, 0.0], atol=1e-12)  # +Z turned by rotateX 90
    np.testing.assert_allclose(spot.axes, [[0.5, 0.0, 0.0], [0.0, 0.0, 0.5]], atol=1e-12)
    np.testing.assert_allclose(spot.radiance, [6.0 / math.pi] * 3, rtol=RTOL)


def test_an_area_light_without_area_is_ignored_with_a_warning(tmp_path):
    """Zero or negative sizes (UsdLux clips them to 0) are real-world problems: warnings, not errors."""
    scene, messages = _load(tmp_path, 'def RectLight "Slit" {\n float inputs:width = 0\n}\n'
                                      'def DiskLight "Dot" {\n float inputs:radius = -1\n}')
    assert scene.lights == ()
    assert any("/Slit: the RectLight has no area; ignored" in m for m in messages), messages
    assert any("/Dot: inputs:radius: is negative (-1); 0 is used" in m for m in messages), messages
    assert any("/Dot: the DiskLight has no area; ignored" in m for m in messages), messages


@pytest.mark.parametrize("attribute, why", [
    ("float inputs:shaping:cone:angle = 30", "inputs:shaping:cone:angle: light shaping is not supported"),
    ("float inputs:specular = 0.5", "inputs:specular: the light's specular multiplier is not honoured"),
])
def test_what_is_not_honoured_warns_naming_prim_and_attribute(tmp_path, attribute, why):
    _, messages = _load(tmp_path, f'def DiskLight "Spot" (prepend apiSchemas = ["ShapingAPI"]) {{\n {attribute}\n}}')
    assert sum(f"/Spot: {why}" in m for m in messages) == 1, messages


def test_flattened_transforms_are_warnings_not_errors(tmp_path):
    """A RectLight scaled flat along its Z still has its area and emits along -(X × Y); a DiskLight
    scaled to nothing along X has no area and is skipped with a warning. Neither stops the render."""
    scene, messages = _load(tmp_path, '''
        def RectLight "Flat" {
            float3 xformOp:scale = (1, 1, 0)
            uniform token[] xformOpOrder = ["xformOp:scale"]
        }
        def DiskLight "Gone" {
            float3 xformOp:scale = (0, 1, 1)
            uniform token[] xformOpOrder = ["xformOp:scale"]
        }''')
    (flat,) = scene.lights
    assert flat.kind == "rect" and flat.direction == (0.0, 0.0, 1.0)
    assert any("/Gone: the DiskLight has no area; ignored" in m for m in messages), messages


def test_a_mesh_light_warns_that_it_does_not_light_the_scene(tmp_path):
    scene, messages = _load(tmp_path, '''
        def Mesh "Panel" (prepend apiSchemas = ["MeshLightAPI"]) {
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
        }''')
    assert scene.lights == ()
    assert sum("/Panel: MeshLightAPI / VolumeLightAPI is not honoured" in m for m in messages) == 1, messages
