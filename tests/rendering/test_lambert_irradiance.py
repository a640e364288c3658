"""Lambert shading, the inverse-square law and light exposure against closed forms
(docs/spec.md §3: lights at rest in the lab, UsdLux intensity × color × 2^exposure).

Scene (a USD stage, read by warp_st.load): a large plane y = 0 with albedo ρ
(primvars:displayColor), seen from a camera at height 10 looking straight down, lit by a
UsdLux SphereLight of radius 1 treated as a point at L (a sphere of radiance L_s and
radius R shines as a point of radiant intensity π L_s R², so ρ/π · π L_s R² = ρ L_s)
and/or a DistantLight of angle 0 (its irradiance at normal incidence E = L_d). For the
hit point x of each pixel (the pinhole ray meets the plane at s = 10 / -n_y) the beauty is

    ρ · I_s 2^E_s c_s · cos θ / r²        (sphere light: r = |L - x|, cos θ = L_y / r)
  + ρ / π · I_d 2^E_d c_d · cos θ_d       (distant light: θ_d between +y and the light's +Z).

These are the scenes of 0.4 re-authored for UsdLux's units (radius 1 and treatAsPoint;
angle 0 and the sun's intensity × π): they render as before.

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


def _stage(tmp_path, *, sphere=None, distant=None, extra=""):
    """sphere: (intensity, exposure, colour, position); distant: (intensity, exposure, colour, tilt about x in
    degrees); extra: more prims (USD text)."""
    lights = extra
    if sphere is not None:
        i, e, c, p = sphere
        lights += f"""
