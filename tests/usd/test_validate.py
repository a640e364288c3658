"""``warp-st validate``: every problem of a stage, one line each, with its prim path.

Laws: each problem class (wrong attribute type, |v| >= 1 on a coupled body, t <= 0, a
reversed lifetime, NaN, a bad light, bad render settings, bad camera values at
some time code; warnings for an arc that does not compose, prims that are ignored and a mesh
whose topology cannot be used) is
reported at ``file:prim[.attribute]``, all of them in one run; exit 2 with one
stderr line iff there is an error; shipped stages are clean; a stage read without the
schemas registered validates the same (docs/spec.md §2); and validate agrees with the reader:
no error <=> ``warp_st.load`` succeeds. Everything compared is text and exit codes.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from pxr import Usd, UsdValidation

import warp_st
from warp_st.commands.cli import main
from warp_st.core.scene import SceneError
from warp_st.usd import SCHEMA_DIR, validators

REPO = Path(__file__).resolve().parents[2]

HEADER = """#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = 0
    endTimeCode = 10
)
"""

CAMERA = """
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""

#: (stage body, [(SEVERITY, location after "file:", fragment of the message)])
CASES = {
    "wrong_type": ("""
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom float3 spacetime:fourVelocity = (1, 0.5, 0)
    def Cube "Hull" {}
}""", [("ERROR", "/Ship.spacetime:fourVelocity", "must be a 4-vector (double4 or float4), not float3")]),
    "superluminal_coupled": ("""
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double4 spacetime:fourVelocity = (1, 0.6, 0.8, 0)
    def Cube "Hull" {}
}""", [("ERROR", "/Ship.spacetime:fourVelocity", "|v| = 1 >= 1")]),
    "animation_frame": ("""
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom uniform token spacetime:animationFrame = "axle"
    def Cube "Hull" {}
}""", [("ERROR", "/Ship.spacetime:animationFrame", "must be one of lab, rest; got 'axle'")]),
    "time_component": ("""
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double4 spacetime:fourVelocity = (0, 0.1, 0, 0)
    def Cube "Hull" {}
}""", [("ERROR", "/Ship.spacetime:fourVelocity", "time component must be > 0, got 0.0")]),
    "lifetime": ("""
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double2 spacetime:lifetime = (3, 3)
    def Cube "Hull" {}
}""", [("ERROR", "/Ship.spacetime:lifetime", "tBegin must be < tEnd, got (3.0, 3.0)")]),
    "nan": ("""
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double spacetime:referenceTime = nan
    def Cube "Hull" {}
}""", [("ERROR", "/Ship.spacetime:referenceTime", "must be finite, got nan")]),
    "mesh": ("""
def Mesh "Tri"
{
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 7]
}""", [("WARNING", "/Tri.faceVertexIndices", "entry 2 = 7 is out of range for 3 points; the mesh is not rendered")]),
    "transform": ("""
def Xform "Group"
{
    double3 xformOp:translate = (inf, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "A" {}
    def Cube "B" {}
}""", [("ERROR", "/Group.xformOp:translate", "is not finite")]),
    "body_pivot": ("""
def Xform "Ghost" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    double3 xformOp:translate = (nan, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}""", [("ERROR", "/Ghost.xformOp:translate", "is not finite")]),  # the reader stops there: no warnings
    "light": ("""
def SphereLight "Lamp"
{
    float inputs:intensity = -1
}""", [("ERROR", "/Lamp.inputs:intensity", "must be >= 0.0, got -1.0")]),
    "settings": ("""
def RenderSettings "Settings"
{
    custom int spacetime:samples = 0
    custom token spacetime:precision = "float16"
    custom double spacetime:shutter = -1
}""", [("ERROR", "/Settings.spacetime:samples", "must be >= 1, got 0"),
       ("ERROR", "/Settings.spacetime:precision", "must be one of float32, float64; got 'float16'"),
       ("ERROR", "/Settings.spacetime:shutter", "must be >= 0.0, got -1.0")]),
    "camera_values": ("""
def Camera "Odd" (prepend apiSchemas = ["SpacetimeCameraAPI"])
{
    float focalLength = -5
    custom double spacetime:time.timeSamples = { 0: 0, 4: nan, 10: 10 }
    custom token spacetime:lightSpeed = "warp"
}""", [("ERROR", "/Odd.focalLength", "must be > 0, got -5.0 (time code 0)"),
       ("ERROR", "/Odd.spacetime:time", "must be finite, got nan (time code 4)"),
       ("ERROR", "/Odd.spacetime:lightSpeed", "must be one of finite, infinite; got 'warp'")]),
    "camera_projection": ("""
def Camera "Flat"
{
    token projection = "orthographic"
}""", [("ERROR", "/Flat.projection", "must be perspective")]),
    "composition": ("""
def Xform "Prop" (prepend references = @no_such_asset.usda@)
{
}""", [("WARNING", "/Prop", "reference @no_such_asset.usda@ (in ")]),
    "unsupported": ("""
def BasisCurves "Hair" {}
def Points "Dust" {}
def Volume "Smoke" {}
def CylinderLight "Tube" {}
def Xform "Empty" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    def NurbsPatch "Sheet" {}
}""", [("WARNING", "/Hair", "BasisCurves gprims are not rendered"),
       ("WARNING", "/Dust", "Points gprims are not rendered"),
       ("WARNING", "/Smoke", "Volume gprims are not rendered"),
       ("WARNING", "/Tube", "CylinderLight is not supported"),
       ("WARNING", "/Empty/Sheet", "NurbsPatch gprims are not rendered"),
       ("WARNING", "/Empty", "nothing of this body is rendered")]),
}


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def write(tmp_path, name: str, body: str, camera: bool = True) -> Path:
    path = tmp_path / f"{name}.usda"
    path.write_text(HEADER + (CAMERA if camera else "") + body + "\n")
    return path


