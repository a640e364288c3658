"""Materials as USD binds them (issue 16, deliverable 3).

Laws:
- every binding form resolves as USD's binding rules say: direct, inherited from an
  ancestor, collection-based (stronger than a weaker direct binding below it when
  authored with strongerThanDescendants), the ``full`` purpose before all-purpose and
  ``preview`` only when nothing else binds; the expectations are written here from
  those rules, one distinct colour per material;
- GeomSubset (``materialBind``) faces render their own material, the other faces the mesh's;
- emissiveColor and metallic read textures like diffuseColor (a single channel output
  on metallic); EXR textures are read linear (``auto``), 8-bit JPEG as sRGB.
"""
from __future__ import annotations

import warnings

import numpy as np
import OpenImageIO as oiio
import pytest

import warp_st
from analytic_scenes import lab_pixel_directions
from corpus import _material, unknown_types_and_subsets
from warp_st.usd.images import read_image

COLOURS = {"Red": (1, 0, 0), "Green": (0, 1, 0), "Blue": (0, 0, 1), "Yellow": (1, 1, 0), "Cyan": (0, 1, 1),
           "White": (1, 1, 1)}

HEADER = '#usda 1.0\n(\n    upAxis = "Y"\n)\n'


def looks(extra: dict | None = None) -> str:
    """A Material per colour of COLOURS (a UsdPreviewSurface with that diffuseColor)."""
    return 'def Scope "Looks"\n{' + "".join(
        _material(name, (extra or {}).get(name, f"color3f inputs:diffuseColor = {rgb}"))
        for name, rgb in COLOURS.items()) + "\n}\n"


QUAD = '''point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]'''

BINDINGS = HEADER + looks() + f'''
def Xform "World" (prepend apiSchemas = ["MaterialBindingAPI", "CollectionAPI:picked"])
{{
    rel collection:picked:includes = [</World/Group/Picked>, </World/Group/PickedStrong>]
    rel material:binding:collection:picked = [</World.collection:picked>, </Looks/Blue>]
    rel material:binding:collection:strong = [</World.collection:picked>, </Looks/Cyan>] (
        bindMaterialAs = "strongerThanDescendants"
    )
    def Mesh "Direct" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        {QUAD}
        rel material:binding = </Looks/Red>
    }}
    def Xform "Group" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        rel material:binding = </Looks/Green>
        def Mesh "Inherits"
        {{
            {QUAD}
        }}
        def Mesh "Picked" (prepend apiSchemas = ["MaterialBindingAPI"])
        {{
            {QUAD}
        }}
        def Mesh "PickedStrong" (prepend apiSchemas = ["MaterialBindingAPI"])
        {{
            {QUAD}
            rel material:binding = </Looks/Red>
        }}
    }}
    def Mesh "FullAndPreview" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        {QUAD}
        rel material:binding = </Looks/White>
        rel material:binding:full = </Looks/Yellow>
        rel material:binding:preview = </Looks/Cyan>
    }}
    def Mesh "AllAndPreview" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        {QUAD}
        rel material:binding = </Looks/White>
        rel material:binding:preview = </Looks/Cyan>
    }}
    def Mesh "PreviewOnly" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        {QUAD}
        rel material:binding:preview = </Looks/Cyan>
    }}
}}
'''

#: What USD's rules bind for a final-frame ("full") render, by prim.
EXPECTED = {
    "/World/Direct": "Red",  # direct binding
    "/World/Group/Inherits": "Green",  # the nearest ancestor's binding
    # The collection binding on /World is weaker than Group's direct one (bindings on
    # nearer prims win) unless authored strongerThanDescendants: then the strongest
    # such binding on the farthest ancestor wins, over the prim's own direct binding too.
    "/World/Group/Picked": "Cyan",
    "/World/Group/PickedStrong": "Cyan",
    "/World/FullAndPreview": "Yellow",  # the full purpose before all-purpose
    "/World/AllAndPreview": "White",  # all-purpose before preview for a full render
    "/World/PreviewOnly": "Cyan",  # preview only when nothing else binds (our choice)
}


def surfaces(scene) -> dict:
    return {s.prim_path: s for b in scene.bodies for s in b.surfaces}


def test_binding_forms(tmp_path):
    path = tmp_path / "bindings.usda"
    path.write_text(BINDINGS)
    scene = warp_st.load(str(path))
    got = {p: s.material.diffuse for p, s in surfaces(scene).items()}
    assert got == {p: tuple(float(c) for c in COLOURS[name]) for p, name in EXPECTED.items()}
    assert not [d for d in scene.diagnostics if d.severity == "warning" and "binding" in (d.attribute or "")]


def render_and_locate(path, w: int, h: int):
    """(scene, image, where each pixel-centre ray meets the plane z = 0 (H, W, 3))."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # what the stage does not honour: asserted by each test
        scene = warp_st.load(str(path))
    img = warp_st.render(scene, frame=0, width=w, height=h)
    cam = scene.camera_state(scene.default_camera, 0)
    n = lab_pixel_directions(cam, w, h)
    return scene, img, np.asarray(cam.position) + (-cam.position[2] / n[..., 2])[..., None] * n


def test_geom_subset_faces_render_their_own_material(tmp_path):
    """The corpus's stage (tests/usd/corpus.py), through its default camera."""
    scene, img, x = render_and_locate(unknown_types_and_subsets().write(tmp_path), 64, 48)
    assert [d.prim for d in scene.diagnostics if d.severity == "warning"] == ["/Glow"]  # its unknown type
    inside_y = np.abs(x[..., 1]) < 0.9
    left = inside_y & (x[..., 0] > -0.9) & (x[..., 0] < 0.9)  # face 0, a tenth of a unit from its edges
    right = inside_y & (x[..., 0] > 1.1) & (x[..., 0] < 2.9)  # face 1
    assert left.sum() > 50 and right.sum() > 50
    # Unlit (no lights): each face shows its diffuse colour exactly (float32 of 0 and 1).
    assert (img.rgba[left][:, :3] == [1, 0, 0]).all()
    assert (img.rgba[right][:, :3] == [0, 0, 1]).all()


