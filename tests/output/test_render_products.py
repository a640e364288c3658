"""UsdRender products (docs/usd_render_products.md): a RenderVar-driven stage writes exactly
the channels it asks for, with the names and pixel types it asks for.

Oracles: the files are opened with the ``OpenEXR`` package directly (not our reader) to
see what is in them; the values are compared with a full render (``-o``: every docs/spec.md §4
channel) of the same frames and view: FLOAT and UINT channels bit for bit (the renderer
is deterministic and both files store the same float32 / uint32 values), HALF channels
bit for bit against numpy's float32 -> float16 rounding of the full channel (round to
nearest even, the conversion OpenEXR's own half type performs); productName time samples
against USD's own value resolution (``Usd.Attribute.Get(t)``).
"""
from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from pxr import Usd

import warp_st
from warp_st.commands.cli import main
from warp_st.core.scene import SceneError
from warp_st.output import exr
from warp_st.output.film import CHANNEL_NAMES, Image, OutputChannel

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "usd_scenes" / "pipeline" / "render_products.usda"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def channels(path) -> dict[str, tuple[str, np.ndarray]]:
    """{name: (pixel type, pixels)} straight from OpenEXR."""
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {n: (str(c.type()).rsplit(".", 1)[-1], np.array(c.pixels)) for n, c in f.channels().items()}


def header(path) -> dict:
    with OpenEXR.File(str(path), header_only=True) as f:
        return dict(f.header())


def bits(a):
    a = np.ascontiguousarray(a)
    return a.view({2: np.uint16, 4: np.uint32, 8: np.uint64}[a.dtype.itemsize]) if a.dtype.kind == "f" else a


def assert_bitwise(a, b, what):
    assert a.dtype == b.dtype and a.shape == b.shape, what
    np.testing.assert_array_equal(bits(a), bits(b), err_msg=what)


def manifest(path) -> dict[str, dict[int, str]]:
    """idManifest as {channel: {id: prim path}} from the header, OpenEXR only."""
    m = header(path).get("idManifest")
    if m is None:
        return {}
    groups = {}
    for i in range(m.size()):
        entries = {int(e.id()): "/".join(e.text()) for e in m[i]}
        for channel in m[i].getChannels():
            groups[channel] = entries
    return groups


# --- a tiny stage: a camera, a moving cube, a sphere at rest, a light ---------------------

WORLD = '''
def Camera "Cam" {
    double3 xformOp:translate = (0, 0, 6)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 20
}
def Camera "Side" {
    double3 xformOp:translate = (0.5, 0, 7)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 18
}
def DistantLight "Sun" {
    float inputs:angle = 0
    float inputs:intensity = 6.2831855
}
def Cube "Mover" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {
    double size = 1.5
    double4 spacetime:fourVelocity = (1, 0.6, 0, 0)
    color3f[] primvars:displayColor = [(0.9, 0.3, 0.1)]
}
def Sphere "Ball" {
    double radius = 1
    double3 xformOp:translate = (-1.5, 0.5, -2)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
'''


def stage(tmp_path: Path, render: str, name: str = "tiny.usda", metadata: str = "") -> Path:
    path = tmp_path / name
    path.write_text('#usda 1.0\n(\n    startTimeCode = 0\n    endTimeCode = 3\n' + metadata + ')\n'
                    + WORLD + usd(textwrap.dedent(render)))
    return path


def settings(products: str, vars_: str, extra: str = "", resolution=(32, 18)) -> str:
    return f'''
def Scope "Render" {{
    def RenderSettings "Settings" {{
        uniform int2 resolution = ({resolution[0]}, {resolution[1]})
        rel camera = </Cam>
        {extra}
    }}
{textwrap.indent(textwrap.dedent(products), "    ")}
{textwrap.indent(textwrap.dedent(vars_), "    ")}
}}
'''


def usd(text: str) -> str:
    """The tests' one-line prims -> usda, which wants a property per line:
    ``def X "x" { a; b }`` -> ``def X "x" {`` / ``a`` / ``b`` / ``}``."""
    return text.replace("; ", "\n").replace("{ ", "{\n").replace(" }", "\n}")


