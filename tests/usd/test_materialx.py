"""Inline MaterialX networks (issue 16, item 3): ``outputs:mtlx:surface`` read onto the material model.

Laws (docs/spec.md §2, "MaterialX networks"):
- Standard Surface: diffuse = base x base_color, emissive = emission x emission_color,
  metallic = metalness, with MaterialX 1.39's defaults (``..._100``: 1.38's); OpenPBR:
  base_weight x base_color, emission_luminance (nits, 1 nit = 1.0) x emission_color,
  base_metalness. Unlit (no lights), a quad shows its diffuse + emissive colour, and a
  metallic quad metallic x diffuse x the background (spec §3.1); the expected colours are
  the authored numbers multiplied here (closed form).
- base_color from an ND_image_color3 inside a NodeGraph (its file on the NodeGraph's
  interface) is the texture: texel x base, raw or sRGB by the file's colorSpace, st from
  ND_texcoord_vector2 (the primvar st) or ND_geompropvalue_vector2 (its geomprop), the
  image's default outside [0, 1) under the ``constant`` address mode.
- MaterialX's ND_UsdPreviewSurface_surfaceshader is read as a UsdPreviewSurface;
- a UsdPreviewSurface on the universal output wins over the mtlx network;
- an unhonoured input authored off its default is one warning, at its default none;
- an unsupported node or surface: one warning line naming prim and attribute, displayColor.
"""
from __future__ import annotations

import numpy as np
import OpenImageIO as oiio

from corpus import _material
from test_materials import render_and_locate, write_image

HEADER = '#usda 1.0\n(\n    upAxis = "Y"\n)\n'
BACKGROUND = (0.25, 0.5, 1.0)
CAMERA = '''def Camera "Cam"
{{
    float focalLength = 10
    double3 xformOp:translate = (0, 0, {z})
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def RenderSettings "Settings"
{{
    color3f spacetime:background = %s
}}
''' % (BACKGROUND,)
LAMBERT = "not honoured (the surface is Lambert diffuse plus a metallic mirror); ignored"
# Tolerance: the colours are float32 products of a few float32 numbers (relative error
# ~1e-7 each); 1e-6 absolute on values <= 1 cannot hide a wrong factor.
TOL = 1e-6


def mx(name: str, shader_id: str, inputs: str, extra: str = "", universal: str = "") -> str:
    """A Material whose mtlx surface is a shader ``S`` of ``shader_id`` (and children ``extra``)."""
    return f'''
    def Material "{name}"
    {{
        token outputs:mtlx:surface.connect = </Looks/{name}/S.outputs:out>
        {universal}
        def Shader "S"
        {{
            uniform token info:id = "{shader_id}"
            {inputs}
            token outputs:out
        }}
        {extra}
    }}'''


def quads(looks: dict, st: str = "(0, 0), (1, 0), (1, 1), (0, 1)", uv: str | None = None) -> tuple[str, dict]:
    """A Scope of the materials and a 2 x 2 quad per material in a row along x (centres
    2.5 apart), each with the faceVarying primvars st and uv (``uv`` None: the same as
    ``st``); the x range of each."""
    text = 'def Scope "Looks"\n{' + "".join(looks.values()) + "\n}\n"
    spans = {}
    for i, name in enumerate(looks):
        x0 = 2.5 * (i - (len(looks) - 1) / 2) - 1
        spans[name] = (x0, x0 + 2)
        text += f'''
def Mesh "{name}Quad" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    point3f[] points = [({x0}, -1, 0), ({x0 + 2}, -1, 0), ({x0 + 2}, 1, 0), ({x0}, 1, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    texCoord2f[] primvars:st = [{st}] (interpolation = "faceVarying")
    texCoord2f[] primvars:uv = [{uv or st}] (interpolation = "faceVarying")
    color3f[] primvars:displayColor = [(0.5, 0.75, 0.25)]
    rel material:binding = </Looks/{name}>
}}'''
    return text, spans


def render(tmp_path, looks: dict, **kwargs):
    """(scene, a function (x0, x1) -> the RGB of the pixels whose ray meets the plane z = 0
    at x0 < x < x1, |y| < 0.9, the x span of each quad)."""
    text, spans = quads(looks, **kwargs)
    path = tmp_path / "mx.usda"
    path.write_text(HEADER + CAMERA.format(z=1.3 * len(looks) + 1) + text)  # the row in view
    scene, img, x = render_and_locate(path, 30 * len(looks), 24)

    def region(lo, hi):
        m = (np.abs(x[..., 1]) < 0.9) & (x[..., 0] > lo) & (x[..., 0] < hi)
        assert m.sum() >= 10
        return img.rgba[m][:, :3].astype(np.float64)

    return scene, region, spans


