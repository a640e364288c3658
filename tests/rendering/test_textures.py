"""Textures ride on their bodies (issue 16, deliverable 3's target).

Law: a textured quad (a UsdUVTexture read through a UsdPrimvarReader_float2, raw colour
space, nearest-texel lookup), at rest and moving at 0.8c, shows at every pixel whose ray
lands well inside a texel exactly that texel's colour (error <= 1/255), on the rigid
default path and the float64 prism (oracle) and tetrahedron paths.

Oracle (closed form, float64 NumPy): the quad lies in the plane z = Z at all times (it
moves along x), so the pixel's past null ray (t_c - s, c + s n) meets it at
s = (Z - c_z) / n_z; the event goes back to the body's rest frame through the
contraction (``warp_st.core.lorentz.contraction_matrix``), r = A^-1 (x - o - v (t - t_ref)),
where the authored (rest) quad gives st affinely, and st gives the texel. Pixels whose
st is within a quarter texel of a texel edge are not compared (there a float32 rounding
of the hit may pick the neighbour).
"""
from __future__ import annotations

import warnings

import numpy as np
import OpenImageIO as oiio
import pytest

import warp_st
from analytic_scenes import lab_pixel_directions
from warp_st.core.lorentz import contraction_matrix

W, H = 96, 72
TEX_W, TEX_H = 8, 6
Z = -6.0  # the quad's plane
BETA = 0.8


def write_png(path, texels: np.ndarray) -> None:
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(texels.shape[1], texels.shape[0], texels.shape[2], oiio.UINT8))
    out.write_image(np.ascontiguousarray(texels))
    out.close()


#: st primvars giving each point p of the quad st = (p + 1) / 2 (before ``st_range``),
#: authored in each interpolation USD offers for them (the points are listed as
#: (1, 1), (-1, 1), (-1, -1), (1, -1); the face is [2, 3, 0, 1]).
ST_PRIMVARS = {
    "vertex": "texCoord2f[] primvars:st = [{a}] (interpolation = \"vertex\")",
    "vertex_indexed": "texCoord2f[] primvars:st = [{b}] (interpolation = \"vertex\")\n"
                      "        int[] primvars:st:indices = [3, 2, 0, 1]",
    "faceVarying": "texCoord2f[] primvars:st = [{c}] (interpolation = \"faceVarying\")",
    "faceVarying_indexed": "texCoord2f[] primvars:st = [{b}] (interpolation = \"faceVarying\")\n"
                           "        int[] primvars:st:indices = [0, 1, 3, 2]",
}


def _st_values(lo: float, hi: float) -> dict:
    def f(*corners):
        return ", ".join(f"({lo + (hi - lo) * u!r}, {lo + (hi - lo) * v!r})" for u, v in corners)
    # a: per point; b: the distinct values in another order (then indices); c: per face corner
    return {"a": f((1, 1), (0, 1), (0, 0), (1, 0)), "b": f((0, 0), (1, 0), (0, 1), (1, 1)),
            "c": f((0, 0), (1, 0), (1, 1), (0, 1))}


def textured_quad_stage(folder, beta: float, *, image: str = "grid.png", space: str = "raw",
                        wrap: str = "repeat", st_range: tuple[float, float] = (0.0, 1.0),
                        interpolation: str = "vertex", extra: str = "", transform: str = "") -> str:
    """A camera at rest at the origin (time = time code) and a 2 x 2 quad of pivot o at
    z = Z moving with beta along +x, placed so that the camera sees it near the centre at
    frame 0 (its pivot passes x = 0 at t = Z, about when the light it sends now left it).
    Its face lists the points out of index order, so the fan's triangles (2, 3, 0) and
    (2, 0, 1) are not ascending: the corner order of each tracing path matters."""
    gamma = float(1.0 / np.sqrt(1.0 - beta * beta))
    ox = -beta * Z  # x(t) = ox + beta t is 0 at t = Z
    st = ST_PRIMVARS[interpolation].format(**_st_values(*st_range))
    text = f'''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 0
)
def Camera "Cam"
{{
    float focalLength = 40
}}
def Scope "Looks"
{{
    def Material "Grid"
    {{
        token outputs:surface.connect = </Looks/Grid/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor.connect = </Looks/Grid/Tex.outputs:rgb>
            token outputs:surface
        }}
        def Shader "Tex"
        {{
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @{image}@
            token inputs:sourceColorSpace = "{space}"
            token inputs:wrapS = "{wrap}"
            token inputs:wrapT = "{wrap}"
            float2 inputs:st.connect = </Looks/Grid/{"Move" if transform else "Reader"}.outputs:result>
            {extra}
            float3 outputs:rgb
        }}
        def Shader "Move"
        {{
            uniform token info:id = "UsdTransform2d"
            float2 inputs:in.connect = </Looks/Grid/Reader.outputs:result>
            {transform}
            float2 outputs:result
        }}
        def Shader "Reader"
        {{
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }}
    }}
}}
def Xform "Body" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate = ({ox!r}, 0, {Z!r})
    uniform token[] xformOpOrder = ["xformOp:translate"]
    double4 spacetime:fourVelocity = ({gamma!r}, {gamma * beta!r}, 0, 0)
    double spacetime:referenceTime = 0
    def Mesh "Quad" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        point3f[] points = [(1, 1, 0), (-1, 1, 0), (-1, -1, 0), (1, -1, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [2, 3, 0, 1]
        {st}
        rel material:binding = </Looks/Grid>
    }}
}}
'''
    path = folder / "quad.usda"
    path.write_text(text)
    return str(path)