def var(name, source, data_type, aov=None, source_type=None) -> str:
    lines = [f'uniform string sourceName = "{source}"', f'uniform token dataType = "{data_type}"']
    if aov is not None:
        lines.append(f'uniform string driver:parameters:aov:name = "{aov}"')
    if source_type is not None:
        lines.append(f'uniform token sourceType = "{source_type}"')
    return f'def RenderVar "{name}" {{ ' + "; ".join(lines) + " }\n"


def product(name, product_name, var_names, extra="") -> str:
    targets = ", ".join(f"</Render/{v}>" for v in var_names)
    return (f'def RenderProduct "{name}" {{ token productName = "{product_name}"; '
            f"rel orderedVars = [{targets}]; {extra} }}\n")


def linked(tmp_path, products_and_vars: str, **kwargs) -> Path:
    """A stage whose settings list every RenderProduct defined in ``products_and_vars``."""
    names = [line.split('"')[1] for line in products_and_vars.splitlines() if "RenderProduct" in line]
    extra = "rel products = [" + ", ".join(f"</Render/{n}>" for n in names) + "]"
    return stage(tmp_path, settings(products_and_vars, "", extra=extra), **kwargs)


# --- the shipped example -----------------------------------------------------------------

@pytest.fixture(scope="module")
def shipped(tmp_path_factory):
    """The shipped stage's products and a full render of the same frames, in one folder."""
    out = tmp_path_factory.mktemp("shipped")
    cwd = os.getcwd()
    os.chdir(out)
    try:
        assert main(["render", str(SHIPPED), "--frames", "0-1", "--quiet"]) == 0
        assert main(["render", str(SHIPPED), "--frames", "0-1", "-o", "full.####.exr", "--quiet"]) == 0
    finally:
        os.chdir(cwd)
    return out


def test_shipped_stage_writes_exactly_the_products_files(shipped):
    """Law: one file per product per frame, named by productName (time samples for the beauty,
    a #### pattern for the spacetime product), relative to the working directory; nothing else."""
    assert sorted(p.name for p in shipped.glob("*.exr")) == sorted(
        [f"parade_beauty.000{f}.exr" for f in (0, 1)] + [f"parade_spacetime.000{f}.exr" for f in (0, 1)]
        + [f"full.000{f}.exr" for f in (0, 1)])


@pytest.mark.parametrize("frame", [0, 1])
def test_shipped_beauty_product_channels_types_and_values(shipped, frame):
    """Law: the beauty file holds exactly R, G, B, A (color4h: HALF) and Z (float: FLOAT), equal
    to the full render's channels (HALF: its float16 rounding), with the same time header."""
    full = channels(shipped / f"full.000{frame}.exr")
    got = channels(shipped / f"parade_beauty.000{frame}.exr")
    assert {n: t for n, (t, _) in got.items()} == {"R": "HALF", "G": "HALF", "B": "HALF", "A": "HALF", "Z": "FLOAT"}
    for name in "RGBA":
        assert_bitwise(got[name][1], full[name][1].astype(np.float16), name)
    assert_bitwise(got["Z"][1], full["Z"][1], "Z")
    h, hf = header(shipped / f"parade_beauty.000{frame}.exr"), header(shipped / f"full.000{frame}.exr")
    for key in ("spacetime:timeOrigin", "spacetime:cameraTime", "spacetime:frame"):
        assert_bitwise(np.asarray(h[key]), np.asarray(hf[key]), key)
    assert h["spacetime:frame"][0] == frame and h["spacetime:camera"] == hf["spacetime:camera"]
    assert "idManifest" not in h  # no objectId in this file: no manifest


@pytest.mark.parametrize("frame", [0, 1])
def test_shipped_spacetime_product_renamed_channels(shipped, frame):
    """Law: the AOV file holds exactly eventTime, properTime (FLOAT) and id (UINT), bit-equal to
    the full render's spacetime.eventTime (both relative to the same timeOrigin),
    spacetime.properTime and objectId; the idManifest describes channel "id"."""
    path = shipped / f"parade_spacetime.000{frame}.exr"
    full = channels(shipped / f"full.000{frame}.exr")
    got = channels(path)
    assert {n: t for n, (t, _) in got.items()} == {"eventTime": "FLOAT", "properTime": "FLOAT", "id": "UINT"}
    for name, source in (("eventTime", "spacetime.eventTime"), ("properTime", "spacetime.properTime"),
                         ("id", "objectId")):
        assert_bitwise(got[name][1], full[source][1], name)
    assert np.unique(got["id"][1]).size > 3  # several bodies are seen: the comparison means something
    ids = manifest(path)
    assert set(ids) == {"id"} and ids["id"] == manifest(shipped / f"full.000{frame}.exr")["objectId"]


