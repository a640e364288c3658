"""The sky: a DomeLight at rest in the lab at infinity (issue 19, deliverable 1).

Laws (the issue's sky oracle):
- an observer moving at beta = 0.9 inside a latlong dome sees, at every pixel away from
  texel edges, the dome's texel in the pixel's aberrated lab direction (closed form:
  ``warp_st.core.lorentz.aberrate``, spec §3), times intensity x color x 2^exposure, in the
  dome's own orientation (its world transform, from USD); the same through a plane mirror
  at rest (the reflected direction);
- ``spacetime.doppler`` of a sky pixel is the dome's D = (k.u_cam)/(k.u_lab) =
  gamma (1 + n.beta) (<= 1e-5 relative);
- ``--searchlight`` brightens the sky by D^4 and ``--doppler-color`` shifts it as it does
  surfaces (``doppler_transform_np``, the kernel's float64 twin).

The latlong map is written here from OpenEXR's definition (UsdLux cites it): latitude
asin(d_y), longitude atan2(d_x, d_z), pixel (0, 0) at latitude +pi/2 and longitude +pi.
Pixels within a quarter texel of a texel edge are not compared.
"""
from __future__ import annotations

import warnings

import numpy as np
import OpenImageIO as oiio
import pytest
from pxr import Usd, UsdGeom

import warp_st
from analytic_scenes import lab_pixel_directions
from warp_st.core.doppler_colour import INTERPOLATION_ERROR, doppler_transform_np

W, H = 96, 64
SKY_W, SKY_H = 16, 8
BETA = 0.9
DIRECTION = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)  # the camera flies forward and to the right
RADIANCE = 2.0 * np.array([1.0, 0.5, 0.25]) * 2.0  # intensity 2, color, exposure 1
MIRROR_Z = -4.0


def write_exr(path, pixels: np.ndarray) -> None:
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], oiio.FLOAT))
    out.write_image(np.ascontiguousarray(pixels, dtype=np.float32))
    out.close()


def sky_stage(folder, *, mirror: bool = False) -> str:
    gamma = 1.0 / np.sqrt(1.0 - BETA * BETA)
    u = [float(gamma)] + [float(gamma * BETA * c) for c in DIRECTION]
    # Something to render that the camera never sees (behind it), unless a mirror is asked for.
    body = f'''def Mesh "Mirror" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    point3f[] points = [(-3, -3, {MIRROR_Z}), (3, -3, {MIRROR_Z}), (3, 3, {MIRROR_Z}), (-3, 3, {MIRROR_Z})]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    rel material:binding = </Looks/Chrome>
}}''' if mirror else '''def Mesh "Behind"
{
    point3f[] points = [(-1, -1, 50), (1, -1, 50), (1, 1, 50)]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
}'''
    text = f'''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 0
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    float focalLength = 12
    double4 spacetime:fourVelocity = ({u[0]!r}, {u[1]!r}, {u[2]!r}, {u[3]!r})
}}
def DomeLight "Sky"
{{
    asset inputs:texture:file = @sky.exr@
    token inputs:texture:format = "latlong"
    float inputs:intensity = 2
    color3f inputs:color = (1, 0.5, 0.25)
    float inputs:exposure = 1
    float xformOp:rotateY = 30
    float xformOp:rotateX = -20
    uniform token[] xformOpOrder = ["xformOp:rotateY", "xformOp:rotateX"]
}}
def Scope "Looks"
{{
    def Material "Chrome"
    {{
        token outputs:surface.connect = </Looks/Chrome/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 1, 1)
            float inputs:metallic = 1
            token outputs:surface
        }}
    }}
}}
{body}
'''
    path = folder / "sky.usda"
    path.write_text(text)
    return str(path)