def oracle_st(scene, beta: float, st_range=(0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """(st (H, W, 2), hit mask) of every pixel centre, in float64 closed form."""
    cam = scene.camera_state("/Cam", 0)
    n = lab_pixel_directions(cam, W, H)
    c = np.asarray(cam.position, dtype=np.float64)
    s = (Z - c[2]) / n[..., 2]
    x = c + s[..., None] * n
    t = cam.time - s
    v = np.array([beta, 0.0, 0.0])
    o = np.array([-beta * Z, 0.0, Z])
    rest = (x - o - t[..., None] * v) @ np.linalg.inv(contraction_matrix(v, False)).T
    lo, hi = st_range  # the authored quad spans [-1, 1]^2 with st = lo + (hi - lo) (p + 1) / 2
    st = lo + (hi - lo) * (rest[..., :2] + 1.0) / 2.0
    hit = (s > 0) & (np.abs(rest[..., :2]) <= 1.0).all(axis=-1)
    return st, hit


def interior_texels(st: np.ndarray, hit: np.ndarray, margin: float = 0.25, *, within: bool = True):
    """(texel column, texel row, mask) of the pixels whose st lies more than ``margin``
    texel from every texel edge (rows from the top: t runs up); ``within``: and inside
    the texture's [0, 1)^2."""
    fx, fy = st[..., 0] * TEX_W, (1.0 - st[..., 1]) * TEX_H
    ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
    inside = hit & ((ix >= 0) & (ix < TEX_W) & (iy >= 0) & (iy < TEX_H)) if within else hit
    away = (np.abs(fx - np.rint(fx)) > margin) & (np.abs(fy - np.rint(fy)) > margin)
    return ix, iy, inside & away


@pytest.mark.parametrize("beta", [0.0, BETA])
@pytest.mark.parametrize("path", ["rigid", "prism64", "tet64"])
def test_texels_ride_on_the_quad(tmp_path, beta, path):
    rng = np.random.default_rng(16)
    texels = rng.integers(0, 256, (TEX_H, TEX_W, 3), dtype=np.uint8)
    write_png(tmp_path / "grid.png", texels)
    scene = warp_st.load(textured_quad_stage(tmp_path, beta))
    kw = {} if path == "rigid" else {"primitive": path[:-2], "precision": "float64"}
    img = warp_st.render(scene, frame=0, width=W, height=H, **kw)

    st, hit = oracle_st(scene, beta)
    ix, iy, mask = interior_texels(st, hit)
    # Every texel is seen by several interior pixels, so the test covers the whole texture.
    seen = np.zeros((TEX_H, TEX_W), int)
    np.add.at(seen, (iy[mask], ix[mask]), 1)
    assert seen.min() >= 4, seen
    expected = texels[iy[mask], ix[mask]].astype(np.float64) / 255.0
    got = img.rgba[..., :3][mask].astype(np.float64)
    # No lights: the surface shows its albedo, the texel itself; raw 8-bit values are
    # exact in float32, so 1/255 is all rounding and interpolation may take (none here).
    err = np.abs(got - expected).max()
    assert err <= 1.0 / 255.0, f"max colour error {err * 255:.2f}/255 over {mask.sum()} pixels"


def random_texture(tmp_path, name="grid.png", seed=16) -> np.ndarray:
    texels = np.random.default_rng(seed).integers(0, 256, (TEX_H, TEX_W, 3), dtype=np.uint8)
    write_png(tmp_path / name, texels)
    return texels


@pytest.mark.parametrize("interpolation", sorted(ST_PRIMVARS))
def test_st_interpolations_and_indices_give_the_same_picture(tmp_path, interpolation):
    """The same st authored per point, per face corner, with and without indices
    (USD flattens them: ``Primvar.ComputeFlattened``) maps the texture the same way."""
    texels = random_texture(tmp_path)
    scene = warp_st.load(textured_quad_stage(tmp_path, BETA, interpolation=interpolation))
    img = warp_st.render(scene, frame=0, width=W, height=H)
    ix, iy, mask = interior_texels(*oracle_st(scene, BETA))
    assert mask.sum() > 500
    err = np.abs(img.rgba[..., :3][mask] - texels[iy[mask], ix[mask]] / 255.0).max()
    assert err <= 1.0 / 255.0  # as in test_texels_ride_on_the_quad


def wrapped(i: np.ndarray, n: int, mode: str) -> np.ndarray:
    """UsdUVTexture's wrap of texel index i on an axis of n texels (-1: black), written
    from the modes' definitions: repeat tiles, clamp holds the edge texel, mirror
    reflects at every edge (period 2n), black is outside the image."""
    if mode == "repeat":
        return np.mod(i, n)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    return np.where((i >= 0) & (i < n), i, -1)


SCALE = (0.5, 2.0, 1.0, 1.0)
BIAS = (0.25, -0.125, 0.0, 0.0)


@pytest.mark.parametrize("wrap", ["repeat", "clamp", "mirror", "black"])
def test_wrap_modes_scale_and_bias(tmp_path, wrap):
    """st over [-1.5, 2.25]: outside the image each wrap mode picks its texel (black: the
    bias, black scaled and biased); every texel is scale x value + bias."""
    texels = random_texture(tmp_path)
    lo, hi = -1.5, 2.25
    extra = f"float4 inputs:scale = {SCALE}\n            float4 inputs:bias = {BIAS}"
    scene = warp_st.load(textured_quad_stage(tmp_path, 0.0, wrap=wrap, st_range=(lo, hi), extra=extra))
    img = warp_st.render(scene, frame=0, width=W, height=H)
    ix, iy, mask = interior_texels(*oracle_st(scene, 0.0, (lo, hi)), within=False)
    wx, wy = wrapped(ix, TEX_W, wrap), wrapped(iy, TEX_H, wrap)
    value = texels[np.clip(wy, 0, None), np.clip(wx, 0, None)] / 255.0 * np.array(SCALE[:3]) + np.array(BIAS[:3])
    value = np.where(((wx < 0) | (wy < 0))[..., None], np.array(BIAS[:3]), value)
    outside = mask & ((ix < 0) | (ix >= TEX_W) | (iy < 0) | (iy >= TEX_H))
    assert outside.sum() > 500  # the test looks outside the image, in every direction
    err = np.abs(img.rgba[..., :3][mask] - value[mask]).max()
    assert err <= 2.0 / 255.0  # scale 2 doubles the 1/255 budget of the value


def srgb_decode(v):
    """IEC 61966-2-1's sRGB EOTF, written here from the standard."""
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


@pytest.mark.parametrize("space", ["sRGB", "auto"])
def test_srgb_textures_are_decoded_to_linear(tmp_path, space):
    """sRGB (and auto on an 8-bit PNG) removes the sRGB curve: each texel shows its
    linear value (to float32 rounding of the decode)."""
    texels = random_texture(tmp_path)
    scene = warp_st.load(textured_quad_stage(tmp_path, 0.0, space=space))
    img = warp_st.render(scene, frame=0, width=W, height=H)
    ix, iy, mask = interior_texels(*oracle_st(scene, 0.0))
    err = np.abs(img.rgba[..., :3][mask] - srgb_decode(texels[iy[mask], ix[mask]] / 255.0)).max()
    assert err <= 1e-5  # float32 decode and storage of values <= 1


def test_a_missing_texture_warns_and_uses_its_fallback(tmp_path):
    extra = "float4 inputs:fallback = (0.2, 0.4, 0.6, 1)"
    with pytest.warns(UserWarning, match="nowhere.png cannot be found"):
        scene = warp_st.load(textured_quad_stage(tmp_path, 0.0, image="nowhere.png", extra=extra))
    warnings = [d for d in scene.diagnostics if d.prim == "/Looks/Grid/Tex"]
    assert [(d.attribute, d.message) for d in warnings] == [
        ("inputs:file", "nowhere.png cannot be found; the texture's fallback (0.2, 0.4, 0.6, 1.0) is used")]
    img = warp_st.render(scene, frame=0, width=W, height=H)
    _ix, _iy, mask = interior_texels(*oracle_st(scene, 0.0))
    assert np.abs(img.rgba[..., :3][mask] - np.array([0.2, 0.4, 0.6])).max() <= 1e-6  # float32 of the fallback


def test_an_unreadable_texture_warns_and_uses_its_fallback(tmp_path):
    (tmp_path / "broken.png").write_bytes(b"not a png")
    with pytest.warns(UserWarning, match="broken.png cannot be read"):
        scene = warp_st.load(textured_quad_stage(tmp_path, 0.0, image="broken.png"))
    (d,) = [d for d in scene.diagnostics if d.prim == "/Looks/Grid/Tex"]
    assert d.attribute == "inputs:file" and d.message.startswith("broken.png cannot be read (")
    assert d.message.endswith("the texture's fallback (0.0, 0.0, 0.0, 1.0) is used")
    img = warp_st.render(scene, frame=0, width=W, height=H)
    _ix, _iy, mask = interior_texels(*oracle_st(scene, 0.0))
    assert mask.sum() > 500 and np.abs(img.rgba[..., :3][mask]).max() == 0.0


def test_the_memory_budget_counts_the_textures(tmp_path):
    """A render's memory estimate holds each texel array twice (the host's float32 copy and
    the kernel's atlas): a limit between the untextured and the textured estimate refuses
    the textured render, naming the textures' share (bad input, before any allocation)."""
    import dataclasses

    from warp_st.core.scene import SceneError
    from warp_st.rendering.budget import check_resources
    from warp_st.rendering.renderer import Renderer
    from warp_st.spacetime.visibility import visibility_windows

    big = np.random.default_rng(5).integers(0, 256, (256, 256, 3), dtype=np.uint8)
    write_png(tmp_path / "grid.png", big)
    scene = warp_st.load(textured_quad_stage(tmp_path, 0.0))
    plain = dataclasses.replace(scene, bodies=tuple(
        dataclasses.replace(b, surfaces=tuple(dataclasses.replace(s, material=dataclasses.replace(
            s.material, diffuse_texture=None)) for s in b.surfaces)) for b in scene.bodies))
    windows = visibility_windows(scene, [scene.camera_state("/Cam", 0)], infinite=False, max_depth=4)
    sizes = [check_resources(s, windows, width=W, height=H, max_depth=4, rigid=True) for s in (plain, scene)]
    assert sizes[1] - sizes[0] == 2 * 256 * 256 * 4 * 4  # RGBA float32, twice
    with pytest.raises(SceneError, match="of textures"):
        Renderer(scene, frames=[0.0], width=W, height=H, max_memory=sum(sizes) // 2)


def test_usd_transform2d_moves_the_texture(tmp_path):
    """A UsdTransform2d between the primvar reader and the texture: st' = translation +
    R(rotation, counter-clockwise) (scale * st), as the UsdPreviewSurface spec orders them."""
    texels = random_texture(tmp_path)
    move = ("float2 inputs:scale = (2, 0.5)\n            float inputs:rotation = 30\n"
            "            float2 inputs:translation = (0.25, 0.1)")
    scene = warp_st.load(textured_quad_stage(tmp_path, 0.0, transform=move))
    assert not [d for d in scene.diagnostics if d.prim and d.prim.startswith("/Looks")]
    img = warp_st.render(scene, frame=0, width=W, height=H)
    st, hit = oracle_st(scene, 0.0)
    c, s = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
    moved = (st * [2.0, 0.5]) @ np.array([[c, -s], [s, c]]).T + [0.25, 0.1]
    ix, iy, mask = interior_texels(moved, hit, within=False)
    assert mask.sum() > 500
    err = np.abs(img.rgba[..., :3][mask] - texels[np.mod(iy, TEX_H)[mask], np.mod(ix, TEX_W)[mask]] / 255.0).max()
    assert err <= 1.0 / 255.0  # as in test_texels_ride_on_the_quad (repeat wrap)


def test_a_texture_inside_a_usdz_package(tmp_path):
    """The same textured quad packaged as a USDZ (USD's own ``UsdUtils.CreateNewUsdzPackage``):
    its texture is a package-relative asset (``quad.usdz[0/grid.png]``), read through USD's
    resolver, and every interior pixel shows its texel as from the loose files (1/255, as
    in test_texels_ride_on_the_quad). 0.7.0 handed the package path to OIIO, which cannot
    open it: the texture's black fallback with a warning."""
    from pxr import Sdf, UsdUtils

    texels = random_texture(tmp_path)
    layer = textured_quad_stage(tmp_path, 0.0)
    package = tmp_path / "quad.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(layer), str(package))
    (tmp_path / "grid.png").unlink()  # only the package holds the texture now
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "cannot be read" warning
        scene = warp_st.load(str(package))
    img = warp_st.render(scene, frame=0, width=W, height=H)
    ix, iy, mask = interior_texels(*oracle_st(scene, 0.0))
    assert mask.sum() > 500
    err = np.abs(img.rgba[..., :3][mask] - texels[iy[mask], ix[mask]] / 255.0).max()
    assert err <= 1.0 / 255.0