def write_image(path, pixels: np.ndarray, fmt) -> None:
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt))
    out.write_image(np.ascontiguousarray(pixels))
    out.close()


def texture_network(name: str, file: str, output: str, connect: str, kind: str) -> str:
    return f'''{kind} inputs:{connect}.connect = </Looks/{name}/Tex.outputs:{output}>
            token outputs:surface
        }}
        def Shader "Tex"
        {{
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @{file}@
            token inputs:sourceColorSpace = "raw"
            float2 inputs:st.connect = </Looks/{name}/Reader.outputs:result>
            float3 outputs:rgb
            float outputs:{output if output != "rgb" else "r"}
        }}
        def Shader "Reader"
        {{
            uniform token info:id = "UsdPrimvarReader_float2"
            token inputs:varname = "uv"
            float2 outputs:result'''


def test_emissive_and_metallic_textures(tmp_path):
    """A 2 x 1 texture: left texel (0.2, 0.4, 0.6) red 0, right (1.0, 0.8, 0.0) red 1.
    Emissive: the texels themselves (diffuse black). Metallic from the red channel: the
    left half diffuse, the right half a perfect mirror of diffuse x the background."""
    texels = np.array([[[51, 102, 153], [255, 204, 0]]], dtype=np.uint8)
    write_image(tmp_path / "two.png", texels, oiio.UINT8)
    red = np.array([[[0], [255]]], dtype=np.uint8)
    write_image(tmp_path / "red.png", red, oiio.UINT8)
    extra = {
        "Red": "color3f inputs:diffuseColor = (0, 0, 0)\n            " + texture_network(
            "Red", "two.png", "rgb", "emissiveColor", "color3f"),
        "Green": "color3f inputs:diffuseColor = (0.5, 0.5, 0.5)\n            " + texture_network(
            "Green", "red.png", "r", "metallic", "float"),
    }
    mesh = '''
def Mesh "{name}" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    point3f[] points = [({x0}, -1, 0), ({x1}, -1, 0), ({x1}, 1, 0), ({x0}, 1, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    texCoord2f[] primvars:uv = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "faceVarying")
    rel material:binding = </Looks/{look}>
}}'''
    text = HEADER + looks(extra) + '''
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 8)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def RenderSettings "Settings"
{
    color3f spacetime:background = (0.25, 0.5, 1)
}
''' + mesh.format(name="Glow", x0=-2.5, x1=-0.5, look="Red") + mesh.format(name="Metal", x0=0.5, x1=2.5,
                                                                           look="Green")
    path = tmp_path / "channels.usda"
    path.write_text(text)
    scene, img, x = render_and_locate(path, 80, 40)
    assert not [d for d in scene.diagnostics if d.severity == "warning"]
    rows = np.abs(x[..., 1]) < 0.9

    def region(lo, hi):
        m = rows & (x[..., 0] > lo) & (x[..., 0] < hi)
        assert m.sum() > 20
        return img.rgba[m][:, :3]

    # Tolerance: float32 of 8-bit values (raw) and of their products, ~1e-7.
    tol = 1e-6
    assert np.abs(region(-2.4, -1.6) - np.array([51, 102, 153]) / 255).max() < tol
    assert np.abs(region(-1.4, -0.6) - np.array([255, 204, 0]) / 255).max() < tol
    assert np.abs(region(0.6, 1.4) - 0.5).max() < tol  # metallic 0: the diffuse colour
    assert np.abs(region(1.6, 2.4) - 0.5 * np.array([0.25, 0.5, 1.0])).max() < tol  # a mirror of the sky


def test_exr_textures_are_linear_and_jpeg_srgb(tmp_path):
    """``auto``: an EXR (float, declared linear) is read as stored; an 8-bit JPEG as sRGB."""
    hdr = np.random.default_rng(3).uniform(0.0, 8.0, (5, 7, 3)).astype(np.float32)
    write_image(tmp_path / "sky.exr", hdr, oiio.FLOAT)
    image = read_image(str(tmp_path / "sky.exr"), "auto")
    assert image.color_space == "raw" and np.array_equal(image.texels, hdr)
    flat = np.full((16, 16, 3), (200, 100, 50), dtype=np.uint8)  # flat: JPEG keeps it to +-1 level
    write_image(tmp_path / "flat.jpg", flat, oiio.UINT8)
    auto, raw = read_image(str(tmp_path / "flat.jpg"), "auto"), read_image(str(tmp_path / "flat.jpg"), "raw")
    assert auto.color_space == "sRGB" and raw.color_space == "raw"
    assert np.abs(raw.texels * 255 - flat).max() <= 1.5  # JPEG's rounding of a flat block
    v = raw.texels.astype(np.float64)
    srgb = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)  # IEC 61966-2-1
    assert np.abs(auto.texels - srgb).max() < 1e-6


@pytest.mark.parametrize("missing", ["", "nothere.exr"])
def test_read_image_names_what_is_wrong(tmp_path, missing):
    from warp_st.usd.images import ImageError

    with pytest.raises(ImageError):
        read_image(str(tmp_path / missing) if missing else str(tmp_path), "auto")
