"""The Doppler shift between a light and the surface it lights (docs/spec.md §3.5, issue 18).

Scene: the floor y = 0 seen straight down by a camera at rest at height 10 at time code 60
(c = 1), lit by a point-like SphereLight (radius 1, treatAsPoint: ρ I cos θ / r² per colour
component) of colour (1, 0.8, 0.5). Either the lamp moves at 0.5 c along x from (-25, 3, 0) at
0 (USD interpolates its two translate samples linearly) past the floor at rest, or the lamp
rests at (0, 3, 0) and the floor slides along x in its own plane (spacetime:fourVelocity).

The float64 twin, independent of the kernels but for the shift's spectral data: the retarded
emission event of uniform motion in closed form, D_ls = (k·u_floor)/(k·u_lamp) with -k·u =
u_t + l·u_x (l from the floor point towards the emission point), the incident colour shifted
by D_ls with warp_st.core.doppler_colour's direct integration (``doppler_transform_np``),
times the albedo and cos θ / r², and then the floor -> camera shift (camera at rest:
D = 1 / (-k·u_floor) with l the camera ray's direction) on top.
"""
from __future__ import annotations

import numpy as np
import pytest
from analytic_scenes import pixel_directions
from animation_stages import DOWN_CAMERA

import warp_st
from warp_st.core.doppler_colour import INTERPOLATION_ERROR, doppler_transform_np

ALBEDO = np.array([0.9, 0.9, 0.9])
COLOUR = np.array([1.0, 0.8, 0.5])
INTENSITY = 30.0
FRAME = 60.0
SIZE = (24, 18)
# Float32 shading and retarded time as tests/rendering/test_animated_lights.py (1e-3 has ample
# margin there); with the colour shift the table's interpolation (INTERPOLATION_ERROR per unit
# Smits weight, the largest weight the colour's largest component) is added per pixel.
RTOL = 1e-3

CAMERA = DOWN_CAMERA
FLOOR = """
def Mesh "Floor" {body_api}
{{
    point3f[] points = [(-60, 0, -40), (60, 0, -40), (60, 0, 40), (-60, 0, 40)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 3, 2, 1]
    color3f[] primvars:displayColor = [(0.9, 0.9, 0.9)]
    {motion}
}}
"""
LAMP = """
def SphereLight "Lamp"
{{
    float inputs:radius = 1
    bool treatAsPoint = true
    float inputs:intensity = 30
    color3f inputs:color = (1, 0.8, 0.5)
    double3 xformOp:translate{translate}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
"""
MOVING_LAMP = LAMP.format(translate=".timeSamples = { 0: (-25, 3, 0), 100: (25, 3, 0) }")
RESTING_LAMP = LAMP.format(translate=" = (0, 3, 0)")
RESTING_FLOOR = FLOOR.format(body_api="", motion="")
LAMP_START, LAMP_V = np.array([-25.0, 3.0, 0.0]), np.array([0.5, 0.0, 0.0])


def _sliding_floor(beta, decoupled):
    motion = f"double4 spacetime:fourVelocity = (1, {beta}, 0, 0)\n    double spacetime:referenceTime = {FRAME}"
    if decoupled:
        motion += "\n    bool spacetime:lorentzDecoupled = true"
    return FLOOR.format(body_api='(prepend apiSchemas = ["SpacetimeBodyAPI"])', motion=motion)


def _render(tmp_path, text, **options):
    path = tmp_path / "lit.usda"
    path.write_text(text)
    scene = warp_st.load(str(path))
    img = warp_st.render(scene, width=SIZE[0], height=SIZE[1], frame=FRAME, **options)
    assert (img.object_id == 1).all()
    cam = scene.camera_state(scene.default_camera, FRAME)
    n = pixel_directions(cam, *SIZE)
    lookback = 10.0 / -n[..., 1]
    hit = np.asarray(cam.position) + lookback[..., None] * n
    return img, n, hit, FRAME - lookback


def _emission_point(hit, t_h, start, v):
    """x(t_e) of the point start + v t seen from (t_h, hit): t_h - t_e = |hit - x(t_e)|, t_e <= t_h."""
    d = hit - start
    a, half_b, c = 1.0 - v @ v, t_h - d @ v, t_h**2 - (d * d).sum(-1)
    t_e = (half_b - np.sqrt(half_b**2 - a * c)) / a  # (1 - v²) t² - 2 (t_h - d·v) t + ... = 0, the root <= t_h
    x_e = start + t_e[..., None] * v
    assert np.allclose(np.linalg.norm(hit - x_e, axis=-1), t_h - t_e)
    return x_e


def _minus_k_dot_u(l, v, decoupled=False):
    """-k·u = u_t + l·u_x for u the four-velocity of velocity v (gamma (1, v); (1, v) decoupled)."""
    g = 1.0 if decoupled else 1.0 / np.sqrt(1.0 - v @ v)
    return g * (1.0 + l @ v)