def assert_listed(out: str, path: Path, expected) -> None:
    lines = out.splitlines()
    for severity, location, fragment in expected:
        prefix = f"{severity} {path}:{location}: "
        hits = [ln for ln in lines if ln.startswith(prefix) and fragment in ln]
        assert len(hits) == 1, f"want one line {prefix}...{fragment}...; got:\n{out}"


def loads(path: Path) -> bool:
    """The reader accepts the stage and every camera evaluates at every frame 0..10."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = warp_st.load(str(path))
            for camera in scene.cameras:
                for frame in range(11):
                    scene.camera_state(camera, frame)
    except SceneError:
        return False
    return True


@pytest.mark.parametrize("name", sorted(CASES))
def test_each_problem_class(tmp_path, capsys, name):
    """One line per problem at file:prim[.attribute]; exit 2 (one stderr line) iff an error;
    and validate agrees with the reader (an error <=> warp_st.load raises)."""
    body, expected = CASES[name]
    path = write(tmp_path, name, body)
    code, out, err = run(capsys, "validate", path)
    assert_listed(out, path, expected)
    errors = sum(e[0] == "ERROR" for e in expected)
    problem_lines = [ln for ln in out.splitlines() if ln.startswith(("ERROR ", "WARNING "))]
    assert len(problem_lines) == len(expected), out
    assert out.splitlines()[-1].startswith(f"{path}: {'invalid' if errors else 'ok'}: {errors} error")
    if errors:
        assert code == 2
        assert err.strip() == f"warp-st: error: {path}: {errors} error{'s' if errors > 1 else ''} (listed above)"
    else:
        assert code == 0 and err == "", err
    assert loads(path) == (errors == 0)


def test_every_problem_in_one_run(tmp_path, capsys):
    """All the cases in one stage (renamed apart): every problem is listed, in stage order,
    including several on one prim; a missing camera is a warning."""
    bodies, expected = [], []
    for name in sorted(CASES):
        body, want = CASES[name]
        if name == "settings":
            bodies.append(body)
            expected += want
            continue
        bodies.append(f'def Xform "{name}"\n{{\n{body}\n}}')
        expected += [(s, f"/{name}{loc}", frag) for s, loc, frag in want]
    bodies.append("""