def test_shipped_products_read_back_and_inspect(shipped, capsys):
    """Law: read_exr keeps renamed channels readable (Image.channel, as stored) and fills the
    absent SPEC ones; the idManifest of the renamed id channel is read; inspect works."""
    img = warp_st.read_exr(shipped / "parade_spacetime.0001.exr")
    full = warp_st.read_exr(shipped / "full.0001.exr")
    assert img.channels == () and set(img.extra) == {"eventTime", "properTime", "id"}
    assert_bitwise(img.channel("id"), full.object_id, "id")
    assert_bitwise(img.channel("eventTime"), full.file_channel("spacetime.eventTime"), "eventTime (relative)")
    assert img.id_manifest == full.id_manifest and not img.rgba.any()
    beauty = warp_st.read_exr(shipped / "parade_beauty.0001.exr")
    assert beauty.channels == ("R", "G", "B", "A", "Z") and beauty.extra == {}
    assert_bitwise(beauty.depth, full.depth, "Z")
    for path, names in (("parade_spacetime.0001.exr", ("eventTime", "properTime", "id")),
                        ("parade_beauty.0001.exr", ("R", "A", "Z"))):
        code, out, err = run(capsys, "inspect", shipped / path)
        assert code == 0, err
        first_words = {line.split()[0] for line in out.splitlines() if line.strip()}
        assert set(names) <= first_words, out  # a statistics row per channel


# --- reading: names, sources, data types ---------------------------------------------------

def test_source_names_data_types_and_channel_names(tmp_path):
    """Law (the mapping table of docs/usd_render_products.md): pipeline source names map to SPEC
    channels; the beauty layer (colour named color/rgba/Ci/C, alpha named a/alpha) writes plain
    R, G, B, A; other multi-component vars <name>.R/.G/.B(/.A); driver:parameters:aov:name wins
    over the prim name; half types are HALF."""
    vars_ = (var("color", "Ci", "color3f") + var("a", "a", "half") + var("beauty", "LdrColor", "color4h")
             + var("rgba", "rgba", "float4", aov="rgba") + var("depth", "depth", "float")
             + var("zz", "z", "half", aov="depth.Z") + var("prim", "primId", "int", aov="objectId")
             + var("ids", "id", "uint") + var("evt", "spacetime.eventTime", "float", aov="t")
             + var("lpe", "C.*", "color3h", aov="lit", source_type="lpe")
             + var("bounce", "spacetime.bounces", "uint", source_type="intrinsic"))
    names = ["color", "a", "beauty", "depth", "zz", "prim", "ids", "evt", "lpe", "bounce"]
    path = linked(tmp_path, product("P", "p.exr", names) + product("Q", "q.exr", ["rgba"]) + vars_)
    p, q = warp_st.load(path).products
    got = {v.prim_path.rsplit("/", 1)[1]: (v.channels, v.half) for v in p.vars}
    assert got == {
        "color": ((("R", "R"), ("G", "G"), ("B", "B")), False),
        "a": ((("A", "A"),), True),
        "beauty": ((("beauty.R", "R"), ("beauty.G", "G"), ("beauty.B", "B"), ("beauty.A", "A")), True),
        "depth": ((("depth", "Z"),), False),
        "zz": ((("depth.Z", "Z"),), True),
        "prim": ((("objectId", "objectId"),), False),
        "ids": ((("ids", "objectId"),), False),
        "evt": ((("t", "spacetime.eventTime"),), False),
        "lpe": ((("lit.R", "R"), ("lit.G", "G"), ("lit.B", "B")), True),
        "bounce": ((("bounce", "spacetime.bounces"),), False),
    }
    assert q.vars[0].channels == (("R", "R"), ("G", "G"), ("B", "B"), ("A", "A"))


