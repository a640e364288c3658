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


def textured_quad_stage(folder, beta: float, *, image: str = "grid.png", space: str = "raw",
                        wrap: str = "repeat", st_scale: float = 1.0) -> str:
    """A camera at rest at the origin (time = time code) and a 2 x 2 quad of pivot o at
    z = Z moving with beta along +x, placed so that the camera sees it near the centre at
    frame 0 (its pivot passes x = 0 at t = Z, about when the light it sends now left it).
    Its face lists the points out of index order, so the fan's triangles (2, 3, 0) and
    (2, 0, 1) are not ascending: the corner order of each tracing path matters."""
    gamma = float(1.0 / np.sqrt(1.0 - beta * beta))
    ox = -beta * Z  # x(t) = ox + beta t is 0 at t = Z
    s = st_scale
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
            float2 inputs:st.connect = </Looks/Grid/Reader.outputs:result>
            float3 outputs:rgb
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
        texCoord2f[] primvars:st = [({s}, {s}), (0, {s}), (0, 0), ({s}, 0)] (interpolation = "vertex")
        rel material:binding = </Looks/Grid>
    }}
}}
'''
    path = folder / "quad.usda"
    path.write_text(text)
    return str(path)


def oracle_st(scene, beta: float) -> tuple[np.ndarray, np.ndarray]:
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
    st = (rest[..., :2] + 1.0) / 2.0  # the authored quad spans [-1, 1]^2 with st = (p + 1) / 2
    hit = (s > 0) & (np.abs(rest[..., :2]) <= 1.0).all(axis=-1)
    return st, hit


def interior_texels(st: np.ndarray, hit: np.ndarray, margin: float = 0.25):
    """(texel column, texel row, mask) of the pixels whose st lies more than ``margin``
    texel from every texel edge (rows from the top: t runs up)."""
    fx, fy = st[..., 0] * TEX_W, (1.0 - st[..., 1]) * TEX_H
    ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
    inside = hit & (ix >= 0) & (ix < TEX_W) & (iy >= 0) & (iy < TEX_H)
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
