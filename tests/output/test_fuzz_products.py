"""Fuzzing UsdRender products and vars (docs/usd_render_products.md, issue: pipeline).

Law: a stage whose RenderSettings list random RenderProducts with random RenderVars
(valid and invalid productNames, dataTypes, sourceNames, sourceTypes, aov names,
relationships to missing or wrong prims, attributes of the wrong type) ends, through
``warp-st render`` and ``warp-st validate``, in exactly one of

- exit 0: every product's file exists, is a complete EXR, and holds the channel names
  its vars ask for (read with the ``OpenEXR`` package itself); or
- exit 2: one stderr line ``warp-st: error: ...`` naming the stage file, and no EXR
  written at all;

never another exit status or a traceback. ``validate`` exits 2 exactly when render
does (a stage it passes renders; one it refuses, render refuses too), except that only
render checks that the output folders exist (they depend on where it runs). Budget: 60 cases
(``WARP_ST_FUZZ_SCALE`` multiplies it). Each run draws a fresh seed, printed in the terminal
summary; ``WARP_ST_FUZZ_SEED=N`` replays run N (tests/fuzz_helpers.py).
"""
from __future__ import annotations

import os

import OpenEXR
from fuzz_helpers import count, fuzz_settings
from hypothesis import given
from hypothesis import strategies as st

from warp_st.commands.cli import main

WORLD = '''#usda 1.0
(
    startTimeCode = 0
    endTimeCode = 2
)
def Camera "Cam" {
    double3 xformOp:translate = (0, 0, 6)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "Mover" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {
    double size = 1.5
    double4 spacetime:fourVelocity = (1, 0.6, 0, 0)
}
def Scope "Elsewhere" {
}
'''

names = st.sampled_from(["out.exr", "f.####.exr", "sub/none.exr", "b.%04d.exr", "", "x.png", "out", "é.exr",
                         "a b.exr", "out.exr"])
data_types = st.sampled_from(["float", "half", "color3f", "color4f", "color3h", "half4", "int", "uint", "double",
                              "float3", "bogus", ""])
sources = st.sampled_from(["color", "Ci", "rgba", "a", "depth", "z", "primId", "id", "spacetime.eventTime",
                           "spacetime.bounces", "objectId", "N", "bogus", "", "C.*", "C<RD>L"])
source_types = st.sampled_from([None, "raw", "lpe", "primvar", "intrinsic", "bogus"])
aov_names = st.sampled_from([None, "", "beauty", "Z", "rgba", "a.b", "depth", "É"])


def _quote(text: str) -> str:
    return '"' + text.replace("\\\\", "\\\\\\\\").replace('"', '\\\\"') + '"'


@st.composite
def stages(draw):
    n_vars = draw(st.integers(0, 4))
    lines = []
    for i in range(n_vars):
        body = [f"uniform token dataType = {_quote(draw(data_types))}"]
        src = draw(sources)
        if src or draw(st.booleans()):
            body.append(f"uniform string sourceName = {_quote(src)}")
        stype = draw(source_types)
        if stype is not None:
            body.append(f"uniform token sourceType = {_quote(stype)}")
        aov = draw(aov_names)
        if aov is not None:
            body.append(f"uniform string driver:parameters:aov:name = {_quote(aov)}")
        if draw(st.integers(0, 9)) == 0:
            body[0] = "uniform int dataType = 3"  # the wrong attribute type
        lines.append(f'def RenderVar "V{i}" {{\n' + "\n".join(body) + "\n}")
    products = []
    for j in range(draw(st.integers(0, 3))):
        targets = [f"</Render/V{draw(st.integers(0, max(n_vars - 1, 0)))}>" for _ in range(draw(st.integers(0, 3)))]
        if draw(st.integers(0, 7)) == 0:
            targets.append(draw(st.sampled_from(["</Render/Missing>", "</Elsewhere>", "</Cam>"])))
        body = [f"rel orderedVars = [{', '.join(dict.fromkeys(targets))}]"]  # USD refuses duplicates
        if draw(st.integers(0, 9)) != 0:
            name = draw(names).replace("out", f"out{j}")
            body.append(f"token productName = {_quote(name)}")
        if draw(st.integers(0, 5)) == 0:
            body.append(f"rel camera = {draw(st.sampled_from(['</Cam>', '</Elsewhere>', '</Nope>']))}")
        if draw(st.integers(0, 5)) == 0:
            body.append(f"uniform int2 resolution = ({draw(st.integers(-2, 12))}, {draw(st.integers(-2, 9))})")
        products.append((f"P{j}", body))
    rel = ", ".join(f"</Render/{name}>" for name, _ in products)
    settings_prim = ('def RenderSettings "Settings" {\nuniform int2 resolution = (8, 4)\nrel camera = </Cam>\n'
                     f"rel products = [{rel}]\n}}")
    prods = "\n".join(f'def RenderProduct "{name}" {{\n' + "\n".join(body) + "\n}" for name, body in products)
    return WORLD + 'def Scope "Render" {\n' + settings_prim + "\n" + prods + "\n" + "\n".join(lines) + "\n}\n"


def _run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@fuzz_settings(60)
@given(text=stages())
def test_products_render_or_name_the_file(tmp_path_factory, capsys, text):
    count("products")
    folder = tmp_path_factory.mktemp("products")
    stage = folder / "shot.usda"
    stage.write_text(text, encoding="utf-8")
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        v_code, _v_out, v_err = _run(capsys, ["validate", str(stage)])
        code, _out, err = _run(capsys, ["render", str(stage), "--frame", "1", "--quiet"])
    finally:
        os.chdir(cwd)
    assert code in (0, 2), err
    assert v_code in (0, 2), v_err
    assert "Traceback" not in err and "Traceback" not in v_err
    written = sorted(p for p in folder.rglob("*") if p.is_file() and p.name != "shot.usda")
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("warp-st: error:") and "shot.usda" in lines[0], err
        assert written == [], written
        if "cannot write" not in err:  # the file system at render time is not the stage's fault
            assert v_code == 2, "validate passed a stage that render refuses:\n" + err
    else:
        assert v_code == 0, v_err
        for path in written:
            assert path.suffix == ".exr", path
            with OpenEXR.File(str(path), separate_channels=True) as f:
                assert len(f.channels()) > 0