def test_unauthored_source_and_aov_names_default_to_the_prim_name(tmp_path):
    """Law: sourceName and driver:parameters:aov:name default to the RenderVar's prim name;
    dataType defaults to the schema's color3f."""
    path = linked(tmp_path, product("P", "p.exr", ["color", "depth"])
                  + 'def RenderVar "color" { }\ndef RenderVar "depth" { uniform token dataType = "float" }\n')
    (prod,) = warp_st.load(path).products
    assert [v.channels for v in prod.vars] == [(("R", "R"), ("G", "G"), ("B", "B")), (("depth", "Z"),)]
    assert [v.source_name for v in prod.vars] == ["color", "depth"]


def test_product_name_time_samples_follow_usd(tmp_path):
    """Law: productName at a frame is USD's held value at that time code (before the first
    sample: the first), whatever the fractional or out-of-range time."""
    samples = "{ 1: \"a.exr\", 2.5: \"b.exr\", 4: \"c.exr\" }"
    render = settings(f'def RenderProduct "P" {{ token productName.timeSamples = {samples}; '
                      'rel orderedVars = </Render/color> }\n' + var("color", "color", "color3f"), "",
                      extra="rel products = </Render/P>")
    path = stage(tmp_path, render)
    (prod,) = warp_st.load(path).products
    usd_stage = Usd.Stage.Open(str(path))
    attr = usd_stage.GetPrimAtPath("/Render/P").GetAttribute("productName")
    for t in (-3.0, 0.0, 1.0, 1.5, 2.4999, 2.5, 3.0, 3.99, 4.0, 4.5, 100.0):
        assert prod.name_at(t) == attr.Get(t), t


def test_per_frame_product_names_on_the_command_line(tmp_path, capsys, monkeypatch):
    """Law: with no -o each frame writes the name its time sample gives (relative to the
    working directory); a static name with a #### pattern is expanded per frame."""
    monkeypatch.chdir(tmp_path)
    names = "{ 1: \"first.exr\", 2: \"second.exr\", 3: \"third.exr\" }"
    render = settings(f'def RenderProduct "P" {{ token productName.timeSamples = {names}; '
                      'rel orderedVars = </Render/color> }\n'
                      + product("Q", "aov/evt.##.exr", ["evt"]) + var("color", "color", "color4f")
                      + var("evt", "spacetime.eventTime", "float"), "",
                      extra="rel products = [</Render/P>, </Render/Q>]")
    path = stage(tmp_path, render)
    (tmp_path / "aov").mkdir()
    code, out, err = run(capsys, "render", path, "--frames", "1-3", "--quiet")
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.glob("*.exr")) == ["first.exr", "second.exr", "third.exr"]
    assert sorted(p.name for p in (tmp_path / "aov").glob("*.exr")) == ["evt.01.exr", "evt.02.exr", "evt.03.exr"]
    assert header(tmp_path / "second.exr")["spacetime:frame"][0] == 2.0
    assert set(channels(tmp_path / "aov" / "evt.03.exr")) == {"evt"}


def test_tiny_stage_values_equal_the_full_render(tmp_path, capsys, monkeypatch):
    """Law: on a moving scene every written channel equals the full render's (FLOAT / UINT bit
    for bit, HALF as its float16 rounding), at each of two frames."""
    monkeypatch.chdir(tmp_path)
    vars_ = (var("rgb", "color", "color3h", aov="beauty") + var("alpha", "A", "float")
             + var("d", "spacetime.doppler", "half") + var("tau", "spacetime.properTime", "float")
             + var("src", "spacetime.sourceTime", "float") + var("b", "spacetime.bounces", "uint"))
    path = linked(tmp_path, product("P", "p.#.exr", ["rgb", "alpha", "d", "tau", "src", "b"]) + vars_)
    assert run(capsys, "render", path, "--frames", "0-1", "--quiet")[0] == 0
    assert run(capsys, "render", path, "--frames", "0-1", "-o", "full.#.exr", "--quiet")[0] == 0
    expected = {"beauty.R": ("R", True), "beauty.G": ("G", True), "beauty.B": ("B", True), "A": ("A", False),
                "d": ("spacetime.doppler", True), "tau": ("spacetime.properTime", False),
                "src": ("spacetime.sourceTime", False), "b": ("spacetime.bounces", False)}
    for frame in (0, 1):
        got, full = channels(f"p.{frame}.exr"), channels(f"full.{frame}.exr")
        assert set(got) == set(expected)
        assert np.count_nonzero(full["A"][1]) > 20  # the bodies are in view
        for name, (source, half) in expected.items():
            want = full[source][1].astype(np.float16) if half else full[source][1]
            assert got[name][0] == ("HALF" if half else full[source][0]), name
            assert_bitwise(got[name][1], want, name)