def warnings_of(scene) -> list[tuple]:
    return sorted((d.prim, d.attribute, d.message) for d in scene.diagnostics if d.severity == "warning")


def inner(span, margin=0.2):
    return span[0] + margin, span[1] - margin


def test_constant_standard_surface_and_open_pbr(tmp_path):
    std, pbr = "ND_standard_surface_surfaceshader", "ND_open_pbr_surface_surfaceshader"
    looks = {
        "Std": mx("Std", std, "float inputs:base = 0.5\n            color3f inputs:base_color = (0.2, 0.4, 0.8)\n"
                              "            float inputs:specular = 1\n            float inputs:specular_roughness = 0.05"),
        "StdDefaults": mx("StdDefaults", std, "color3f inputs:base_color = (1, 0.5, 0.25)"),  # base 1 (1.39)
        "Std100": mx("Std100", std + "_100", "color3f inputs:base_color = (1, 0.5, 0.25)"),  # base 0.8 (1.38)
        "StdGlow": mx("StdGlow", std, "float inputs:base = 0\n            float inputs:emission = 2\n"
                                      "            color3f inputs:emission_color = (0.25, 0.5, 0.125)"),
        "StdMetal": mx("StdMetal", std, "float inputs:metalness = 1\n            color3f inputs:base_color = (1, 0.5, 0.5)"),
        "Pbr": mx("Pbr", pbr, "float inputs:base_weight = 0.5\n            color3f inputs:base_color = (0.5, 0.25, 1)"),
        "PbrGlow": mx("PbrGlow", pbr, "float inputs:base_weight = 0\n            float inputs:emission_luminance = 3\n"
                                      "            color3f inputs:emission_color = (0.1, 0.2, 0.3)"),
        "PbrMetal": mx("PbrMetal", pbr, "float inputs:base_metalness = 1"),  # base_color 0.8 by default
        # MaterialX's UsdPreviewSurface node, read as a UsdPreviewSurface
        "MxPreview": mx("MxPreview", "ND_UsdPreviewSurface_surfaceshader", "color3f inputs:diffuseColor = (0.1, 0.2, 0.4)"),
        # both contexts: the universal UsdPreviewSurface is read (red), not the network (green)
        "Both": mx("Both", std, "color3f inputs:base_color = (0, 1, 0)", universal=(
            'token outputs:surface.connect = </Looks/Both/P.outputs:surface>\n        def Shader "P"\n        {\n'
            '            uniform token info:id = "UsdPreviewSurface"\n'
            '            color3f inputs:diffuseColor = (1, 0, 0)\n            token outputs:surface\n        }')),
    }
    scene, region, spans = render(tmp_path, looks)
    # specular at its default (1) is not a warning; specular_roughness off its default is
    assert warnings_of(scene) == [("/Looks/Std/S", "inputs:specular_roughness", LAMBERT)]
    f32 = np.float32
    expected = {
        "Std": f32(0.5) * np.array([0.2, 0.4, 0.8], f32),
        "StdDefaults": np.array([1, 0.5, 0.25]),
        "Std100": f32(0.8) * np.array([1, 0.5, 0.25], f32),
        "StdGlow": f32(2) * np.array([0.25, 0.5, 0.125], f32),
        "StdMetal": np.array([1, 0.5, 0.5]) * BACKGROUND,  # a perfect mirror tinted by the base
        "Pbr": f32(0.5) * np.array([0.5, 0.25, 1], f32),
        "PbrGlow": f32(3) * np.array([0.1, 0.2, 0.3], f32),
        "PbrMetal": f32(0.8) * np.array(BACKGROUND, f32),
        "MxPreview": np.array([0.1, 0.2, 0.4], f32),
        "Both": np.array([1, 0, 0]),
    }
    for name, rgb in expected.items():
        assert np.abs(region(*inner(spans[name])) - rgb).max() < TOL, name


def image_material(name: str, texcoord: str, colour_space: str, address: str = "periodic") -> str:
    """Standard Surface, base 0.5, base_color from an ND_image_color3 in a NodeGraph whose
    interface input holds the file; ``texcoord`` the node feeding its texcoord."""
    graph = f'''def NodeGraph "NG"
        {{
            asset inputs:file = @grid.png@ (
                colorSpace = "{colour_space}"
            )
            color3f outputs:out_color.connect = </Looks/{name}/NG/Image.outputs:out>
            def Shader "Image"
            {{
                uniform token info:id = "ND_image_color3"
                asset inputs:file.connect = </Looks/{name}/NG.inputs:file>
                color3f inputs:default = (0.1, 0.2, 0.3)
                string inputs:uaddressmode = "{address}"
                float2 inputs:texcoord.connect = </Looks/{name}/NG/Coords.outputs:out>
                color3f outputs:out
            }}
            def Shader "Coords"
            {{
                {texcoord}
                float2 outputs:out
            }}
        }}'''
    inputs = f"float inputs:base = 0.5\n            color3f inputs:base_color.connect = </Looks/{name}/NG.outputs:out_color>"
    return mx(name, "ND_standard_surface_surfaceshader", inputs, graph)