def _lit(hit, lamp, d_ls, **flags):
    """ρ ⊙ T(D_ls)[I colour] cos θ / r² per pixel (the floor's normal +y)."""
    to = lamp - hit
    r = np.linalg.norm(to, axis=-1)
    incident = doppler_transform_np(np.broadcast_to(INTENSITY * COLOUR, hit.shape), d_ls, **flags)
    return ALBEDO * incident * (to[..., 1] / r**3)[..., None], to / r[..., None]


def _check(got, want, geometric):
    """|got - want| <= RTOL |want| + the table's bound on the incident colour's shift."""
    table = INTERPOLATION_ERROR * INTENSITY * COLOUR.max() * ALBEDO.max() * geometric
    bound = RTOL * np.abs(want) + table[..., None]
    assert (np.abs(got - want) <= bound).all(), np.abs(got - want).max()


@pytest.mark.parametrize("options", [{}, {"precision": "float64"}])
def test_passing_lamp_colour_is_shifted_by_its_retarded_velocity(tmp_path, options):
    """--doppler-color, the lamp at 0.5 c, the floor at rest: each pixel is the incident colour
    shifted by D_ls = 1 / (gamma (1 + l·v)) at the lamp's emission event, blue ahead of the lamp
    (l·v < 0: it approaches) and red behind; the unshifted lighting is far off."""
    img, _n, hit, t_h = _render(tmp_path, CAMERA + RESTING_FLOOR + MOVING_LAMP, doppler_color=True, **options)
    lamp = _emission_point(hit, t_h, LAMP_START, LAMP_V)
    to = lamp - hit
    l = to / np.linalg.norm(to, axis=-1)[..., None]
    d_ls = 1.0 / _minus_k_dot_u(l, LAMP_V)
    assert d_ls.min() < 0.85 and d_ls.max() > 1.2, "the view must hold both shifts"
    want, _l = _lit(hit, lamp, d_ls, color_shift=True, searchlight=False)
    geometric = to[..., 1] / np.linalg.norm(to, axis=-1) ** 3
    _check(img.rgba[..., :3], want, geometric)
    unshifted, _l = _lit(hit, lamp, np.ones_like(d_ls), color_shift=True, searchlight=False)
    assert np.abs(unshifted / want - 1.0).max() > 0.1


def test_passing_lamp_searchlight_scales_by_d_to_the_fourth(tmp_path):
    """--searchlight alone: the lit radiance is the plain Lambert term times D_ls⁴ (closed form)."""
    img, _n, hit, t_h = _render(tmp_path, CAMERA + RESTING_FLOOR + MOVING_LAMP, searchlight=True)
    lamp = _emission_point(hit, t_h, LAMP_START, LAMP_V)
    to = lamp - hit
    r = np.linalg.norm(to, axis=-1)
    d_ls = 1.0 / _minus_k_dot_u(to / r[..., None], LAMP_V)
    want = ALBEDO * INTENSITY * COLOUR * (d_ls**4 * to[..., 1] / r**3)[..., None]
    np.testing.assert_allclose(img.rgba[..., :3], want, rtol=RTOL)


def test_infinite_light_speed_leaves_the_lamps_time_dilation(tmp_path):
    """Infinite light speed (§1: only time dilation remains): D_ls = 1 / gamma of the lamp at 0.5 c,
    where USD puts it at the hit time; --searchlight scales the Lambert term by gamma⁻⁴ = 0.5625."""
    img, _n, hit, _t_h = _render(tmp_path, CAMERA + RESTING_FLOOR + MOVING_LAMP, searchlight=True,
                                 light_speed="infinite")
    to = LAMP_START + FRAME * LAMP_V - hit
    r = np.linalg.norm(to, axis=-1)
    want = ALBEDO * INTENSITY * COLOUR * (0.75**2 * to[..., 1] / r**3)[..., None]
    np.testing.assert_allclose(img.rgba[..., :3], want, rtol=RTOL)


@pytest.mark.parametrize("frame", [-30.0, 160.0])
def test_held_lamp_is_a_lamp_at_rest(tmp_path, frame):
    """Before its first sample and after its last USD holds the lamp (spec §3.4): it has no
    velocity there, so --searchlight leaves the beauty bit-identical to the plain render."""
    path = tmp_path / "held.usda"
    path.write_text(CAMERA + RESTING_FLOOR + MOVING_LAMP)
    scene = warp_st.load(str(path))
    plain = warp_st.render(scene, width=SIZE[0], height=SIZE[1], frame=frame)
    lit = warp_st.render(scene, width=SIZE[0], height=SIZE[1], frame=frame, searchlight=True)
    assert plain.rgba[..., :3].max() > 0.0
    assert np.array_equal(plain.rgba, lit.rgba)


