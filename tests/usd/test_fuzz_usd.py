"""Fuzzing the USD reader and the render path (issue: bad input and faults).

Law: every stage, however malformed, ends in exactly one of

- a correct render: an 8 x 6 image with no NaN in the beauty, and the docs/spec.md §4
  background values (A = 0, Z = +inf, NaN times and Doppler, RGB = the background
  colour) exactly where objectId == 0 and only there; or
- a :class:`warp_st.SceneError` (exit 2 on the command line) whose single line names
  the file and, when one authored attribute is at fault, that prim and attribute,

never another exception, a traceback, a hang or a crash. Three generators:

- ``single``: a valid stage with exactly one attribute replaced by a random type and
  value (NaN, inf, huge, negative, wrong type, wrong array length, time samples only,
  declared without a value). The error must name file, prim and attribute.
- ``wild``: random stages built from random bodies (nested SpacetimeBodyAPI, deep
  Xform chains, random transforms), random meshes (empty, out-of-range and negative
  indices, degenerate and non-manifold polygons), random references, payloads and
  sublayers (missing, cyclic, to another file). The error must name the file.
- byte corruption of .usda and .usdc files (``Usd.Stage.Export``), run in a child
  process so that a crash in USD could not take the test run with it (a signal or a
  timeout fails the test and names the case).

Budgets: the default run is small (a few seconds per generator on two cores);
``WARP_ST_FUZZ_SCALE=X`` scales every generator, and the ``slow`` tests run the
figures quoted in ``docs/reliability.md``. Every case is bounded in time
(``faulthandler`` aborts a hang with a traceback; children have timeouts).

Seeds: every run draws a fresh seed for all the generators and prints it in the terminal
summary (``fuzz seed: N``) and beside each failing test; ``WARP_ST_FUZZ_SEED=N`` replays
that run (tests/fuzz_helpers.py).
"""
from __future__ import annotations

import contextlib
import faulthandler
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from fuzz_helpers import (
    ROOT,
    SLOTS,
    budget,
    corrupt,
    count,
    fuzz_random,
    fuzz_settings,
    run_worker,
    single_stage,
)
from hypothesis import given
from hypothesis import strategies as st

import warp_st
from warp_st import SceneError

#: Per-case wall-clock bound in the parent process: a hang dumps every thread's stack and exits.
CASE_SECONDS = 120


@contextlib.contextmanager
def watchdog(seconds: float = CASE_SECONDS):
    faulthandler.dump_traceback_later(seconds, exit=True)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


# --- values -------------------------------------------------------------------------

NAN, INF = float("nan"), float("inf")
SPECIAL_REALS = [
    0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 0.9, 0.99, 0.9999999, 1.0000001, 2.0, -2.0, 10.0, 1e-7, 1e-300,
    5e-324, 65504.0, 65520.0, 3.4e38, 3.5e38, 1e15, 1e16, 1e20, 1e300, 1.7976931348623157e308, -1e300,
    NAN, INF, -INF,
]
reals = st.one_of(
    st.sampled_from(SPECIAL_REALS),
    st.floats(-20, 20),
    st.floats(allow_nan=True, allow_infinity=True),
)
tame = st.floats(-3, 3, allow_nan=False).map(lambda x: round(x, 3))


def fmt_real(x: float) -> str:
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(float(x))


def fmt_tuple(xs) -> str:
    return "(" + ", ".join(fmt_real(x) for x in xs) + ")"


INT_TYPES = {"int": (-2**31, 2**31 - 1), "uint": (0, 2**32 - 1), "int64": (-2**63, 2**63 - 1)}
INT_VEC_TYPES = {"int2": 2, "int3": 3}
REAL_TYPES = ("double", "float", "half")
VEC_TYPES = {f"{b}{n}": n for b in ("double", "float", "half") for n in (2, 3, 4)}
VEC_TYPES.update({"color3f": 3, "point3f": 3, "vector3f": 3, "normal3f": 3, "point3d": 3})
SCALAR_TYPES = (*REAL_TYPES, *INT_TYPES, *INT_VEC_TYPES, *VEC_TYPES, "bool", "string", "token", "asset", "matrix4d")
VALUE_TYPES = (*SCALAR_TYPES, *(t + "[]" for t in SCALAR_TYPES if t not in ("asset", "matrix4d")))