def tiled_material(name: str, tiling: str) -> str:
    """Standard Surface, base_color from an ND_tiledimage_color3 (raw) with ``tiling``."""
    image = f'''def Shader "Tiled"
        {{
            uniform token info:id = "ND_tiledimage_color3"
            asset inputs:file = @grid.png@ (
                colorSpace = "raw"
            )
            {tiling}
            color3f outputs:out
        }}'''
    return mx(name, "ND_standard_surface_surfaceshader",
              f"color3f inputs:base_color.connect = </Looks/{name}/Tiled.outputs:out>", image)


def test_image_base_color_through_a_node_graph(tmp_path):
    """A 2 x 1 image: left texel (51, 102, 153), right (255, 204, 0). The quads' st runs
    over s in [0, 2): the first half shows the two texels, the second half repeats them
    (periodic) or shows the image's default (constant). Their uv runs backwards (2 - s):
    the quad reading uv shows the texels in the other order. An ND_image_float (0, then 1)
    on metalness: diffuse, then a mirror. ND_tiledimage_color3 maps st by its tiling."""
    write_image(tmp_path / "grid.png", np.array([[[51, 102, 153], [255, 204, 0]]], dtype=np.uint8), oiio.UINT8)
    uv0 = 'uniform token info:id = "ND_texcoord_vector2"'
    uv = 'uniform token info:id = "ND_geompropvalue_vector2"\n                string inputs:geomprop = "uv"'
    write_image(tmp_path / "mask.png", np.array([[[0], [255]]], dtype=np.uint8), oiio.UINT8)
    mask = '''def Shader "Mask"
        {
            uniform token info:id = "ND_image_float"
            asset inputs:file = @mask.png@ (
                colorSpace = "raw"
            )
            float outputs:out
        }'''
    looks = {"Raw": image_material("Raw", uv0, "lin_rec709"), "Srgb": image_material("Srgb", uv, "srgb_texture"),
             "Edge": image_material("Edge", uv0, "lin_rec709", address="constant"),
             "Mask": mx("Mask", "ND_standard_surface_surfaceshader", "color3f inputs:base_color = (0.5, 0.5, 0.5)\n"
                        "            float inputs:metalness.connect = </Looks/Mask/Mask.outputs:out>", mask),
             "Tiled": tiled_material("Tiled", "float2 inputs:uvtiling = (0.5, 1)\n            "
                                     "float2 inputs:uvoffset = (0.25, 0)"),
             "World": tiled_material("World", "float2 inputs:realworldimagesize = (2, 1)")}
    scene, region, spans = render(tmp_path, looks, st="(0, 0), (2, 0), (2, 1), (0, 1)",
                                  uv="(2, 0), (0, 0), (0, 1), (2, 1)")
    assert warnings_of(scene) == []
    stored = np.array([[51, 102, 153], [255, 204, 0]]) / 255.0
    srgb = np.where(stored <= 0.04045, stored / 12.92, ((stored + 0.055) / 1.055) ** 2.4)  # IEC 61966-2-1
    # Tolerance: float32 decoding of 8-bit values and the sRGB curve (~1e-7 relative), times 0.5.
    for name, texels in (("Raw", stored), ("Srgb", srgb), ("Edge", stored)):
        x0 = spans[name][0]
        for k in range(4):  # quarters of the quad: s in [k/2, (k+1)/2)
            lo, hi = x0 + 0.5 * k + 0.1, x0 + 0.5 * (k + 1) - 0.1
            texel = texels[(k + (name == "Srgb")) % 2]  # uv: quarter k at 2 - s, the other texel
            if name == "Edge" and k >= 2:
                texel = np.array([0.1, 0.2, 0.3], np.float32)  # outside [0, 1): the default
            assert np.abs(region(lo, hi) - 0.5 * texel).max() < TOL, (name, k)
        # ND_tiledimage: s' = (s uvtiling - uvoffset) / realworldimagesize x realworldtilesize
        # (periodic): Tiled s' = s / 2 - 1 / 4, in quarter k [k/4 - 1/4, (k+1)/4 - 1/4): texels 1, 0, 0, 1;
        # World s' = s / 2: texels 0, 0, 1, 1 (base 1: the texels themselves)
        for name, order in (("Tiled", (1, 0, 0, 1)), ("World", (0, 0, 1, 1))):
            lo, hi = spans[name][0] + 0.5 * k + 0.1, spans[name][0] + 0.5 * (k + 1) - 0.1
            assert np.abs(region(lo, hi) - stored[order[k]]).max() < TOL, (name, k)
        # metalness from the mask (texel 0, then 1): the diffuse 0.5, then a mirror of the background
        lo, hi = spans["Mask"][0] + 0.5 * k + 0.1, spans["Mask"][0] + 0.5 * (k + 1) - 0.1
        shown = np.float32(0.5) * (np.array(BACKGROUND) if k % 2 else 1.0)  # base 1 (1.39) x base_color 0.5
        assert np.abs(region(lo, hi) - shown).max() < TOL, ("Mask", k)