def dome_oracle(stage_path: str, directions: np.ndarray, texels: np.ndarray):
    """(expected radiance (..., 3), mask of directions away from texel edges)."""
    stage = Usd.Stage.Open(stage_path)
    m = np.array(UsdGeom.Xformable(stage.GetPrimAtPath("/Sky")).ComputeLocalToWorldTransform(0), dtype=np.float64)
    d = directions @ np.linalg.inv(m[:3, :3])  # row vectors: d_lab = d_local M
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    lat, lon = np.arcsin(np.clip(d[..., 1], -1, 1)), np.arctan2(d[..., 0], d[..., 2])
    u = (np.pi - lon) / (2 * np.pi) * SKY_W
    v = (np.pi / 2 - lat) / np.pi * SKY_H
    away = (np.abs(u - np.rint(u)) > 0.25) & (np.abs(v - np.rint(v)) > 0.25)
    x, y = np.clip(np.floor(u).astype(int), 0, SKY_W - 1), np.clip(np.floor(v).astype(int), 0, SKY_H - 1)
    return texels[y, x] * RADIANCE, away


@pytest.fixture
def sky_texels(tmp_path):
    texels = np.random.default_rng(19).uniform(0.05, 1.0, (SKY_H, SKY_W, 3)).astype(np.float32)
    write_exr(tmp_path / "sky.exr", texels)
    return texels.astype(np.float64)


@pytest.mark.parametrize("path_kind", ["rigid", "prism64"])
def test_moving_observer_sees_the_aberrated_dome_and_its_doppler_factor(tmp_path, sky_texels, path_kind):
    path = sky_stage(tmp_path)
    scene = warp_st.load(path)
    assert scene.dome is not None and not [d for d in scene.diagnostics if d.prim == "/Sky"]
    kw = {} if path_kind == "rigid" else {"primitive": "prism", "precision": "float64"}
    img = warp_st.render(scene, frame=0, width=W, height=H, **kw)
    cam = scene.camera_state("/Cam", 0)
    n = lab_pixel_directions(cam, W, H)  # lorentz.aberrate of the rest-frame pixel directions
    expected, away = dome_oracle(path, n, sky_texels)
    # a quarter texel off each edge on both axes leaves about a quarter of the pixels
    assert away.sum() > 0.2 * W * H and (img.rgba[..., 3] == 0).all()  # all sky
    # float32 texels times a float32 radiance, compared relative to the value.
    err = np.abs(img.rgba[..., :3][away] - expected[away]) / expected[away]
    assert err.max() < 1e-5
    v = BETA * DIRECTION
    gamma = 1.0 / np.sqrt(1.0 - BETA * BETA)
    dop = gamma * (1.0 + n @ v)  # D = (k.u_cam)/(k.u_lab), k = (1, -n), u_lab = (1, 0)
    rel = np.abs(img.doppler - dop) / dop
    assert rel.max() <= 1e-5, rel.max()  # the bound; float32 gives ~1e-7
    assert dop.max() > 3.0 and dop.min() < 1.0  # blue ahead, red behind: the starbow's factor


@pytest.mark.parametrize("mode", ["searchlight", "doppler_color"])
def test_the_sky_is_doppler_shifted_like_surfaces(tmp_path, sky_texels, mode):
    path = sky_stage(tmp_path)
    scene = warp_st.load(path)
    img = warp_st.render(scene, frame=0, width=W, height=H, **{mode: True})
    cam = scene.camera_state("/Cam", 0)
    n = lab_pixel_directions(cam, W, H)
    base, away = dome_oracle(path, n, sky_texels)
    gamma = 1.0 / np.sqrt(1.0 - BETA * BETA)
    dop = gamma * (1.0 + n @ (BETA * DIRECTION))
    got = img.rgba[..., :3][away]
    if mode == "searchlight":
        want = (base * (dop ** 4)[..., None])[away]  # radiance transforms as D^4
        assert (np.abs(got - want) / want).max() < 1e-4  # float32 D^4 and products
    else:
        # As surfaces are (tests/kernels/test_doppler_shading.py): the twin at the
        # rendered D (checked against the closed form above), within the table's
        # interpolation bound per unit of the colour's largest component (+ float32).
        want = doppler_transform_np(base[away], img.doppler[away], color_shift=True, searchlight=False)
        scale = np.abs(base[away]).max(axis=-1, keepdims=True)
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=0.0 + (INTERPOLATION_ERROR + 1e-5) * scale.max())