def SphereLight "Lamp"
{{
    float inputs:radius = 1
    bool treatAsPoint = true
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
    float inputs:angle = 0
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


def _render_and_hits(path, *, size=(WIDTH, HEIGHT), floor_only=True, **options):
    """The render and each pixel ray's hit on the floor plane (and, without ``floor_only``, the camera's
    lookback to it)."""
    scene = warp_st.load(str(path))
    img = warp_st.render(scene, width=size[0], height=size[1], **options)
    cam = scene.camera_state(scene.default_camera, 0.0)
    n = pixel_directions(cam, *size)
    assert np.all(n[..., 1] < 0), "every pixel must look down at the floor"
    lookback = CAMERA_HEIGHT / -n[..., 1]
    hit = np.asarray(cam.position) + lookback[..., None] * n
    if floor_only:
        assert (img.object_id == 1).all()
        return img, hit
    return img, hit, lookback


def _sphere_term(hit, intensity, exposure, colour, position):
    to_light = np.asarray(position, dtype=np.float64) - hit
    r = np.linalg.norm(to_light, axis=-1)
    cos = to_light[..., 1] / r
    return ALBEDO * intensity * 2.0**exposure * np.asarray(colour) * (cos / r**2)[..., None]


def _distant_term(intensity, exposure, colour, tilt_deg):
    # the light's local +Z (towards the light) rotated about x by the tilt: (0, -sin t, cos t)
    cos = -math.sin(math.radians(tilt_deg))
    return ALBEDO / math.pi * intensity * 2.0**exposure * np.asarray(colour) * cos


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
    sun = (3.0 * math.pi, -1.0, (0.9, 1.0, 0.7), -60.0)
    img, _ = _render_and_hits(_stage(tmp_path, distant=sun))
    np.testing.assert_allclose(img.rgba[..., :3], np.broadcast_to(_distant_term(*sun), img.rgba[..., :3].shape),
                               rtol=1e-5)
    lamp = (30.0, 0.5, (1.0, 0.5, 0.25), (-2.0, 3.0, 1.0))
    img, hit = _render_and_hits(_stage(tmp_path, sphere=lamp, distant=sun))
    np.testing.assert_allclose(img.rgba[..., :3], _sphere_term(hit, *lamp) + _distant_term(*sun), rtol=1e-5)


# -- UsdLux as specified (docs/spec.md §3 additions): radius, normalize, angle, area lights --------------
#
# A Lambert surface of albedo ρ under irradiance E shows ρ/π · E. The closed forms for E:
# - sphere of radiance L and radius R at distance r, wholly above the horizon: E = L π R² cos θ / r²;
#   with normalize L = intensity / (4π R²);
# - distant light of angular diameter a: E = L π sin²(a/2) cos θ_d (E = L cos θ_d for a = 0); with
#   normalize E = intensity cos θ_d;
# - disk of radiance L, radius R, parallel to the floor at height h, a point ρ off its axis:
#   E = π L / 2 · (1 - (h² + ρ² - R²) / √((h² + ρ² + R²)² - 4 ρ² R²))  (on the axis π L R² / (R² + h²));
# - rect (any polygon) of radiance L: Lambert's formula E = L / 2 · Σ_i θ_i N·(a_i × a_{i+1}) / |a_i × a_{i+1}|,
#   a_i the unit vectors from the point to the corners, θ_i the angles between successive ones.
# Area lights are integrated by a few fixed Gauss-Legendre points (warp_st.core.light_samples); at the
# distances used here (twice the light's half-size and more) that quadrature is within 1.3e-5 of the
# closed forms (docs/design/usdlux.md), so 1e-3 relative (the target) has ample margin over it
# and over float32 shading (1e-6).
AREA_RTOL = 1e-3


def _light_prim(kind: str, body: str, *, at=(0.0, 0.0, 0.0), down: bool = False) -> str:
    """A UsdLux prim; ``down``: its -Z (an area light's emission) turned to -y (rotateX -90)."""
    ops = f"double3 xformOp:translate = {_usd(at)}\n"
    order = '"xformOp:translate"'
    if down:
        ops += "float xformOp:rotateX = -90\n"
        order += ', "xformOp:rotateX"'
    return f'def {kind} "Light"\n{{\n{body}\n{ops}uniform token[] xformOpOrder = [{order}]\n}}\n'


def test_sphere_light_radius_and_normalize(tmp_path):
    """A SphereLight of radius 0.5 (not a point) 4 above the floor: ρ L R² cos θ / r² at every pixel
    (the shadow rays to its silhouette all arrive); normalized, ρ intensity cos θ / (4π r²)."""
    centre = np.array([1.5, 4.0, -0.5])
    for normalize, scale in ((False, 0.25), (True, 1.0 / (4.0 * math.pi))):
        body = f"float inputs:intensity = 30\nfloat inputs:radius = 0.5\nbool inputs:normalize = {str(normalize).lower()}"
        img, hit = _render_and_hits(_stage(tmp_path, extra=_light_prim("SphereLight", body, at=centre)))
        to_light = centre - hit
        r = np.linalg.norm(to_light, axis=-1)
        want = ALBEDO * 30.0 * scale * (to_light[..., 1] / r**3)[..., None]
        np.testing.assert_allclose(img.rgba[..., :3], want, rtol=1e-5)


def test_distant_light_at_its_schema_defaults_is_a_sane_sun(tmp_path):
    """The sample-asset case of issue 16: a DistantLight with nothing authored (intensity 50000, angle
    0.53 degrees, from usd-core's schema) straight above an albedo-ρ floor shows ρ/π · E with
    E = 50000 π sin²(0.265°) ≈ 3.36: about ρ, not ρ × 50000."""
    from pxr import Usd, UsdLux

    stage = Usd.Stage.CreateInMemory()
    schema = UsdLux.DistantLight.Define(stage, "/D")
    intensity, angle = schema.GetIntensityAttr().Get(), schema.GetAngleAttr().Get()
    assert (intensity, round(angle, 6)) == (50000.0, 0.53)
    irradiance = intensity * math.pi * math.sin(math.radians(angle) / 2.0) ** 2
    path = _stage(tmp_path, extra='def DistantLight "Sun"\n{\nfloat xformOp:rotateX = -90\n'
                                  'uniform token[] xformOpOrder = ["xformOp:rotateX"]\n}\n')
    img, _ = _render_and_hits(path)
    want = np.broadcast_to(ALBEDO / math.pi * irradiance, img.rgba[..., :3].shape)
    np.testing.assert_allclose(img.rgba[..., :3], want, rtol=1e-5)
    assert 0.5 < img.rgba[..., :3].max() < 1.5


@pytest.mark.parametrize("angle, normalize", [(5.0, False), (5.0, True), (40.0, False)])
def test_distant_light_angle_and_normalize_obey_the_cosine_law(tmp_path, angle, normalize):
    """At 30 degrees from the normal: ρ/π · L π sin²(a/2) · cos 30° (normalized: ρ/π · intensity · cos 30°)."""
    body = f"float inputs:intensity = 2\nfloat inputs:angle = {angle}\nbool inputs:normalize = {str(normalize).lower()}"
    path = _stage(tmp_path, extra=f'def DistantLight "Sun"\n{{\n{body}\nfloat xformOp:rotateX = -60\n'
                                  'uniform token[] xformOpOrder = ["xformOp:rotateX"]\n}\n')
    img, _ = _render_and_hits(path)
    size = 1.0 if normalize else math.pi * math.sin(math.radians(angle) / 2.0) ** 2
    want = ALBEDO / math.pi * 2.0 * size * math.cos(math.radians(30.0))
    np.testing.assert_allclose(img.rgba[..., :3], np.broadcast_to(want, img.rgba[..., :3].shape), rtol=1e-5)


def _disk_irradiance(radiance, radius, height, off_axis):
    a = height**2 + off_axis**2
    return math.pi * radiance / 2.0 * (1.0 - (a - radius**2) / np.sqrt((a + radius**2) ** 2 - 4 * off_axis**2 * radius**2))


def test_disk_light_matches_the_parallel_disk_closed_form(tmp_path):
    """A DiskLight (radius 0.5, intensity 8) facing the floor from height 2, centred above one pixel's
    hit: that pixel matches π L R² / (R² + h²), and every pixel the off-axis closed form; normalized,
    L = intensity / (π R²)."""
    probe = _render_and_hits(_stage(tmp_path))[1][9, 12]
    centre = np.array([probe[0], 2.0, probe[2]])
    for normalize, radiance in ((False, 8.0), (True, 8.0 / (math.pi * 0.25))):
        body = f"float inputs:intensity = 8\nfloat inputs:radius = 0.5\nbool inputs:normalize = {str(normalize).lower()}"
        img, hit = _render_and_hits(_stage(tmp_path, extra=_light_prim("DiskLight", body, at=centre, down=True)))
        off = np.linalg.norm((hit - centre)[..., [0, 2]], axis=-1)
        want = ALBEDO / math.pi * _disk_irradiance(radiance, 0.5, 2.0, off)[..., None]
        on_axis = ALBEDO / math.pi * (math.pi * radiance * 0.25 / (0.25 + 4.0))
        np.testing.assert_allclose(img.rgba[9, 12, :3], on_axis, rtol=AREA_RTOL)
        np.testing.assert_allclose(img.rgba[..., :3], want, rtol=AREA_RTOL)
        assert want.max() / want.min() > 3, "the case must show the fall-off"


def _polygon_irradiance(radiance, corners, hit, normal):
    """Lambert's formula for a polygon wholly above the point's horizon, per hit (…, 3)."""
    a = [(c - hit) / np.linalg.norm(c - hit, axis=-1, keepdims=True) for c in corners]
    total = 0.0
    for p, q in zip(a, a[1:] + a[:1]):
        cross = np.cross(p, q)
        theta = np.arccos(np.clip(np.sum(p * q, axis=-1), -1.0, 1.0))
        total = total + theta * (cross @ normal) / np.linalg.norm(cross, axis=-1)
    return radiance / 2.0 * np.abs(total)


def test_rect_light_matches_lamberts_polygon_formula(tmp_path):
    """A RectLight 1 × 1.5 (its local X and Y) at height 2 facing the floor, scaled by 2 along X by its
    transform (world size 2 × 1.5): every pixel matches Lambert's formula over its world corners;
    normalized, L = intensity / world area."""
    centre = np.array([0.7, 2.0, -0.4])
    # rotateX -90 takes local X to +x and local Y to -z; the scale doubles local X
    u, v = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -0.75])
    corners = [centre - u - v, centre + u - v, centre + u + v, centre - u + v]
    for normalize, radiance in ((False, 5.0), (True, 5.0 / 3.0)):
        body = (f"float inputs:intensity = 5\nfloat inputs:width = 1\nfloat inputs:height = 1.5\n"
                f"bool inputs:normalize = {str(normalize).lower()}")
        prim = (f'def RectLight "Light"\n{{\n{body}\ndouble3 xformOp:translate = {_usd(centre)}\n'
                'float xformOp:rotateX = -90\nfloat3 xformOp:scale = (2, 1, 1)\n'
                'uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX", "xformOp:scale"]\n}\n')
        img, hit = _render_and_hits(_stage(tmp_path, extra=prim))
        want = ALBEDO / math.pi * _polygon_irradiance(radiance, corners, hit, np.array([0.0, 1.0, 0.0]))[..., None]
        np.testing.assert_allclose(img.rgba[..., :3], want, rtol=AREA_RTOL)
        assert want.max() / want.min() > 3, "the case must show the fall-off"