@st.composite
def usd_value(draw, type_name: str) -> str:
    """Text of a value of ``type_name`` as .usda writes it (every value parses)."""
    if type_name.endswith("[]"):
        n = draw(st.integers(0, 4))
        return "[" + ", ".join(draw(usd_value(type_name[:-2])) for _ in range(n)) + "]"
    if type_name in REAL_TYPES:
        return fmt_real(draw(reals))
    if type_name in INT_TYPES:
        lo, hi = INT_TYPES[type_name]
        return str(draw(st.one_of(st.integers(-3, 8), st.sampled_from([lo, hi]), st.integers(lo, hi))))
    if type_name in INT_VEC_TYPES:
        n = INT_VEC_TYPES[type_name]
        ints = st.one_of(st.integers(-3, 16), st.integers(-2**31, 2**31 - 1))
        return "(" + ", ".join(str(draw(ints)) for _ in range(n)) + ")"
    if type_name in VEC_TYPES:
        n = VEC_TYPES[type_name]
        return fmt_tuple(draw(st.lists(st.one_of(tame, reals), min_size=n, max_size=n)))
    if type_name == "bool":
        return draw(st.sampled_from(["true", "false", "0", "1"]))
    if type_name in ("string", "token"):
        return json.dumps(draw(st.sampled_from(["fast", "finite", "infinite", "float32", "float64", "", "perspective",
                                                "orthographic", "vertex", "leftHanded", "invisible"])))
    if type_name == "asset":
        return draw(st.sampled_from(["@./missing.usda@", "@@", "@/dev/null@"]))
    if type_name == "matrix4d":
        rows = [draw(st.lists(st.one_of(tame, reals), min_size=4, max_size=4)) for _ in range(4)]
        return "(" + ", ".join(fmt_tuple(r) for r in rows) + ")"
    raise AssertionError(type_name)


@st.composite
def attribute_line(draw, name: str, good_type: str, prefix: str = "custom ") -> str:
    """One authored attribute ``name``: of the expected type (half the time) or any type,
    with a default value, only time samples, or no value at all."""
    type_name = draw(st.one_of(st.just(good_type), st.sampled_from(VALUE_TYPES)))
    form = draw(st.sampled_from(["default"] * 6 + ["samples", "both", "declared"]))
    head = f"{prefix}{type_name} {name}"
    if form == "declared":
        return head
    if form == "default":
        return f"{head} = {draw(usd_value(type_name))}"
    samples = ", ".join(f"{t}: {draw(usd_value(type_name))}" for t in draw(st.lists(st.integers(-2, 5), min_size=1,
                                                                                      max_size=3, unique=True)))
    line = f"{head}.timeSamples = {{ {samples} }}"
    if form == "both":
        line = f"{head} = {draw(usd_value(type_name))}\n{line}"
    return line




@st.composite
def single_fault(draw):
    slot = draw(st.sampled_from(sorted(SLOTS)))
    _, _, name, good_type, good = SLOTS[slot]
    prefix = "uniform " if good.startswith("uniform ") else ("custom " if good.startswith("custom ") else "")
    line = draw(attribute_line(name, good_type, prefix))
    return slot, line


# --- the oracle --------------------------------------------------------------------------