def test_a_plane_mirror_shows_the_dome_in_the_reflected_direction(tmp_path, sky_texels):
    path = sky_stage(tmp_path, mirror=True)
    scene = warp_st.load(path)
    img = warp_st.render(scene, frame=0, width=W, height=H)
    cam = scene.camera_state("/Cam", 0)
    n = lab_pixel_directions(cam, W, H)
    c = np.asarray(cam.position, dtype=np.float64)
    s = (MIRROR_Z - c[2]) / n[..., 2]
    x = c + s[..., None] * n
    on_mirror = (s > 0) & (np.abs(x[..., :2]) < 2.9).all(axis=-1)  # a tenth from its edges
    reflected = n * np.array([1.0, 1.0, -1.0])  # the mirror (at rest, normal z) flips n_z
    expected, away = dome_oracle(path, reflected, sky_texels)
    mask = on_mirror & away
    assert mask.sum() > 100
    err = np.abs(img.rgba[..., :3][mask] - expected[mask]) / expected[mask]
    assert err.max() < 1e-5  # as above; the mirror's weight is diffuse 1 x metallic 1


def lit_quads_stage(folder, texture: str | None, dome_rotate_x: float = 0.0) -> str:
    """Five diffuse quads (albedo (0.8, 0.6, 0.4)) tilted about x by -60 .. 60 degrees
    (normal (0, sin a, cos a)), in a dome of radiance 2 x (1, 0.5, 0.25) x 2, no other light."""
    quads = "\n".join(f'''def Mesh "Q{i}" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    point3f[] points = [(-0.6, -0.6, 0), (0.6, -0.6, 0), (0.6, 0.6, 0), (-0.6, 0.6, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    double3 xformOp:translate = ({(i - 2) * 1.6}, 0, 0)
    float xformOp:rotateX = {-a}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
    rel material:binding = </Looks/Clay>
}}''' for i, a in enumerate(TILTS))
    file = f"asset inputs:texture:file = @{texture}@" if texture else ""
    text = f'''#usda 1.0
(
    upAxis = "Y"
)
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 0, 20)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def DomeLight "Sky"
{{
    {file}
    float inputs:intensity = 2
    color3f inputs:color = (1, 0.5, 0.25)
    float inputs:exposure = 1
    float xformOp:rotateX = {dome_rotate_x}
    uniform token[] xformOpOrder = ["xformOp:rotateX"]
}}
def Scope "Looks"
{{
    def Material "Clay"
    {{
        token outputs:surface.connect = </Looks/Clay/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = {ALBEDO}
            token outputs:surface
        }}
    }}
}}
{quads}
'''
    path = folder / "lit.usda"
    path.write_text(text)
    return str(path)


TILTS = (-60.0, -30.0, 0.0, 30.0, 60.0)
ALBEDO = (0.8, 0.6, 0.4)


def quad_colours(path: str, **kw) -> list:
    """The colour of each quad (every pixel of a flat quad under a dome alone is the same)."""
    scene = warp_st.load(path)
    img = warp_st.render(scene, frame=0, width=160, height=48, **kw)
    out = []
    for i in range(len(TILTS)):
        body = 1 + [b.prim_path for b in scene.bodies].index(f"/Q{i}")
        pixels = img.rgba[img.object_id == body][:, :3]
        assert len(pixels) > 30
        assert np.ptp(pixels, axis=0).max() < 1e-6  # one colour per quad
        out.append(pixels[0].astype(np.float64))
    return out


@pytest.mark.parametrize("path_kind", ["rigid", "prism64"])
def test_a_constant_dome_lights_diffuse_surfaces_with_pi_times_its_radiance(tmp_path, path_kind):
    """E = pi L for any normal (the closed form), so each quad shows albedo x L."""
    kw = {} if path_kind == "rigid" else {"primitive": "prism", "precision": "float64"}
    for colour in quad_colours(lit_quads_stage(tmp_path, None), **kw):
        want = np.array(ALBEDO) * RADIANCE
        assert np.abs(colour - want).max() / want.max() < 1e-6  # float32 of exact products


