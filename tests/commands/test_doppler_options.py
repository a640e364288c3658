"""Doppler colour shift and searchlight, switched on three ways (docs/spec.md §3, §6):
``warp-st render --doppler-color / --searchlight``, the stage's render settings
(``spacetime:dopplerColor`` / ``spacetime:searchlight`` on the UsdRender.Settings prim) and
the Python API (``warp_st.render(doppler_color=..., searchlight=...)``).

Laws: each way gives the bit-identical beauty (the EXR's FLOAT channels are lossless) and
the same recorded options; it differs from the default render, which has both off; and
each hit pixel of the shifted beauty is the float64 twin of the kernel's transform
(``doppler_transform_np``) applied to the default beauty at that pixel's Doppler AOV, the
sun's light shifted first by its own D_ls (the sphere moves towards it, §3.5; 0.7.0).
The scene: a lit sphere approaching the camera at 0.6c (D up to 2 on the axis).
"""
from __future__ import annotations

import numpy as np
import pytest

import warp_st
from warp_st.commands.cli import main
from warp_st.core.doppler_colour import INTERPOLATION_ERROR, doppler_transform_np

WIDTH, HEIGHT = 16, 12


def _stage(settings: str = "") -> str:
    """A coupled sphere seen straight ahead at distance 6 at t = 0, moving at 0.6c towards
    the camera, under a distant light; ``settings``: lines of a RenderSettings prim."""
    prim = ""
    if settings:
        prim = f'def Scope "Render"\n{{\n    def RenderSettings "Settings"\n    {{\n        {settings}\n    }}\n}}\n'
    return f"""#usda 1.0
(
    upAxis = "Y"
)

def Camera "Cam"
{{
    float focalLength = 35
    float horizontalAperture = 20
}}

def Xform "Ball" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{{
    double3 xformOp:translate = (0, 0, -6)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    custom double4 spacetime:fourVelocity = (1, 0, 0, 0.6)
    custom double spacetime:referenceTime = -6

    def Sphere "S"
    {{
        double radius = 1.5
        color3f[] primvars:displayColor = [(0.6, 0.5, 0.3)]
    }}
}}

def DistantLight "Sun"
{{
    float inputs:angle = 0
    float inputs:intensity = 6.2831855
}}
{prim}"""


OPTIONS = {  # name: (command-line flags, settings lines, API keywords)
    "doppler_color": (["--doppler-color"], "custom bool spacetime:dopplerColor = true", {"doppler_color": True}),
    "searchlight": (["--searchlight"], "custom bool spacetime:searchlight = true", {"searchlight": True}),
    "both": (["--doppler-color", "--searchlight"],
             "custom bool spacetime:dopplerColor = true\n        custom bool spacetime:searchlight = true",
             {"doppler_color": True, "searchlight": True}),
}


def _cli(tmp_path, capsys, stage_text: str, name: str, flags=()):
    stage = tmp_path / f"{name}.usda"
    stage.write_text(stage_text)
    out = tmp_path / f"{name}.exr"
    code = main(["render", str(stage), "-o", str(out), "--width", str(WIDTH), "--height", str(HEIGHT), "--quiet",
                 *flags])
    _, err = capsys.readouterr()
    assert code == 0, err
    return warp_st.read_exr(out)


@pytest.fixture(scope="module")
def default(tmp_path_factory):
    path = tmp_path_factory.mktemp("default") / "plain.usda"
    path.write_text(_stage())
    return warp_st.render(warp_st.load(str(path)), width=WIDTH, height=HEIGHT)


@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_command_line_settings_and_api_agree(option, tmp_path, capsys, default):
    flags, settings, keywords = OPTIONS[option]
    by_flag = _cli(tmp_path, capsys, _stage(), "flag", flags)
    by_settings = _cli(tmp_path, capsys, _stage(settings), "settings")
    path = tmp_path / "api.usda"
    path.write_text(_stage())
    by_api = warp_st.render(warp_st.load(str(path)), width=WIDTH, height=HEIGHT, **keywords)
    want = {"dopplerColor": "true" if "doppler_color" in keywords else "false",
            "searchlight": "true" if "searchlight" in keywords else "false"}
    for img in (by_flag, by_settings, by_api):
        assert {k: img.metadata[k] for k in want} == want
        np.testing.assert_array_equal(img.rgba, by_api.rgba)
    assert {default.metadata[k] for k in want} == {"false"}
    hit = default.object_id > 0
    assert hit.sum() > 20 and np.all(np.abs(default.doppler[hit] - 1.0) > 0.1), "the case needs D != 1"
    assert np.abs(by_api.rgba[hit] - default.rgba[hit]).max() > 0.05, "the option changed nothing"
    # the transform of the default beauty at each pixel's Doppler factor (float64 twin);
    # 1e-4 relative: float32 work and D^4 of D ~ 2; with the colour shift plus the table's
    # interpolation bound per unit weight times each pixel's largest component (and D^4)
    shift, light = "doppler_color" in keywords, "searchlight" in keywords
    # the white sun (light from +z) reaches the ball moving towards it at D_ls = gamma (1 + l.v) = 1.25 x 1.6;
    # the default beauty is albedo x sun x cos, so the lit colour is it times the sun's shifted white
    d_ls = 1.25 * 1.6
    lit = default.rgba[hit][:, :3] * doppler_transform_np(np.ones(3), d_ls, color_shift=shift, searchlight=light)
    twin = doppler_transform_np(lit, default.doppler[hit], color_shift=shift, searchlight=light)
    # the table's bound for the sun's shift (carried through the second, D^4 with the searchlight) and the second's
    d_ls4, d_cam4 = (d_ls**4, default.doppler[hit] ** 4) if light else (1.0, 1.0)
    table = INTERPOLATION_ERROR * (default.rgba[hit][:, :3].max(axis=1) * d_ls4 + lit.max(axis=1)) * d_cam4
    np.testing.assert_allclose(by_api.rgba[hit][:, :3], twin, rtol=1e-4, atol=1e-6 + (table.max() if shift else 0.0))