def Xform "Many" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom float3 spacetime:fourVelocity = (1, 2, 0)
    custom double2 spacetime:lifetime = (5, -5)
    custom double spacetime:referenceTime = inf
    custom int spacetime:lorentzDecoupled = 1
    def Sphere "Ball" {}
}""")
    expected += [("ERROR", "/Many.spacetime:fourVelocity", "not float3"),
                 ("ERROR", "/Many.spacetime:lifetime", "tBegin must be < tEnd"),
                 ("ERROR", "/Many.spacetime:referenceTime", "must be finite, got inf"),
                 ("ERROR", "/Many.spacetime:lorentzDecoupled", "must be a bool")]
    path = tmp_path / "everything.usda"
    path.write_text(HEADER + "\n".join(bodies) + "\n")
    code, out, err = run(capsys, "validate", path)
    lines = out.splitlines()
    for severity, location, fragment in expected:
        prefix = f"{severity} {path}{':' + location if location else ''}: "
        assert sum(ln.startswith(prefix) and fragment in ln for ln in lines) == 1, (prefix, fragment, out)
    n_errors = sum(e[0] == "ERROR" for e in expected)
    assert len(lines) == len(expected) + 1 and code == 2
    assert lines[-1] == f"{path}: invalid: {n_errors} errors, {len(expected) - n_errors} warnings"
    order = [ln.split(": ", 1)[0].split(":", 1)[-1] for ln in lines[1:-1]]  # stage order of the prims
    firsts = [o.split(".", 1)[0] for o in order]
    stage = Usd.Stage.Open(str(path))
    index = {str(p.GetPath()): i for i, p in enumerate(stage.TraverseAll())}
    assert [index[f] for f in firsts] == sorted(index[f] for f in firsts)


def test_shipped_stages_are_clean(capsys):
    """Every shipped stage: exit 0 (warnings allowed: the assets meant to be referenced have
    no camera)."""
    stages = sorted((REPO / "usd_scenes").rglob("*.usda"))
    assert len(stages) >= 10
    for path in stages:
        code, out, err = run(capsys, "validate", path)
        assert code == 0, out + err
        assert "ERROR" not in out and out.splitlines()[-1].startswith(f"{path}: ok: 0 errors")


def test_hidden_and_instanced_prims_follow_the_reader(tmp_path, capsys):
    """An invisible broken gprim is not read, so not reported, nor is a class; a broken prim
    in an instanced prototype is reported at each instance's path."""
    path = write(tmp_path, "hidden", """
def Mesh "Ghost" (doc = "hidden: never read")
{
    token visibility = "invisible"
    int[] faceVertexCounts = [4]
}
class Xform "Proto"
{
    def Mesh "Bad"
    {
        point3f[] points = [(0, 0, 0)]
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 0, 2]
    }
}
def Xform "I1" (instanceable = true
    prepend references = </Proto>)
{
}
def Xform "I2" (instanceable = true
    prepend references = </Proto>)
{
}""")
    code, out, _ = run(capsys, "validate", path)
    assert code == 0 and "Ghost" not in out
    assert_listed(out, path, [("WARNING", "/I1/Bad.faceVertexIndices", "out of range"),
                              ("WARNING", "/I2/Bad.faceVertexIndices", "out of range")])


def test_reader_failure_the_validators_miss_is_still_an_error(tmp_path, capsys, monkeypatch):
    """If a rule of the reader had no validator, validate must not pass the stage: the reader
    reads it after the validators and its SceneError becomes an ERROR line."""
    path = write(tmp_path, "ok", 'def Cube "Box" {}')
    import warp_st.usd.reader as reader

    def failing(*args, **kwargs):  # as load_scene(stage) names it: by its real path
        raise SceneError.at(str(path.resolve()), "/Box", "size", "a rule only the reader knows")

    monkeypatch.setattr(reader, "load_scene", failing)
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "validate", path.name)
    errors = [ln for ln in out.splitlines() if ln.startswith("ERROR")]
    assert code == 2 and errors == ["ERROR ok.usda:/Box.size: a rule only the reader knows"]


def test_json_output(tmp_path, capsys):
    path = write(tmp_path, "j", CASES["lifetime"][0] + CASES["unsupported"][0])
    code, out, _ = run(capsys, "validate", path, "--json")
    doc = json.loads(out)
    assert code == 2 and doc["ok"] is False and doc["errors"] == 1 and doc["warnings"] == len(CASES["unsupported"][1])
    first = doc["problems"][0]
    assert first == {"severity": "error", "file": str(path), "prim": "/Ship", "attribute": "spacetime:lifetime",
                     "message": "tBegin must be < tEnd, got (3.0, 3.0)", "validator": "warpSt:SpacetimeBody"}


def test_file_named_as_given(tmp_path, capsys, monkeypatch):
    """Problems name the stage as the user wrote it (a relative path stays relative)."""
    write(tmp_path, "rel", CASES["nan"][0])
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "validate", "rel.usda")
    assert code == 2 and out.splitlines()[0] == "ERROR rel.usda:/Ship.spacetime:referenceTime: must be finite, got nan"


