"""Bad input through the real command line: exit 2, one line naming file, prim and
attribute, and no output file created or overwritten (docs/spec.md §6)."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

BODY = """#usda 1.0
(
    upAxis = "Y"
)
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Xform "Ship" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{{
    {attr}
    def Cube "Hull"
    {{
        double size = 1
    }}
}}
"""

CASES = {
    "coupled_superluminal": ("custom double4 spacetime:fourVelocity = (1, 1.0, 0, 0)", "spacetime:fourVelocity"),
    "time_component_not_positive": ("custom double4 spacetime:fourVelocity = (0, 0.5, 0, 0)", "spacetime:fourVelocity"),
    "lifetime_reversed": ("custom double2 spacetime:lifetime = (5, 5)", "spacetime:lifetime"),
    "nan_velocity": ("custom double4 spacetime:fourVelocity = (1, nan, 0, 0)", "spacetime:fourVelocity"),
    "inf_reference_time": ("custom double spacetime:referenceTime = inf", "spacetime:referenceTime"),
    "wrong_type": ('custom string spacetime:fourVelocity = "fast"', "spacetime:fourVelocity"),
    "animation_frame_unknown": ('custom uniform token spacetime:animationFrame = "axle"', "spacetime:animationFrame"),
    "animation_frame_rest_decoupled": ('custom uniform token spacetime:animationFrame = "rest"\n'
                                       '    custom bool spacetime:lorentzDecoupled = true', "spacetime:animationFrame"),
}


def _render(scene: Path, out: Path):
    return subprocess.run(
        [sys.executable, "-m", "warp_st", "render", str(scene), "-o", str(out), "--width", "8", "--height", "6"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_attribute_exit_2_names_file_prim_attribute(tmp_path, case):
    """Each bad-attribute class: exit 2, a single stderr line with the file name, the prim
    path and the attribute, no traceback, and a pre-existing output left byte-identical."""
    attr, name = CASES[case]
    scene = tmp_path / f"{case}.usda"
    scene.write_text(BODY.format(attr=attr))
    out = tmp_path / "out.exr"
    out.write_bytes(b"earlier good frame")
    proc = _render(scene, out)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert scene.name in lines[0] and "/Ship" in lines[0] and name in lines[0], lines[0]
    assert "Traceback" not in proc.stderr
    assert out.read_bytes() == b"earlier good frame"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([scene.name, "out.exr"])


def test_syntax_error_and_missing_file_exit_2(tmp_path):
    """A USD syntax error and a missing scene file: exit 2 naming the file, nothing written."""
    broken = tmp_path / "broken.usda"
    broken.write_text("#usda 1.0\ndef Xform \"A\" {\n  double3 xformOp:translate = (0, 0\n}\n")
    for scene in (broken, tmp_path / "absent.usda"):
        out = tmp_path / "never.exr"
        proc = _render(scene, out)
        assert proc.returncode == 2, proc.stderr
        assert scene.name in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
        assert not out.exists()


def test_a_bad_camera_attribute_is_the_one_line_after_warnings(tmp_path, capsys):
    """A stage with a warning (an unsupported prim) and a camera whose spacetime:lightSpeed
    has the wrong type: exit 2 with only the error line. The camera is evaluated per frame,
    so the command line evaluates it once while the stage's warnings are still held back
    (found by the fuzz test, WARP_ST_FUZZ_SEED=3256744215)."""
    from cli_helpers import run

    path = tmp_path / "cam.usda"
    path.write_text('''#usda 1.0
def Camera "Cam"
{
    custom int spacetime:lightSpeed = 3
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "Box"
{
}
def Points "Dots"
{
    point3f[] points = [(0, 0, 0)]
}
''')
    out = tmp_path / "x.exr"
    code, _, err = run(capsys, "render", path, "-o", out, "--width", "8", "--height", "8", "--quiet")
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0].startswith(f"warp-st: error: {path}: /Cam: spacetime:lightSpeed: must be a token")
    assert not out.exists()


def test_a_camera_too_fast_at_a_later_frame_is_the_one_line_after_warnings(tmp_path, capsys):
    """The camera is at rest until time code 8 and then moves 30 units in 2 time codes (15 c,
    in a schema stage: 1 unit per time code). Rendering frames 0-10 of a stage that also
    warns is exit 2 with only the error line, and nothing written: the command line
    evaluates the camera at every frame of the run while the warnings are held back."""
    from cli_helpers import run

    path = tmp_path / "fast.usda"
    path.write_text('''#usda 1.0
(
    startTimeCode = 0
    endTimeCode = 10
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    double3 xformOp:translate.timeSamples = { 0: (0, 0, 10), 8: (0, 0, 10), 10: (30, 0, 10) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "Box"
{
}
def Points "Dots"
{
    point3f[] points = [(0, 0, 0)]
}
''')
    code, _, err = run(capsys, "render", path, "-o", tmp_path / "x.####.exr", "--frames", "0-10",
                       "--width", "8", "--height", "8", "--quiet")
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0].startswith(f"warp-st: error: {path}: /Cam") and "15 c at time code 8" in lines[0], lines[0]
    assert not list(tmp_path.glob("x.*.exr"))