def check_image(img, scene) -> None:
    """A correct render: no NaN in the beauty, docs/spec.md §4 background exactly where objectId == 0."""
    assert img.rgba.shape == (6, 8, 4)
    assert not np.isnan(img.rgba).any(), "NaN in the beauty"
    bg = img.object_id == 0
    hit = ~bg
    assert (img.object_id <= len(scene.bodies)).all(), "objectId beyond the bodies"
    alpha = img.rgba[..., 3]
    assert ((alpha >= 0) & (alpha <= 1)).all(), "A outside [0, 1]"
    assert np.isposinf(img.depth[bg]).all(), "Z != +inf on a background pixel"
    for name in ("event_time", "proper_time", "doppler", "source_time"):
        assert np.isnan(getattr(img, name)[bg]).all(), f"{name} is not NaN on a background pixel"
    assert (img.bounces[bg] == 0).all()
    background = np.asarray(scene.settings.background or (0.0, 0.0, 0.0), dtype=np.float32)
    # The AOVs come from the pixel-centre ray; with several samples the beauty is the
    # mean over the pixel (A = coverage), so only uncovered pixels show the pure background.
    single = int(img.metadata.get("samples", "1")) == 1
    empty = bg & (alpha == 0) if not single else bg
    assert (alpha[empty] == 0).all(), "A != 0 on a background pixel"
    assert (img.rgba[..., :3][empty] == background).all(), "background pixel is not the background colour"
    if hit.any():
        if single:
            assert (alpha[hit] > 0).all(), "A == 0 on a hit pixel"
        assert np.isfinite(img.depth[hit]).all() and (img.depth[hit] >= 0).all(), "Z not finite on a hit"
        assert np.isfinite(img.event_time[hit]).all(), "eventTime not finite on a hit"
        assert not np.isnan(img.proper_time[hit]).any(), "properTime NaN on a hit"
        assert not np.isnan(img.doppler[hit]).any(), "Doppler NaN on a hit"


#: The fuzzed renders' memory limit: a stage that asks for more ends in the resource SceneError.
FUZZ_MAX_MEMORY = 1 << 30


def is_resource_error(exc: SceneError) -> bool:
    return "more than the memory limit" in str(exc)