# --- command-line precedence ---------------------------------------------------------------

def views_stage(tmp_path, second=None):
    """Product P with its own camera /Side and resolution 40x20; optionally a second product."""
    products = product("P", "p.exr", ["color"], extra="rel camera = </Side>; uniform int2 resolution = (40, 20)")
    if second:
        products += product("Q", "q.exr", ["depth"], extra=second)
    return linked(tmp_path, products + var("color", "color", "color4f") + var("depth", "depth", "float"))


def test_product_camera_and_resolution_and_overrides(tmp_path, capsys, monkeypatch):
    """Law: a product's camera and resolution override the settings'; --camera, --width and
    --height override the product's; -o writes every channel from the settings' view."""
    monkeypatch.chdir(tmp_path)
    path = views_stage(tmp_path)
    assert run(capsys, "render", path, "--frame", "1", "--quiet")[0] == 0
    got = channels("p.exr")
    assert set(got) == {"R", "G", "B", "A"} and got["R"][1].shape == (20, 40)
    assert header("p.exr")["spacetime:camera"] == "/Side"

    assert run(capsys, "render", path, "--frame", "1", "--camera", "/Cam", "--width", "24", "--height", "12",
               "--quiet")[0] == 0
    assert channels("p.exr")["R"][1].shape == (12, 24) and header("p.exr")["spacetime:camera"] == "/Cam"

    os.unlink("p.exr")
    assert run(capsys, "render", path, "--frame", "1", "-o", "all.exr", "--quiet")[0] == 0
    got = channels("all.exr")
    assert set(got) == set(CHANNEL_NAMES) and got["R"][1].shape == (18, 32)
    assert header("all.exr")["spacetime:camera"] == "/Cam" and not Path("p.exr").exists()


def test_products_with_different_views_exit_2_unless_overridden(tmp_path, capsys, monkeypatch):
    """Law: one run renders one view: products needing two views are exit 2 with one line and
    nothing written; --camera with --width/--height puts them on one view."""
    monkeypatch.chdir(tmp_path)
    path = views_stage(tmp_path, second="uniform int2 resolution = (32, 18)")
    code, _, err = run(capsys, "render", path, "--frame", "0")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "different views" in err, err
    assert not list(tmp_path.glob("*.exr"))
    assert run(capsys, "render", path, "--frame", "0", "--camera", "/Cam", "--width", "16", "--height", "8",
               "--quiet")[0] == 0
    assert channels("p.exr")["R"][1].shape == channels("q.exr")["depth"][1].shape == (8, 16)


# --- bad input ---------------------------------------------------------------------------

BAD = [
    (var("v", "beautyy", "color3f"), "/Render/v", "sourceName", "unknown source 'beautyy'; known: color"),
    (var("v", "depth", "color3f"), "/Render/v", "dataType", "'color3f' cannot hold source 'depth'"),
    (var("v", "color", "float"), "/Render/v", "dataType", "cannot hold source 'color'"),
    (var("v", "depth", "double"), "/Render/v", "dataType", "use one of float, half"),
    (var("v", "primId", "float"), "/Render/v", "dataType", "use one of int, uint"),
    (var("v", "Nn", "color3f", source_type="primvar"), "/Render/v", "sourceType", "no primvar outputs"),
    (var("v", "C<RD>.*", "color3f", source_type="lpe"), "/Render/v", "sourceName", "not supported"),
    (var("v", "color", "color3f", aov=""), "/Render/v", "driver:parameters:aov:name", "is empty"),
    (var("v", "color", "color3f") + var("w", "rgba", "color3f", aov="v"), "/Render/w",
     "driver:parameters:aov:name", "'v.R' is also written by /Render/v"),
]