def test_area_lights_emit_from_one_side_only(tmp_path):
    """Turned away (its -Z up), a DiskLight above the floor lights nothing: the beauty is black."""
    prim = _light_prim("DiskLight", "float inputs:intensity = 8", at=(0.0, 2.0, 0.0)).replace(
        "double3 xformOp:translate", "float xformOp:rotateX = 90\ndouble3 xformOp:translate").replace(
        '"xformOp:translate"]', '"xformOp:translate", "xformOp:rotateX"]')
    img, _ = _render_and_hits(_stage(tmp_path, extra=prim))
    assert np.all(img.rgba[..., :3] == 0.0)


# -- shadows from area and sphere lights: a NumPy twin of the sampled shadow rays ---------------------
#
# A cube (size 0.8) between a light and the floor; the oracle traces each documented shadow sample
# (docs/spec.md §3: a RectLight's 4 × 4 Gauss-Legendre points; a SphereLight's silhouette centre and four
# points at 0.7 of its radius) as a segment against the exact box, in float64. Moving (0.5c along x,
# lorentzDecoupled: no contraction; at c0 at T = -10, about when the camera at t_c = 0 sees the floor lit),
# the cube is where it was when the light passed it: the segment from the hit event (t_h, x) back towards p
# is (t_h - s, x + s l), and relative to the cube (c0 + v (t - T)) it is the straight line
# x - c0 - v (t_h - T) + s (l + v), s in [0, |p - x|]. Pixels where a segment passes within
# 2e-3 of the box's faces (float32 could fall either side) are left out.
BLOCK = """
def Cube "Block" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{{
    double size = 0.8
    custom double4 spacetime:fourVelocity = (1, {v}, 0, 0)
    custom bool spacetime:lorentzDecoupled = true
    custom double spacetime:referenceTime = {t_ref}
    double3 xformOp:translate = (0, 1.2, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
"""
SHADOW_SIZE = (48, 36)
T_REF = -10.0