def test_bad_files_exit_2_one_line(tmp_path, capsys):
    for path, fragment in ((tmp_path / "none.usda", "no such file"), (tmp_path / "junk.usda", "junk.usda")):
        if path.name == "junk.usda":
            path.write_text("#usda 1.0\ndef Xform \"A\" {\n")
        code, out, err = run(capsys, "validate", path)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("warp-st: error: ") and fragment in lines[0]
        assert out == ""


def test_validators_are_registered_with_usd_validation(tmp_path):
    """The validators live in pxr.UsdValidation's registry (keyword warpSt) and run there too."""
    validators.register()
    registry = UsdValidation.ValidationRegistry()
    names = {m.name for m in registry.GetValidatorMetadataForKeyword(validators.KEYWORD)}
    assert names == {"warpSt:SpacetimeBody", "warpSt:Geometry", "warpSt:Light", "warpSt:Stage"}
    path = write(tmp_path, "r", CASES["time_component"][0])
    stage = Usd.Stage.Open(str(path))
    errors = registry.GetOrLoadValidatorByName("warpSt:SpacetimeBody").Validate(stage.GetPrimAtPath("/Ship"))
    assert len(errors) == 1 and errors[0].GetType() == UsdValidation.ValidationErrorType.Error
    site = errors[0].GetSites()[0]
    assert site.IsProperty() and str(site.GetProperty().GetPath()) == "/Ship.spacetime:fourVelocity"
    assert "time component must be > 0" in errors[0].GetMessage()


SCHEMALESS = """
import sys
from pxr import Usd
Usd.SchemaRegistry()  # built before warp_st registers its plugin: the schemas stay unknown
import warp_st
from warp_st.commands.cli import main
assert Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("SpacetimeBodyAPI") is None
sys.exit(main(["validate", sys.argv[1]]))
"""


def test_same_result_without_the_schemas(tmp_path, capsys):
    """docs/spec.md §2: a stage read without SpacetimeBodyAPI / SpacetimeCameraAPI registered gives
    the same problems (the rules read the apiSchemas metadata and the authored types)."""
    bodies = [CASES[n][0] for n in ("wrong_type",)]
    bodies.append(CASES["camera_values"][0])
    bodies.append("""
def Xform "Other" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double4 spacetime:fourVelocity = (1, 0, 0, 3)
    custom double2 spacetime:lifetime = (1, 0)
    def Cube "Box" {}
}""")
    path = write(tmp_path, "noschema", "\n".join(bodies))
    code, out, _ = run(capsys, "validate", path)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    # importing warp_st before pxr in this process put the schema plugin on the path: not there
    plugins = env.get("PXR_PLUGINPATH_NAME", "").split(os.pathsep)
    env["PXR_PLUGINPATH_NAME"] = os.pathsep.join(p for p in plugins if p and Path(p) != SCHEMA_DIR)
    proc = subprocess.run([sys.executable, "-c", SCHEMALESS, str(path)], capture_output=True, text=True, env=env,
                          timeout=300)
    assert proc.returncode == code == 2, proc.stderr
    assert proc.stdout == out
    assert "/Other.spacetime:fourVelocity" in out and "/Other.spacetime:lifetime" in out


def test_products_writing_one_file_are_an_error(tmp_path, capsys, monkeypatch):
    """Two RenderProducts naming the same file at a frame: validate lists it on the second
    product's productName (render would refuse the stage the same way)."""
    from warp_st.commands.cli import main as cli

    path = tmp_path / "clash.usda"
    path.write_text('''#usda 1.0
(
    upAxis = "Y"
)
def Camera "Cam" {
}
def Cube "C" {
}
def Scope "Render" {
    def RenderSettings "Settings" {
        rel products = [</Render/P0>, </Render/P1>]
    }
    def RenderProduct "P0" {
        token productName = "same.exr"
        rel orderedVars = [</Render/V>]
    }
    def RenderProduct "P1" {
        token productName = "same.exr"
        rel orderedVars = [</Render/V>]
    }
    def RenderVar "V" {
        uniform string sourceName = "color"
        uniform token dataType = "color3f"
    }
}
''')
    code = cli(["validate", str(path)])
    out, err = capsys.readouterr()
    assert code == 2, out + err
    assert f"ERROR {path}:/Render/P1.productName: 'same.exr' is also the file of /Render/P0" in out, out
    monkeypatch.chdir(tmp_path)  # product names are relative to the working directory
    code = cli(["render", str(path), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "/Render/P1: productName:" in err and not list(tmp_path.glob("*.exr")), err