@pytest.mark.parametrize("vars_, prim, attribute, problem", BAD, ids=[b[3][:24] for b in BAD])
def test_bad_render_var_exit_2_naming_file_prim_attribute(tmp_path, capsys, monkeypatch, vars_, prim,
                                                          attribute, problem):
    """Law: a RenderVar that cannot be written as asked is exit 2, one line naming the file,
    the prim and the attribute, and nothing is written."""
    monkeypatch.chdir(tmp_path)
    names = [line.split('"')[1] for line in vars_.splitlines()]
    path = linked(tmp_path, product("P", "p.exr", names) + vars_)
    code, _, err = run(capsys, "render", path, "--frames", "0-1")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{path}: {prim}: {attribute}: " in err and problem in err, err
    assert not list(tmp_path.glob("*.exr"))


BAD_PRODUCTS = [
    ('def RenderProduct "P" { rel orderedVars = </Render/v> }', "/Render/P", "productName", "is empty"),
    ('def RenderProduct "P" { token productName.timeSamples = { 0: "a.exr", 1: "" }; '
     'rel orderedVars = </Render/v> }', "/Render/P", "productName", "is empty at time 1"),
    ('def RenderProduct "P" { token productName = "p.png"; rel orderedVars = </Render/v> }',
     "/Render/P", "productName", "must end in .exr"),
    ('def RenderProduct "P" { token productName = "p.exr"; rel orderedVars = </Ball> }',
     "/Render/P", "orderedVars", "/Ball is not a UsdRender.Var prim"),
    ('def RenderProduct "P" { token productName = "p.exr" }', "/Render/P", "orderedVars", "names no RenderVar"),
    ('def RenderProduct "P" { token productName = "p.exr"; uniform token productType = "deepRaster"; '
     'rel orderedVars = </Render/v> }', "/Render/P", "productType", "not supported"),
    ('def RenderProduct "P" { token productName = "p.exr"; rel camera = </Ball>; '
     'rel orderedVars = </Render/v> }', "/Render/P", "camera", "/Ball is not a UsdGeom.Camera"),
    ('def RenderProduct "P" { token productName = "p.exr"; uniform int2 resolution = (0, 10); '
     'rel orderedVars = </Render/v> }', "/Render/P", "resolution", "must be positive"),
    ('def RenderProduct "P" { token productName = "same.exr"; rel orderedVars = </Render/v> }',
     "/Render/P", "productName", "is also the file of the frames 0 and 1"),
]


@pytest.mark.parametrize("text, prim, attribute, problem", BAD_PRODUCTS, ids=[b[3][:24] for b in BAD_PRODUCTS])
def test_bad_render_product_exit_2(tmp_path, capsys, monkeypatch, text, prim, attribute, problem):
    """Law: a RenderProduct without a usable name, vars, type, camera or resolution is exit 2,
    one line naming file, prim and attribute, nothing written."""
    monkeypatch.chdir(tmp_path)
    path = linked(tmp_path, text + "\n" + var("v", "color", "color3f"))
    code, _, err = run(capsys, "render", path, "--frames", "0-1")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{path}: {prim}: {attribute}: " in err and problem in err, err
    assert not list(tmp_path.glob("*.exr"))


def test_products_relationship_to_a_non_product(tmp_path):
    """Law: the settings' products must name UsdRender.Product prims."""
    path = stage(tmp_path, settings(var("v", "color", "color3f"), "", extra="rel products = </Render/v>"))
    with pytest.raises(SceneError, match=r"tiny.usda: /Render/Settings: products: /Render/v is not a "
                                         r"UsdRender.Product prim"):
        warp_st.load(path)


def test_two_products_with_one_name_exit_2(tmp_path, capsys, monkeypatch):
    """Law: two products naming the same file at a frame are exit 2 naming the second."""
    monkeypatch.chdir(tmp_path)
    path = linked(tmp_path, product("P", "x.#.exr", ["v"]) + product("Q", "x.#.exr", ["v"])
                  + var("v", "color", "color3f"))
    code, _, err = run(capsys, "render", path, "--frame", "0")
    assert code == 2 and "/Render/Q: productName: 'x.0.exr' is also the file of /Render/P" in err, err
    assert not list(tmp_path.glob("*.exr"))


# --- resume --------------------------------------------------------------------------------