@pytest.mark.parametrize("dome_rotate_x", [0.0, 90.0])
def test_a_hemisphere_dome_gives_the_closed_form_irradiance(tmp_path, dome_rotate_x):
    """A dome bright above its horizon (its upper texel rows 1, the lower 0) gives
    E(n) = pi L (1 + cos theta) / 2, theta between the normal and the dome's pole: +Y, or
    +Z when the dome is turned by rotateX 90. The order-2 harmonic projection is exact
    here (the step's non-constant part is odd, and the clamped cosine's A_l vanishes for
    odd l >= 3); what is left is the projection's quadrature over the map (4 x 4 samples
    per texel of 16 rows), below 1e-3 of the full sky's value."""
    texels = np.zeros((16, 32, 3), np.float32)
    texels[:8] = 1.0
    write_exr(tmp_path / "half.exr", texels)
    pole = np.array([0.0, 1.0, 0.0]) if dome_rotate_x == 0.0 else np.array([0.0, 0.0, 1.0])
    colours = quad_colours(lit_quads_stage(tmp_path, "half.exr", dome_rotate_x))
    for tilt, colour in zip(TILTS, colours):
        a = np.radians(tilt)
        cos_theta = np.array([0.0, np.sin(a), np.cos(a)]) @ pole  # the normal towards the camera
        scale = np.array(ALBEDO) * RADIANCE  # a full bright sky's value: the quadrature's scale
        want = scale * (1.0 + cos_theta) / 2.0
        assert (np.abs(colour - want) / scale).max() < 1e-3, (tilt, colour, want)


def test_what_the_dome_cannot_use_is_a_warning_and_the_sky_is_its_constant(tmp_path):
    """An unsupported map format, a missing map and a second DomeLight: one warning each
    (in the stage's one list of diagnostics), and the sky is the first dome's constant
    radiance, intensity x color x 2^exposure."""
    (tmp_path / "ball.exr").write_bytes(b"")
    (tmp_path / "d.usda").write_text('''#usda 1.0
def Camera "Cam"
{
}
def DomeLight "Sky"
{
    asset inputs:texture:file = @ball.exr@
    token inputs:texture:format = "mirroredBall"
    color3f inputs:color = (0.5, 0.25, 1)
    float inputs:exposure = -1
}
def DomeLight "Sky2"
{
    asset inputs:texture:file = @nothere.exr@
}
def DomeLight "Sky3"
{
}
def Mesh "Behind"
{
    point3f[] points = [(-1, -1, 50), (1, -1, 50), (1, 1, 50)]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
}
''')
    with pytest.warns(UserWarning):
        scene = warp_st.load(str(tmp_path / "d.usda"))
    got = sorted((d.prim, d.attribute, d.message) for d in scene.diagnostics if d.prim and d.prim.startswith("/Sky"))
    constant = "the sky is its constant radiance (color x intensity x 2^exposure)"
    assert got == [
        ("/Sky", "inputs:texture:format", f"'mirroredBall' maps are not supported (latlong and automatic are); "
                                          f"{constant}"),
        ("/Sky2", None, "only one DomeLight is the sky (/Sky); this one is ignored"),
        ("/Sky3", None, "only one DomeLight is the sky (/Sky); this one is ignored"),
    ]
    img = warp_st.render(scene, frame=0, width=8, height=6)
    assert np.abs(img.rgba[..., :3] - np.array([0.25, 0.125, 0.5])).max() < 1e-7  # float32 of exact values


def test_an_automatic_map_that_is_not_two_to_one_warns(tmp_path):
    write_exr(tmp_path / "square.exr", np.ones((8, 8, 3), np.float32))
    write_exr(tmp_path / "latlong.exr", np.ones((8, 16, 3), np.float32))
    for name, expected in (("square.exr", ["'automatic': the map is 8 x 8, not a 2:1 latlong map; it is read as "
                                           "latlong (other layouts are not detected)"]), ("latlong.exr", [])):
        (tmp_path / "a.usda").write_text(f'''#usda 1.0
def DomeLight "Sky"
{{
    asset inputs:texture:file = @{name}@
}}
def Mesh "M"
{{
    point3f[] points = [(-1, -1, -5), (1, -1, -5), (1, 1, -5)]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
}}
''')
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = warp_st.load(str(tmp_path / "a.usda"))
        assert [d.message for d in scene.diagnostics if d.prim == "/Sky"] == expected
        assert scene.dome.texels.shape[:2] == (8, 8 if name == "square.exr" else 16)
