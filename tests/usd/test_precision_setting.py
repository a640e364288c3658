"""A stage's ``spacetime:precision`` (UsdRender.Settings, docs/spec.md §3) chooses the kernels'
scalar type, and the difference shows in the AOVs.

Scene: an exact plane (two triangles, no tessellation error) 10 in front of a camera at
rest whose time is 10^6, moving along itself at β = 0.999999 (coupled: its proper time
runs γ ≈ 707 times slower and depends steeply on x). Closed forms per pixel, with n the
pinhole direction: s = 10 / -n_z, event time t = t_c - s, and proper time
τ = γ((t - t_ref) - β (x - o_x)) at x = s n_x (docs/spec.md §2).

Laws: with ``float64`` the AOVs are the closed form rounded once to their float32 planes
(eventTime is stored as float32 t - t_c, properTime as float32): error ≤ half an ulp of
float32 at the value, plus 1e-9 for float64 work on numbers ~10^6. With ``float32`` the same
stage misses that bound (float32 work rounds before the storage does: about one ulp
in eventTime, and ~10^-4 in τ, whose γ(Δt - β Δx) cancels). The Image and its header record
the precision; a ``precision=`` keyword overrides the stage.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from analytic_scenes import pixel_directions

import warp_st

T_C, DISTANCE, BETA = 1.0e6, 10.0, 0.999999
WIDTH, HEIGHT = 16, 12


def _stage(tmp_path, precision: str):
    half_x = 5.0e4  # rest length: contracted by γ ≈ 707 to ±71 in the lab
    path = tmp_path / f"plane_{precision}.usda"
    path.write_text(f"""#usda 1.0
(
    upAxis = "Y"
    renderSettingsPrimPath = "/Render/Settings"
)

def Camera "Cam" (
    prepend apiSchemas = ["SpacetimeCameraAPI"]
)
{{
    float focalLength = 30
    float horizontalAperture = 24
    custom double spacetime:time = {T_C!r}
}}

def Xform "Plane" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{{
    double3 xformOp:translate = (0, 0, {-DISTANCE!r})
    uniform token[] xformOpOrder = ["xformOp:translate"]
    custom double4 spacetime:fourVelocity = (1, {BETA!r}, 0, 0)
    custom double spacetime:referenceTime = {T_C - DISTANCE!r}

    def Mesh "Surface"
    {{
        point3f[] points = [({-half_x}, -50, 0), ({half_x}, -50, 0), ({half_x}, 50, 0), ({-half_x}, 50, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
    }}
}}

def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        custom token spacetime:precision = "{precision}"
    }}
}}
""")
    return path


def _beyond_float64(img, scene):
    """Masks of the pixels whose eventTime / properTime miss the float64 bound: the closed
    form rounded once to float32 (half an ulp at the value) plus float64 work, 64 eps64 of
    |t_c| + s for the event time (t_c is added back in float64) and, for τ, 64 eps64 γ² of
    the coordinates it is formed from, t - t_ref and x - o from events and a pivot ~ s + 10
    about the camera event (entries of size γ multiplied: test_lorentz's rule)."""
    cam = scene.camera_state(scene.default_camera, T_C)
    n = pixel_directions(cam, WIDTH, HEIGHT)
    assert (img.object_id == 1).all(), "every pixel must see the plane"
    s = DISTANCE / -n[..., 2]
    t = T_C - s
    gamma = 1.0 / math.sqrt((1.0 - BETA) * (1.0 + BETA))
    x = s * n[..., 0]
    tau = gamma * ((t - (T_C - DISTANCE)) - BETA * x)
    eps64 = float(np.finfo(np.float64).eps)
    dt = np.abs(img.event_time - t) > _half_ulp32(s) + 64 * eps64 * (T_C + s)
    size = 2.0 * (s + DISTANCE)
    dtau = np.abs(img.proper_time.astype(np.float64) - tau) > _half_ulp32(tau) + 64 * eps64 * gamma**2 * size
    return dt, dtau


def _half_ulp32(x):
    return 0.5 * np.spacing(np.abs(x).astype(np.float32)).astype(np.float64)


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    folder = tmp_path_factory.mktemp("precision")
    out = {}
    for precision in ("float64", "float32"):
        scene = warp_st.load(str(_stage(folder, precision)))
        out[precision] = (scene, warp_st.render(scene, width=WIDTH, height=HEIGHT))
    return out


def test_float64_stage_renders_to_the_storage_rounding(renders):
    scene, img = renders["float64"]
    assert scene.settings.precision.value == "float64" and img.precision == "float64"
    dt, dtau = _beyond_float64(img, scene)
    assert not dt.any() and not dtau.any(), (dt.sum(), dtau.sum())


def test_float32_stage_is_visibly_less_exact(renders):
    """Measured: about 30 % of the pixels' event times and most proper times miss the float64
    bound in float32; 10 % is required."""
    scene, img = renders["float32"]
    assert img.precision == "float32"
    dt, dtau = _beyond_float64(img, scene)
    assert dt.mean() > 0.1 and dtau.mean() > 0.1, (dt.mean(), dtau.mean())


def test_the_keyword_overrides_the_stage(renders):
    scene, _ = renders["float64"]
    img = warp_st.render(scene, width=WIDTH, height=HEIGHT, precision="float32")
    np.testing.assert_array_equal(img.proper_time, renders["float32"][1].proper_time)
    assert img.precision == "float32"