def test_resume_with_products(tmp_path, capsys, monkeypatch):
    """Law: --resume skips a frame only when every product file is complete and holds the
    channels its product asks for; a missing file or one with other channels is redone."""
    monkeypatch.chdir(tmp_path)
    path = linked(tmp_path, product("P", "p.#.exr", ["color"]) + product("Q", "q.#.exr", ["depth"])
                  + var("color", "color", "color4f") + var("depth", "depth", "float"))
    assert run(capsys, "render", path, "--frames", "0-2", "--quiet")[0] == 0
    for name in ("p.0.exr", "q.0.exr", "p.2.exr"):
        os.utime(name, (1_000_000_000, 1_000_000_000))
    os.unlink("q.1.exr")
    Image(rgba=np.zeros((18, 32, 4), np.float32)).write_exr("q.2.exr", [OutputChannel("Z", "Z")])  # wrong name
    code, out, err = run(capsys, "render", path, "--frames", "0-2", "--resume")
    assert code == 0, err
    assert "frame 0: complete, skipped" in out and "frame 1:" in out and "frame 2:" in out
    assert os.stat("p.0.exr").st_mtime == os.stat("q.0.exr").st_mtime == 1_000_000_000
    assert os.stat("p.2.exr").st_mtime != 1_000_000_000  # the frame is rendered again as a whole
    assert set(channels("q.1.exr")) == set(channels("q.2.exr")) == {"depth"}


# --- the EXR writer on its own ------------------------------------------------------------------

def test_write_exr_channel_list_renames_subsets_and_halves(tmp_path):
    """Law: write_exr(channels=...) writes exactly the listed channels under their names, HALF
    where asked; the idManifest is written on the channel(s) holding objectId, else not at all;
    read_exr keeps unknown names as stored and writing that image back is bit-exact."""
    rng = np.random.default_rng(7)
    img = Image(rgba=rng.random((5, 6, 4)).astype(np.float32) * 70000,  # > 65504: HALF inf
                event_time=100.0 - rng.random((5, 6)), object_id=rng.integers(0, 4, (5, 6)).astype(np.uint32),
                camera_time=100.0, id_manifest={1: "/A", 2: "/B", 3: "/C"})
    spec = [OutputChannel("col.R", "R", True), OutputChannel("t", "spacetime.eventTime"),
            OutputChannel("id", "objectId"), OutputChannel("R", "R")]
    img.write_exr(tmp_path / "a.exr", spec)
    got = channels(tmp_path / "a.exr")
    assert {n: t for n, (t, _) in got.items()} == {"col.R": "HALF", "t": "FLOAT", "id": "UINT", "R": "FLOAT"}
    with np.errstate(over="ignore"):
        assert_bitwise(got["col.R"][1], img.rgba[..., 0].astype(np.float16), "col.R")
    assert np.isinf(got["col.R"][1]).any()
    assert_bitwise(got["t"][1], img.file_channel("spacetime.eventTime"), "t")
    assert manifest(tmp_path / "a.exr") == {"id": {1: "/A", 2: "/B", 3: "/C"}}
    img.write_exr(tmp_path / "b.exr", [OutputChannel("R", "R")])
    assert manifest(tmp_path / "b.exr") == {}

    back = warp_st.read_exr(tmp_path / "a.exr")
    assert back.channels == ("R",) and list(back.extra) == ["col.R", "id", "t"]
    assert back.extra["col.R"].dtype == np.float16 and back.id_manifest == img.id_manifest
    back.write_exr(tmp_path / "c.exr")
    again = channels(tmp_path / "c.exr")
    assert set(again) == set(got)
    for name in got:
        assert again[name][0] == got[name][0], name
        assert_bitwise(again[name][1], got[name][1], name)
    assert exr.is_complete_exr(tmp_path / "a.exr", ["t", "id"]) and not exr.is_complete_exr(tmp_path / "a.exr", ["Z"])


def test_write_exr_channel_list_errors(tmp_path):
    """Law: a duplicate or empty channel name, an unknown source, or a UINT stored as HALF is
    a ValueError / KeyError and no file is created."""
    img = Image(rgba=np.zeros((2, 2, 4), np.float32))
    for bad, error in (([OutputChannel("R", "R"), OutputChannel("R", "G")], ValueError),
                       ([OutputChannel("", "R")], ValueError), ([], ValueError),
                       ([OutputChannel("x", "nope")], KeyError),
                       ([OutputChannel("id", "objectId", True)], ValueError)):
        with pytest.raises(error):
            img.write_exr(tmp_path / "x.exr", bad)
        assert not list(tmp_path.iterdir())