def _blocked(start, direction, length, half):
    """Does start + s direction, s in [0, length], meet the box |y| <= half (per pixel)?"""
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (-half - start) / direction, (half - start) / direction
    t_in = np.max(np.minimum(t0, t1), axis=-1)
    t_out = np.min(np.maximum(t0, t1), axis=-1)
    return (t_out >= np.maximum(t_in, 0.0)) & (t_in <= length)


def _unblocked_sum(hit, lookback, samples, v):
    """sum over (point, weight) samples of weight * [the shadow segment misses the cube], per pixel,
    and the pixels no segment grazes."""
    velocity = np.array([v, 0.0, 0.0])
    start = hit - np.array([0.0, 1.2, 0.0]) - velocity * (-lookback[..., None] - T_REF)  # t_h = 0 - lookback
    total = np.zeros(hit.shape[:-1])
    clear = np.ones(hit.shape[:-1], dtype=bool)
    for p, weight in samples:
        to_p = p - hit
        d = np.linalg.norm(to_p, axis=-1)
        direction = to_p / d[..., None] + velocity
        inner, outer = (_blocked(start, direction, d, 0.4 + m) for m in (-2e-3, 2e-3))
        clear &= inner == outer
        total += np.where(outer, 0.0, weight)
    return total, clear


@pytest.mark.parametrize("v, primitive", [(0.0, "rigid"), (0.5, "rigid"), (0.5, "prism")])
def test_rect_light_soft_shadow_matches_the_sampled_oracle(tmp_path, v, primitive):
    """The cube's shadow from a 1 × 1.2 RectLight at height 3 (static, and moving with retarded shadows,
    on both tracing paths): umbra, penumbra and lit floor each match the twin's sum over unblocked
    samples (rel 1e-5 + abs 1e-7: float32 shading)."""
    centre = np.array([1.5, 3.0, 0.2])
    u, w = np.array([0.5, 0.0, 0.0]), np.array([0.0, 0.0, -0.6])
    prim = _light_prim("RectLight", "float inputs:intensity = 10\nfloat inputs:height = 1.2", at=centre, down=True)
    img, hit, lookback = _render_and_hits(_stage(tmp_path, extra=prim + BLOCK.format(v=v, t_ref=T_REF)), size=SHADOW_SIZE,
                                          floor_only=False, primitive=primitive)
    x, gw = np.polynomial.legendre.leggauss(4)
    samples = []
    for a, wa in zip(x, gw):
        for b, wb in zip(x, gw):
            p = centre + a * u + b * w
            to_p = p - hit
            d = np.linalg.norm(to_p, axis=-1)
            # area weight (the GL weights sum to 4 per unit square, the light's area is 1.2) * cos cos' / d^2:
            # the floor and the light are parallel, so both cosines are to_p_y / d
            samples.append((p, wa * wb / 4.0 * 1.2 * (to_p[..., 1] / d) ** 2 / d**2))
    total, clear = _unblocked_sum(hit, lookback, samples, v)
    keep = clear & (img.object_id == 1)
    want = ALBEDO / math.pi * 10.0 * total[..., None]
    np.testing.assert_allclose(img.rgba[keep][:, :3], want[keep], rtol=1e-5, atol=1e-7)
    fraction = (total / sum(weight for _, weight in samples))[keep]
    assert (fraction < 1e-9).any() and ((fraction > 0.05) & (fraction < 0.95)).any() and (fraction > 0.999).any(), \
        "the case must show umbra, penumbra and lit floor"