def test_unsupported_nodes_warn_and_fall_back_to_display_color(tmp_path):
    noise = '''def Shader "Noise"
        {
            uniform token info:id = "ND_noise2d_color3"
            color3f outputs:out
        }'''
    missing = '''def Shader "Image"
        {
            uniform token info:id = "ND_image_color3"
            asset inputs:file = @nothere.png@
            color3f inputs:default = (0.5, 0.25, 0.125)
            color3f outputs:out
        }'''
    looks = {
        "Noisy": mx("Noisy", "ND_standard_surface_surfaceshader",
                    "color3f inputs:base_color.connect = </Looks/Noisy/Noise.outputs:out>", noise),
        "Gltf": mx("Gltf", "ND_gltf_pbr_surfaceshader", "color3f inputs:base_color = (1, 0, 0)"),
        # a weight from an image (weights are constants), a colour from a missing file: only
        # the weight's line (nothing is read from a material that falls back)
        "WeightMap": mx("WeightMap", "ND_standard_surface_surfaceshader",
                        "float inputs:base.connect = </Looks/WeightMap/Mask.outputs:out>\n            color3f "
                        "inputs:base_color.connect = </Looks/WeightMap/Image.outputs:out>", missing + '''
        def Shader "Mask"
        {
            uniform token info:id = "ND_image_float"
            asset inputs:file = @nothere.png@
            float outputs:out
        }'''),
        # MaterialX's UsdPreviewSurface node is read on the mtlx output only (as before elsewhere)
        "Universal": _material("Universal", "color3f inputs:diffuseColor = (1, 0, 0)",
                               shader_id="ND_UsdPreviewSurface_surfaceshader"),
        "Missing": mx("Missing", "ND_standard_surface_surfaceshader",
                      "float inputs:base = 1\n            color3f inputs:base_color.connect = "
                      "</Looks/Missing/Image.outputs:out>", missing),
    }
    scene, region, spans = render(tmp_path, looks)
    assert warnings_of(scene) == [
        ("/Looks/Gltf", "outputs:mtlx:surface", "its shader /Looks/Gltf/S is 'ND_gltf_pbr_surfaceshader', not one "
         "of ND_standard_surface_surfaceshader, ND_standard_surface_surfaceshader_100, "
         "ND_open_pbr_surface_surfaceshader, which are the MaterialX surfaces supported; displayColor is used"),
        ("/Looks/Missing/Image", "inputs:file", "nothere.png cannot be found; the image's default (0.5, 0.25, "
         "0.125) is used"),
        ("/Looks/Noisy/S", "inputs:base_color", "is connected to /Looks/Noisy/Noise (ND_noise2d_color3), which is "
         "not evaluated (it can be an ND_image_color3 or ND_tiledimage_color3 node); displayColor is used"),
        ("/Looks/Universal", "outputs:surface", "its shader /Looks/Universal/Surface is "
         "'ND_UsdPreviewSurface_surfaceshader', not UsdPreviewSurface, which is the only one supported; "
         "displayColor is used"),
        ("/Looks/WeightMap/S", "inputs:base", "is connected to /Looks/WeightMap/Mask (ND_image_float), which is not "
         "evaluated (it can be a constant); displayColor is used"),
    ]
    for name, rgb in (("Noisy", (0.5, 0.75, 0.25)), ("Gltf", (0.5, 0.75, 0.25)), ("WeightMap", (0.5, 0.75, 0.25)),
                      ("Universal", (0.5, 0.75, 0.25)), ("Missing", (0.5, 0.25, 0.125))):
        assert np.abs(region(*inner(spans[name])) - rgb).max() < TOL, name
    assert {s.material.prim_path for b in scene.bodies for s in b.surfaces} >= {"/Looks/Noisy", "/Looks/Gltf"}