def render_or_scene_error(path: Path, *, no_references: bool = False):
    """(image, scene) or the SceneError; anything else propagates (a bug)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unsupported prims warn; not the law under test
        try:
            scene = warp_st.load(str(path), no_references=no_references)
            img = warp_st.render(scene, width=8, height=6, max_memory=FUZZ_MAX_MEMORY)
        except SceneError as exc:
            return exc
    check_image(img, scene)
    return img


def assert_names(exc: SceneError, *fragments: str) -> None:
    text = str(exc)
    assert "\n" not in text, f"multi-line error: {text!r}"
    for f in fragments:
        assert f in text, f"{f!r} not in error: {text}"


# --- single-fault fuzzing ------------------------------------------------------------------

def test_single_fault_base_stage_renders(tmp_path):
    """The base of the single-fault generator is valid and draws every body."""
    path = tmp_path / "base.usda"
    path.write_text(single_stage())
    result = render_or_scene_error(path)
    assert not isinstance(result, SceneError), result
    assert set(np.unique(result.object_id)) >= {1, 2}


def _single_case(tmp_path_factory, case):
    slot, line = case
    _, prim, name, _, _ = SLOTS[slot]
    path = tmp_path_factory.mktemp("single") / "stage.usda"
    path.write_text(single_stage(slot, line))
    with watchdog():
        result = render_or_scene_error(path)
    count("single")
    if isinstance(result, SceneError):
        if is_resource_error(result):  # names the file and the largest body, not an attribute
            assert_names(result, path.name)
        else:
            assert_names(result, path.name, prim, name)


def test_a_camera_speed_whose_square_underflows_renders_finite_depth(tmp_path_factory):
    # Found by test_single_fault_stage_many (WARP_ST_FUZZ_SEED=2222): a camera speed of
    # 1.5e-47 is not 0 in float64 (the camera counted as moving) but its square is 0 in the
    # kernel's float32, and the rest-frame distance's (gamma - 1) / v.v was 0 / 0: NaN depth
    # on every hit. It must render as a camera at rest does (check_image's laws;
    # rendering/camera.make_camera decides "moving" in the kernel's float type).
    _single_case(tmp_path_factory, ("cam_u", "custom double4 spacetime:fourVelocity = (1.0, 0.0, 0.0, 1.5e-47)"))


@fuzz_settings(150)
@given(case=single_fault())
def test_single_fault_stage_renders_or_names_the_attribute(tmp_path_factory, case):
    """One attribute replaced by a random type / value: a correct render, or a SceneError
    naming the file, that prim and that attribute."""
    _single_case(tmp_path_factory, case)


@pytest.mark.slow
@fuzz_settings(3000)
@given(case=single_fault())
def test_single_fault_stage_many(tmp_path_factory, case):
    _single_case(tmp_path_factory, case)


# --- wild stages ---------------------------------------------------------------------------

HELPER_GEOMETRY = """#usda 1.0
(
    defaultPrim = "Asset"
)
def Xform "Asset"
{
    def Cube "Box"
    {
        double size = 1
    }
}
"""


def _maybe(draw, p: float) -> bool:
    return draw(st.floats(0, 1)) < p


@st.composite
def wild_attr(draw, name: str, good_type: str, good_values, prefix: str = "custom ") -> str:
    """Mostly a sane value of the expected type, sometimes anything (attribute_line)."""
    if _maybe(draw, 0.85):
        return f"{prefix}{good_type} {name} = {draw(good_values)}"
    return draw(attribute_line(name, good_type, prefix))


def _vec(n, elems=tame):
    return st.lists(elems, min_size=n, max_size=n).map(fmt_tuple)


@st.composite
def wild_mesh(draw, name: str) -> str:
    n_pts = draw(st.integers(0, 8))
    shape = draw(st.sampled_from(["random"] * 6 + ["line", "point", "wild"]))
    if shape == "line":
        pts = [(i * 0.5, i * 0.25, 0.0) for i in range(n_pts)]
    elif shape == "point":
        pts = [(0.5, 0.5, 0.5)] * n_pts
    else:
        coord = st.one_of(tame, reals) if shape == "wild" else tame
        pts = [tuple(draw(coord) for _ in range(3)) for _ in range(n_pts)]
    counts = draw(st.lists(st.one_of(st.integers(3, 6), st.integers(-1, 2)), max_size=5))
    index = st.one_of(st.integers(0, max(n_pts - 1, 0)), st.integers(0, max(n_pts - 1, 0)), st.integers(-2, n_pts + 2))
    indices = [draw(index) for _ in range(sum(c for c in counts if c > 0))]
    if _maybe(draw, 0.1) and indices:
        indices = indices[:-1]
    lines = [
        f"point3f[] points = [{', '.join(fmt_tuple(p) for p in pts)}]",
        f"int[] faceVertexCounts = [{', '.join(map(str, counts))}]",
        f"int[] faceVertexIndices = [{', '.join(map(str, indices))}]",
    ]
    if _maybe(draw, 0.15):
        i = draw(st.integers(0, 2))
        lines[i] = draw(attribute_line(["points", "faceVertexCounts", "faceVertexIndices"][i],
                                       ["point3f[]", "int[]", "int[]"][i], ""))
    if _maybe(draw, 0.2):
        lines.append(draw(wild_attr("normals", "normal3f[]", st.lists(_vec(3), max_size=8).map(
            lambda v: "[" + ", ".join(v) + "]"), "")))
    if _maybe(draw, 0.2):
        lines.append(draw(wild_attr("primvars:displayColor", "color3f[]", st.lists(_vec(3), max_size=3).map(
            lambda v: "[" + ", ".join(v) + "]"), "")))
    if _maybe(draw, 0.1):
        lines.append('uniform token orientation = "leftHanded"')
    return f'def Mesh "{name}"\n{{\n' + "\n".join(lines) + "\n}\n"


@st.composite
def wild_xform_ops(draw) -> str:
    if not _maybe(draw, 0.5):
        return ""
    value = draw(_vec(3, st.one_of(tame, reals)) if _maybe(draw, 0.15) else _vec(3))
    op = draw(st.sampled_from(["translate", "scale", "rotateXYZ"]))
    typ = draw(st.sampled_from(["double3", "float3", "double3", "half3"]))
    return f'{typ} xformOp:{op} = {value}\nuniform token[] xformOpOrder = ["xformOp:{op}"]\n'


@st.composite
def wild_gprim(draw, name: str, depth: int = 0) -> str:
    kind = draw(st.sampled_from(["Mesh", "Mesh", "Cube", "Sphere", "Cylinder", "Body"] if depth < 2 else
                                ["Mesh", "Cube", "Sphere"]))
    if kind == "Mesh":
        text = draw(wild_mesh(name))
        return text[:-2] + draw(wild_xform_ops()) + "}\n"
    if kind == "Body":
        return draw(wild_body(name, depth + 1))
    attr = {"Cube": ("size", st.floats(0.1, 3).map(fmt_real)), "Sphere": ("radius", st.floats(0.1, 2).map(fmt_real)),
            "Cylinder": ("height", st.just("1"))}[kind]
    body = draw(wild_attr(attr[0], "double", attr[1], ""))
    extra = 'token visibility = "invisible"\n' if _maybe(draw, 0.1) else ""
    return f'def {kind} "{name}"\n{{\n{body}\n{extra}{draw(wild_xform_ops())}}}\n'


@st.composite
def wild_body(draw, name: str, depth: int = 0) -> str:
    api = _maybe(draw, 0.8)
    meta = ' (\n    prepend apiSchemas = ["SpacetimeBodyAPI"]\n)' if api else ""
    lines = []
    slow = st.floats(-0.95, 0.95).map(lambda x: round(x, 3))
    if _maybe(draw, 0.7):
        u = draw(st.tuples(st.floats(0.5, 2), slow, slow, slow))
        speed = math.sqrt(sum(c * c for c in u[1:])) / u[0]
        lines.append(draw(wild_attr("spacetime:fourVelocity", "double4",
                                    st.just(fmt_tuple(u) if speed < 0.99 else "(1, 0.5, 0, 0)"))))
    if _maybe(draw, 0.4):
        lines.append(draw(wild_attr("spacetime:lifetime", "double2",
                                    st.sampled_from(["(-10, 10)", "(-inf, 5)", "(0, inf)", "(-1e300, 1e300)", "(-20, -19)"]))))
    if _maybe(draw, 0.4):
        lines.append(draw(wild_attr("spacetime:referenceTime", "double", tame.map(fmt_real))))
    if _maybe(draw, 0.3):
        lines.append(draw(wild_attr("spacetime:lorentzDecoupled", "bool", st.sampled_from(["true", "false"]))))
    lines.append(draw(wild_xform_ops()))
    chain = draw(st.integers(0, CHAIN_DEPTH))
    children = "".join(draw(wild_gprim(f"G{i}", depth)) for i in range(draw(st.integers(0, 3))))
    for level in range(chain):  # a deep Xform chain between the body and its gprims
        children = f'def Xform "L{level}"\n{{\n{children}}}\n'
    return f'def Xform "{name}"{meta}\n{{\n' + "\n".join(lines) + "\n" + children + "}\n"


#: Depth of the Xform chains of the wild stages (test_deep_hierarchy goes to 3000).
CHAIN_DEPTH = 30

ARCS = {
    "none": "",
    "missing_ref": "prepend references = @./missing.usda@",
    "missing_payload": "prepend payload = @./missing.usda@",
    "helper_ref": "prepend references = @./helper.usda@",
    "helper_payload": "prepend payload = @./helper.usda@",
    "cycle_ref": "prepend references = @./back.usda@",
    "self_ref": "prepend references = @./stage.usda@</World>",
    "internal_missing": "prepend references = </Nowhere>",
    "internal_cycle": "prepend references = </World/Arc0>",
    "inherits_missing": "inherits = </Class>",
    "not_usd": "prepend references = @./garbage.usda@",
}


@st.composite
def wild_stage(draw) -> dict:
    """{"stage.usda": text, ...}: random cameras, lights, bodies, arcs and sublayers."""
    header = ['upAxis = "%s"' % draw(st.sampled_from(["Y", "Y", "Z", "X"]))]
    if _maybe(draw, 0.3):
        header.append(f"startTimeCode = {draw(st.integers(-3, 3))}")
        header.append(f"endTimeCode = {draw(st.integers(-3, 6))}")
    sub = draw(st.sampled_from([None] * 6 + ["missing.usda", "stage.usda", "back_sub.usda", "helper.usda"]))
    if sub:
        header.append(f"subLayers = [@./{sub}@]")
    parts = []
    if _maybe(draw, 0.9):
        where = draw(st.sampled_from([st.just("(0, 0, 10)")] * 8 + [_vec(3), _vec(3, reals)]))
        cam = [f"double3 xformOp:translate = {draw(where)}",
               'uniform token[] xformOpOrder = ["xformOp:translate"]']
        for name, typ, good in (("focalLength", "float", "30"), ("horizontalAperture", "float", "36"),
                                ("spacetime:time", "double", "0"), ("spacetime:lightSpeed", "token", '"infinite"')):
            if _maybe(draw, 0.3):
                prefix = "custom " if name.startswith("spacetime") else ""
                cam.append(draw(wild_attr(name, typ, st.just(good), prefix)))
        parts.append('def Camera "Cam" (\n prepend apiSchemas = ["SpacetimeCameraAPI"]\n)\n{\n' + "\n".join(cam) + "\n}\n")
    for i in range(draw(st.integers(0, 2))):
        kind = draw(st.sampled_from(["DistantLight", "SphereLight", "RectLight", "DiskLight"]))
        attrs = [draw(wild_attr("inputs:intensity", "float", st.floats(0, 10).map(fmt_real), ""))]
        if _maybe(draw, 0.3):
            attrs.append(draw(wild_attr("inputs:exposure", "float", st.floats(-3, 3).map(fmt_real), "")))
        if _maybe(draw, 0.3):
            attrs.append(draw(wild_attr("inputs:color", "color3f", _vec(3, st.floats(0, 1)), "")))
        parts.append(f'def {kind} "Light{i}"\n{{\n' + "\n".join(attrs) + "\n" + draw(wild_xform_ops()) + "}\n")
    for i in range(draw(st.integers(0, 4))):
        parts.append(draw(wild_body(f"Body{i}")))
    for i in range(draw(st.integers(0, 2))):
        arc = ARCS[draw(st.sampled_from(sorted(ARCS)))]
        meta = f" (\n    {arc}\n)" if arc else ""
        parts.append(f'def Xform "Arc{i}"{meta}\n{{\n{draw(wild_gprim("G"))}}}\n')
    if _maybe(draw, 0.2):
        parts.append('class Xform "Class"\n{\n}\n')
    settings_prim = ""
    if _maybe(draw, 0.3):
        lines = []
        for name, typ, good in (("spacetime:maxDepth", "int", "1"), ("spacetime:samples", "int", "2"),
                                ("spacetime:background", "color3f", "(0.1, 0.2, 0.3)"),
                                ("spacetime:precision", "token", '"float64"'), ("spacetime:shutter", "double", "0.5")):
            if _maybe(draw, 0.4):
                lines.append(draw(wild_attr(name, typ, st.just(good))))
        settings_prim = 'def Scope "Render"\n{\ndef RenderSettings "S"\n{\n' + "\n".join(lines) + "\n}\n}\n"
    main = "#usda 1.0\n(\n" + "\n".join(header) + "\n)\n" + 'def Xform "World"\n{\n' + "".join(parts) + "}\n" + settings_prim
    return {
        "stage.usda": main,
        "helper.usda": HELPER_GEOMETRY,
        "back.usda": '#usda 1.0\n(\n    defaultPrim = "B"\n)\ndef Xform "B" (\n    prepend references = @./stage.usda@</World>\n)\n{\n}\n',
        "back_sub.usda": "#usda 1.0\n(\n    subLayers = [@./stage.usda@]\n)\n",
        "garbage.usda": "#usda 1.0\n def def def {{{\n",
    }


def wild_case(directory: Path, files: dict) -> None:
    """The wild-stage law: a correct render or a one-line SceneError naming the file;
    with ``no_references`` too (arcs to other files are then not composed)."""
    for name, text in files.items():
        (directory / name).write_text(text)
    path = directory / "stage.usda"
    with watchdog():
        for no_refs in (False, True):
            result = render_or_scene_error(path, no_references=no_refs)
            if isinstance(result, SceneError):
                assert_names(result, path.name)


@fuzz_settings(60)
@given(files=wild_stage())
def test_wild_stage_renders_or_names_the_file(tmp_path_factory, files):
    """Random stages (bodies, meshes, deep chains, arcs, sublayers): a correct render or a
    one-line SceneError naming the file, with and without --no-references."""
    count("wild")
    wild_case(tmp_path_factory.mktemp("wild"), files)


@pytest.mark.slow
@fuzz_settings(1500)
@given(files=wild_stage())
def test_wild_stage_many(tmp_path_factory, files):
    count("wild")
    wild_case(tmp_path_factory.mktemp("wild"), files)




def _usd_seeds(directory: Path) -> list[Path]:
    """Valid stages to corrupt: the single-fault base, its .usdc export, the shipped scene's
    .usdc export (bigger: meshes, materials), and a mesh-heavy one."""
    from pxr import Usd

    seeds = []
    base = directory / "seed_base.usda"
    base.write_text(single_stage())
    seeds.append(base)
    for src in (base, ROOT / "usd_scenes" / "relativistic_parade.usda"):
        stage = Usd.Stage.Open(str(src))
        out = directory / f"seed_{src.stem}.usdc"
        assert stage.Export(str(out))
        seeds.append(out)
    return seeds


def _corruption_run(tmp_path: Path, suffix: str, n: int, tag: str, timeout: float) -> dict:
    rng = fuzz_random(tag)
    seeds = [p for p in _usd_seeds(tmp_path) if p.suffix == suffix]
    paths = []
    for i in range(n):
        src = seeds[i % len(seeds)]
        data, op = corrupt(src.read_bytes(), rng, hot=256 if suffix == ".usda" else 1024)
        path = tmp_path / f"case{i:05d}_{op}{suffix}"
        path.write_bytes(data)
        paths.append(path)
    counts = run_worker("usd", paths, tmp_path / "results.jsonl", timeout)
    count(f"corrupt{suffix}", n)
    return counts


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_corrupted_stage_bytes(tmp_path, suffix):
    """Random byte corruption of .usda text and .usdc crate files, through the real command
    line in a child process: exit 0 with a correct image, or exit 2 with one line naming the
    file and no output -- never exit 1, a traceback, a signal or a hang."""
    counts = _corruption_run(tmp_path, suffix, budget(30), f"stage{suffix}", timeout=300)
    assert sum(counts.values()) == budget(30)


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_corrupted_stage_bytes_many(tmp_path, suffix):
    counts = _corruption_run(tmp_path, suffix, budget(1000), f"stage{suffix}-many", timeout=3000)
    print(suffix, counts)


def test_empty_stage_near_the_origin_renders_background():
    """Regression (found by the wild-stage fuzzer): a stage with no visible geometry and the
    camera within a unit of the world origin hung the kernel (the empty BVH's root box was
    entered and its missing children read out of bounds). Every light speed and precision."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateInMemory()
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set((-0.5, 0.2, 0.1))
    scene = warp_st.load(stage)
    with watchdog(60):
        for light_speed in ("finite", "infinite"):
            for precision in ("float32", "float64"):
                img = warp_st.render(scene, width=8, height=6, light_speed=light_speed, precision=precision)
                assert (img.object_id == 0).all()
                check_image(img, scene)