@pytest.mark.parametrize("decoupled", [False, True])
def test_lamp_at_rest_over_a_sliding_floor_shifts_by_the_floors_motion(tmp_path, decoupled):
    """The lamp at rest, the floor sliding at 0.5 c along x (coupled: gamma (1, v); decoupled: (1, v)),
    --doppler-color and --searchlight: the light arrives at D_ls = -k·u_floor (the lamp's -k·u is 1),
    the floor sends it on to the camera at rest at D = 1 / (-k·u_floor) along the camera ray: the
    twin applies both transforms in turn."""
    beta = np.array([0.5, 0.0, 0.0])
    text = CAMERA + _sliding_floor(0.5, decoupled) + RESTING_LAMP
    img, n, hit, _t_h = _render(tmp_path, text, doppler_color=True, searchlight=True)
    lamp = np.broadcast_to([0.0, 3.0, 0.0], hit.shape)
    to = lamp - hit
    l = to / np.linalg.norm(to, axis=-1)[..., None]
    d_ls = _minus_k_dot_u(l, beta, decoupled)
    incident, _l = _lit(hit, lamp, d_ls, color_shift=True, searchlight=True)
    d_cam = 1.0 / _minus_k_dot_u(n, beta, decoupled)
    np.testing.assert_allclose(img.doppler, d_cam, rtol=1e-5)  # the camera side as it was
    want = doppler_transform_np(incident, d_cam, color_shift=True, searchlight=True)
    geometric = to[..., 1] / np.linalg.norm(to, axis=-1) ** 3
    table = INTERPOLATION_ERROR * INTENSITY * COLOUR.max() * ALBEDO.max() * geometric * d_ls**4
    # the second shift acts on a colour known to the first's bound: its own bound on top, per unit weight
    bound = RTOL * np.abs(want) + ((table + INTERPOLATION_ERROR * np.abs(incident).max(-1)) * d_cam**4)[..., None]
    assert (np.abs(img.rgba[..., :3] - want) <= bound).all()
    camera_only = doppler_transform_np(ALBEDO * INTENSITY * COLOUR * geometric[..., None], d_cam,
                                       color_shift=True, searchlight=True)
    assert np.abs(camera_only / want - 1.0).max() > 0.1, "the light's shift must show"


def test_moving_panel_samples_shift_one_by_one(tmp_path):
    """A 2 x 1 RectLight facing down at height 3 moving at 0.5 c along x, --searchlight: the beauty is
    ρ/π L times the sum over its 4 x 4 Gauss-Legendre points of w cos cos' / d² D_i⁴, each point
    at its own emission event with its own D_i (the light's quadrature, docs/design/usdlux.md)."""
    panel = RECT.replace("double3 xformOp:translate = (1, 3, 0)",
                         "double3 xformOp:translate.timeSamples = { 0: (-25, 3, 0), 100: (25, 3, 0) }")
    img, _n, hit, t_h = _render(tmp_path, CAMERA + RESTING_FLOOR + panel, searchlight=True)
    x, gw = np.polynomial.legendre.leggauss(4)
    total = np.zeros(hit.shape[:-1])
    spread = []
    for a, wa in zip(x, gw):
        for b, wb in zip(x, gw):
            offset = np.array([a * 1.0, 0.0, -b * 0.5])  # rotateX -90: local y -> -z
            to = _emission_point(hit, t_h, LAMP_START + offset, LAMP_V) - hit
            d = np.linalg.norm(to, axis=-1)
            d_i = 1.0 / _minus_k_dot_u(to / d[..., None], LAMP_V)
            spread.append(d_i)
            total += wa * wb / 4.0 * 2.0 * (to[..., 1] / d) ** 2 / d**2 * d_i**4  # floor and panel parallel
    want = ALBEDO / np.pi * 10.0 * total[..., None]
    np.testing.assert_allclose(img.rgba[..., :3], want, rtol=RTOL)
    assert np.ptp(spread, axis=0).max() > 0.05, "the panel's points must see different shifts"


RECT = """
def RectLight "Panel"
{
    float inputs:intensity = 10
    float inputs:width = 2
    float inputs:height = 1
    float xformOp:rotateX = -90
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
    double3 xformOp:translate = (1, 3, 0)
}
"""


@pytest.mark.parametrize("options", [{}, {"precision": "float64"}, {"primitive": "prism"}])
def test_lights_and_floor_at_rest_are_unchanged(tmp_path, options):
    """Lamp, panel and floor at rest: D_ls = 1 exactly, so --doppler-color and --searchlight leave
    the beauty bit-identical to the plain render (point and area lights)."""
    text = CAMERA + RESTING_FLOOR + RESTING_LAMP + RECT
    plain, *_ = _render(tmp_path, text, **options)
    shifted, *_ = _render(tmp_path, text, doppler_color=True, searchlight=True, **options)
    assert np.array_equal(plain.rgba, shifted.rgba)
    assert plain.rgba[..., :3].min() > 0.0