def test_sphere_light_shadow_rays_leave_from_its_silhouette(tmp_path):
    """The cube under a SphereLight of radius 0.6 at height 3: each pixel shows ρ L R² cos θ / r² times the
    fraction of the five silhouette samples the cube leaves unblocked (docs/spec.md §3)."""
    centre, radius = np.array([1.5, 3.0, 0.2]), 0.6
    prim = _light_prim("SphereLight", f"float inputs:intensity = 10\nfloat inputs:radius = {radius}", at=centre)
    img, hit, lookback = _render_and_hits(_stage(tmp_path, extra=prim + BLOCK.format(v=0.0, t_ref=T_REF)), size=SHADOW_SIZE,
                                          floor_only=False)
    to_c = centre - hit
    d = np.linalg.norm(to_c, axis=-1, keepdims=True)
    l = to_c / d
    disk_centre = centre - l * radius**2 / d  # the silhouette circle, seen from the hit
    rs = 0.7 * radius * np.sqrt(1.0 - radius**2 / d**2)
    a = np.where(np.abs(l[..., :1]) > 0.6, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    e1 = np.cross(l, a)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(l, e1)
    fifth = np.full(hit.shape[:-1], 0.2)
    samples = [(disk_centre + rs * o, fifth) for o in (0.0 * e1, e1, -e1, e2, -e2)]
    total, clear = _unblocked_sum(hit, lookback, samples, 0.0)
    keep = clear & (img.object_id == 1)
    want = ALBEDO * 10.0 * radius**2 * (to_c[..., 1:2] / d**3) * total[..., None]
    np.testing.assert_allclose(img.rgba[keep][:, :3], want[keep], rtol=1e-5, atol=1e-7)
    assert ((total > 0.1) & (total < 0.9))[keep].any() and (total < 1e-9)[keep].any(), "umbra and penumbra"


def test_a_sphere_light_lights_nothing_inside_it(tmp_path):
    """UsdLux's sphere emits outwards: floor points inside a SphereLight of radius 3 centred 2 above the
    floor (within √5 of its foot) are black; the floor outside it is lit."""
    prim = _light_prim("SphereLight", "float inputs:intensity = 1\nfloat inputs:radius = 3", at=(0.0, 2.0, 0.0))
    img, hit = _render_and_hits(_stage(tmp_path, extra=prim))
    foot = np.linalg.norm(hit[..., [0, 2]], axis=-1)
    inside, outside = foot < math.sqrt(5.0) - 0.05, foot > math.sqrt(5.0) + 0.05
    assert inside.sum() > 4 and outside.sum() > 4, "the case must have pixels on both sides"
    assert np.all(img.rgba[inside][:, :3] == 0.0) and np.all(img.rgba[outside][:, :3] > 0.0)