def test_deep_hierarchy(tmp_path):
    """A body 3000 Xforms deep, each translating by 1e-4: read without recursion limits,
    the transforms composed exactly (pivot at x = 0.3), rendered."""
    depth = 3000
    chain = 'def Cube "C"\n{\ndouble size = 1\n}\n'
    for level in range(depth):
        api = ' (\n prepend apiSchemas = ["SpacetimeBodyAPI"]\n)' if level == 0 else ""
        chain = (f'def Xform "L{level}"{api}\n{{\ndouble3 xformOp:translate = (0.0001, 0, 0)\n'
                 f'uniform token[] xformOpOrder = ["xformOp:translate"]\n{chain}}}\n')
    path = tmp_path / "deep.usda"
    path.write_text('#usda 1.0\ndef Camera "Cam"\n{\ndouble3 xformOp:translate = (0, 0, 10)\n'
                    'uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n' + chain)
    with watchdog(120):
        result = render_or_scene_error(path)
    assert not isinstance(result, SceneError), result
    scene = warp_st.load(str(path))
    assert len(scene.bodies) == 1 and scene.bodies[0].prim_path.count("/") == depth
    assert abs(scene.bodies[0].surfaces[0].points[:, 0].mean() - 0.0001 * depth) < 1e-9
    assert (result.object_id == 1).any()
