"""The ``warp-st`` command line (docs/spec.md §6).

Laws checked: exit 0 on success, 2 on bad input with exactly one stderr line
``warp-st: error: ...`` and no file created or overwritten, 130 on ^C naming the
complete frames; frame lists and output patterns expand as documented; inspect
reports what the EXR holds. No numeric tolerances: everything compared is text,
exit codes, file presence and exact values written by ``write_exr``.

Tests marked "real renderer" need ``warp_st.rendering.renderer.Renderer`` and the USD reader;
the others use small fakes so the command logic is checked on its own.
"""
from __future__ import annotations

import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import moving_body_stage

import warp_st
from warp_st.commands.cli import expand_output, format_frame, has_frame_pattern, main, parse_frames
from warp_st.core.scene import SceneError
from warp_st.jobs import tasks
from warp_st.output import exr
from warp_st.output.film import Image

REPO = Path(__file__).resolve().parents[2]

TINY_SCENE = moving_body_stage('def Cube "Box"\n        {\n            double size = 2\n        }', end_time=2,
                               vertical_aperture=27)

BAD_SCENE = """#usda 1.0
(
    upAxis = "Y"
)

def Xform "World"
{
    def Camera "Cam"
    {
        double3 xformOp:translate = (0, 0, 10)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def Xform "FasterThanLight" (
        prepend apiSchemas = ["SpacetimeBodyAPI"]
    )
    {
        custom double4 spacetime:fourVelocity = (1, 1.5, 0, 0)

        def Cube "Box"
        {
        }
    }
}
"""


def run(capsys, *argv):
    """main(argv) -> (exit code, stdout, stderr)."""
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def assert_usage_error(code, err, *fragments):
    """Exit 2 and exactly one stderr line ``warp-st: error: ...`` containing the fragments."""
    assert code == 2, err
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1 and lines[0].startswith("warp-st: error: "), err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


# --- frame lists and output names ---------------------------------------------------


@pytest.mark.parametrize(
    "text, frames",
    [
        ("7", [7.0]),
        ("1-5", [1.0, 2.0, 3.0, 4.0, 5.0]),
        ("1-240x2", [float(f) for f in range(1, 241, 2)]),
        ("1,5,10-20x5", [1.0, 5.0, 10.0, 15.0, 20.0]),
        ("3-3", [3.0]),
        ("0-2,1-3", [0.0, 1.0, 2.0, 3.0]),  # duplicates dropped, order kept
        ("-2-1", [-2.0, -1.0, 0.0, 1.0]),
        ("1.5,2.25", [1.5, 2.25]),
        (" 1 - 4 x 3 ", [1.0, 4.0]),
    ],
)
def test_parse_frames(text, frames):
    """Ranges are inclusive integer ranges with an optional step; lists are comma separated."""
    assert parse_frames(text) == frames


@pytest.mark.parametrize("text", ["", "5-1", "1-5x0", "a-b", "1-", "1,,2", "1-5x2.5", "nan", "inf", "1.5-3"])
def test_parse_frames_rejects(text):
    import argparse

    with pytest.raises(argparse.ArgumentTypeError):
        parse_frames(text)


@pytest.mark.parametrize(
    "pattern, frame, name",
    [
        ("out.####.exr", 7, "out.0007.exr"),
        ("out.#.exr", 12, "out.12.exr"),
        ("out.%04d.exr", 7, "out.0007.exr"),
        ("out.%4d.exr", 7, "out.0007.exr"),
        ("out.%d.exr", 7, "out.7.exr"),
        ("shots/s1_####/f.####.exr", 3, "shots/s1_0003/f.0003.exr"),
        ("out.####.exr", 1.5, "out.0001.5.exr"),
        ("out.####.exr", -3, "out.-003.exr"),
        ("out.####.exr", 123456, "out.123456.exr"),
        ("plain.exr", 4, "plain.exr"),
    ],
)
def test_expand_output(pattern, frame, name):
    """'#' runs become the zero-padded frame (width = run length), like %0Nd."""
    assert expand_output(pattern, frame) == name


def test_frame_pattern_detection():
    assert has_frame_pattern("a.####.exr") and has_frame_pattern("a.%04d.exr") and has_frame_pattern("a.%d.exr")
    assert not has_frame_pattern("a.exr") and not has_frame_pattern("100%.exr")
    assert format_frame(0.25, 4) == "0000.25"


# --- argument errors ------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, fragment",
    [
        ([], "command is required"),
        (["frobnicate"], "invalid choice"),
        (["render"], "SCENE.usda"),
        (["render", "s.usda", "--frames", "9-2"], "--frames"),
        (["render", "s.usda", "--frames", "1-3x0"], "step"),
        (["render", "s.usda", "--frame", "1", "--frames", "2-3"], "not allowed"),
        (["render", "s.usda", "--width", "0"], "--width"),
        (["render", "s.usda", "--samples", "two"], "--samples"),
        (["render", "s.usda", "--precision", "float16"], "--precision"),
        (["render", "s.usda", "--light-speed", "warp"], "--light-speed"),
        (["render", "s.usda", "--bogus"], "--bogus"),
        (["inspect"], "OUT.exr"),
        (["inspect", "x.exr", "--pixel", "1"], "--pixel"),
        (["validate"], "SCENE.usda"),
    ],
)
def test_bad_arguments_exit_2_one_line(capsys, tmp_path, monkeypatch, argv, fragment):
    """argparse errors are one line (no usage block) and exit 2; nothing is written."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *argv)
    assert_usage_error(code, err, fragment)
    assert list(tmp_path.iterdir()) == []


def test_help_exits_0(capsys):
    code, out, _ = run(capsys, "render", "--help")
    assert code == 0 and "--frames" in out and "--resume" in out


def test_python_dash_m_help():
    """``python -m warp_st --help`` runs the same command line."""
    result = subprocess.run(
        [sys.executable, "-m", "warp_st", "--help"], cwd=REPO, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    for command in ("render", "inspect", "validate"):
        assert command in result.stdout


# --- render with a fake scene and renderer (command logic only) ----------------------


class FakeRenderer:
    """Follows the Renderer API the command codes against; records its calls."""

    instances: list["FakeRenderer"] = []
    interrupt_at: float | None = None
    bad_option: bool = False

    def __init__(self, scene, *, frames, camera=None, width=None, height=None, max_depth=None,
                 samples=None, shutter=None, doppler_color=None, searchlight=None, precision=None,
                 light_speed=None):
        if self.bad_option:
            raise SceneError(f"{scene.source}: /Render/Settings: spacetime:samples: must be >= 1")
        self.scene = scene
        self.frames = list(frames)
        self.options = dict(camera=camera, width=width, height=height, max_depth=max_depth,
                            samples=samples, shutter=shutter, precision=precision, light_speed=light_speed)
        self.rendered: list[float] = []
        FakeRenderer.instances.append(self)

    def describe(self):
        return {"tetrahedra": 12, "build_seconds": 0.0}

    def render(self, frame):
        if self.interrupt_at is not None and frame == self.interrupt_at:
            raise KeyboardInterrupt
        self.rendered.append(frame)
        rgba = np.full((3, 4, 4), 0.5, np.float32)
        return Image(rgba=rgba, camera_time=frame, frame=frame, id_manifest={1: "/World/Mover"})


@pytest.fixture
def fake(monkeypatch, tmp_path):
    """A loadable scene file whose load() and Renderer are fakes; cwd = tmp_path."""
    FakeRenderer.instances = []
    monkeypatch.setattr(FakeRenderer, "interrupt_at", None)
    monkeypatch.setattr(FakeRenderer, "bad_option", False)
    monkeypatch.setattr(tasks, "Renderer", FakeRenderer)
    frame_range = {"value": (10.0, 20.0)}

    def fake_load(path, **kwargs):
        if "bad" in Path(path).name:
            raise SceneError(f"{path}: /World/Ship: spacetime:fourVelocity: speed 1.5 >= 1")
        return types.SimpleNamespace(source=str(path), frame_range=frame_range["value"],
                                     bodies=(), cameras=("/World/Cam",), lights=(), products=(),
                                     diagnostics=(), camera_state=lambda path, frame: None)

    monkeypatch.setattr(warp_st, "load", fake_load)
    monkeypatch.setattr(tasks, "load_scene", fake_load)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "shot.usda").write_text("#usda 1.0\n")
    (tmp_path / "bad.usda").write_text("#usda 1.0\n")
    return types.SimpleNamespace(path=tmp_path, frame_range=frame_range)


def test_render_default_frame_and_output(fake, capsys):
    """No --frame: the stage's start time code; no -o: <scene stem>.exr in the cwd."""
    code, out, err = run(capsys, "render", "shot.usda")
    assert code == 0, err
    assert FakeRenderer.instances[0].frames == [10.0]
    img = warp_st.read_exr(fake.path / "shot.exr")
    assert img.frame == 10.0 and img.id_manifest == {1: "/World/Mover"}
    assert img.metadata["stage"] == "shot.usda" and "commandLine" in img.metadata
    assert "frame 10" in out and "shot.exr" in out


def test_render_default_frame_without_range(fake, capsys):
    """A stage without startTimeCode renders time code 0."""
    fake.frame_range["value"] = None
    assert run(capsys, "render", "shot.usda")[0] == 0
    assert FakeRenderer.instances[0].frames == [0.0]


def test_render_frames_pattern_and_options(fake, capsys):
    """--frames builds the renderer once for all frames and writes one file per frame;
    command-line options reach the renderer (enums for precision / light speed)."""
    code, out, err = run(capsys, "render", "shot.usda", "--frames", "1-5x2", "--camera", "/World/Cam",
                         "--width", "32", "--height", "24", "--max-depth", "0", "--samples", "2",
                         "--shutter", "0.5", "--precision", "float64", "--light-speed", "infinite", "--quiet")
    assert code == 0, err
    assert out == "" and err == ""
    (renderer,) = FakeRenderer.instances
    assert renderer.frames == renderer.rendered == [1.0, 3.0, 5.0]
    assert renderer.options == dict(camera="/World/Cam", width=32, height=24, max_depth=0, samples=2,
                                    shutter=0.5, precision=warp_st.Precision.FLOAT64,
                                    light_speed=warp_st.LightSpeed.INFINITE)
    assert sorted(p.name for p in fake.path.glob("*.exr")) == ["shot.0001.exr", "shot.0003.exr", "shot.0005.exr"]
    assert warp_st.read_exr(fake.path / "shot.0003.exr").camera_time == 3.0


def test_render_printf_pattern_and_subdirectory(fake, capsys):
    (fake.path / "out").mkdir()
    code, _, err = run(capsys, "render", "shot.usda", "--frames", "2,4", "-o", "out/f_%03d.exr")
    assert code == 0, err
    assert sorted(p.name for p in (fake.path / "out").iterdir()) == ["f_002.exr", "f_004.exr"]


def test_several_frames_need_a_pattern(fake, capsys):
    """Two frames into one file name is bad input: exit 2, nothing rendered or written."""
    code, _, err = run(capsys, "render", "shot.usda", "--frames", "1-2", "-o", "single.exr")
    assert_usage_error(code, err, "frame pattern")
    assert FakeRenderer.instances == [] and not list(fake.path.glob("*.exr"))


def test_output_directory_missing(fake, capsys):
    code, _, err = run(capsys, "render", "shot.usda", "-o", "nowhere/f.exr")
    assert_usage_error(code, err, "nowhere")
    assert FakeRenderer.instances == []


def test_scene_error_exit_2_no_output(fake, capsys):
    """A SceneError from load or from the renderer's option check: exit 2, one line, no file,
    and an existing output is not touched."""
    code, _, err = run(capsys, "render", "bad.usda")
    assert_usage_error(code, err, "bad.usda", "fourVelocity")
    assert not list(fake.path.glob("*.exr"))

    (fake.path / "shot.exr").write_bytes(b"keep me")
    FakeRenderer.bad_option = True
    code, _, err = run(capsys, "render", "shot.usda", "--samples", "3")
    assert_usage_error(code, err, "spacetime:samples")
    assert (fake.path / "shot.exr").read_bytes() == b"keep me"


def test_missing_scene_exit_2(fake, capsys):
    code, _, err = run(capsys, "render", "absent.usda", "--frames", "0-2")
    assert_usage_error(code, err, "absent.usda")
    assert not list(fake.path.glob("*.exr"))


def test_resume_skips_complete_frames(fake, capsys):
    """--resume leaves complete outputs alone (mtime unchanged) and redoes broken ones."""
    assert run(capsys, "render", "shot.usda", "--frames", "0-2", "--quiet")[0] == 0
    done = fake.path / "shot.0000.exr"
    os.utime(done, (1_000_000_000, 1_000_000_000))
    broken = fake.path / "shot.0001.exr"
    broken.write_bytes(broken.read_bytes()[:100])
    (fake.path / "shot.0002.exr").unlink()
    FakeRenderer.instances = []
    code, out, err = run(capsys, "render", "shot.usda", "--frames", "0-2", "--resume")
    assert code == 0, err
    assert FakeRenderer.instances[0].frames == [1.0, 2.0]
    assert done.stat().st_mtime == 1_000_000_000
    assert "skipped" in out
    assert exr.is_complete_exr(broken) and exr.is_complete_exr(fake.path / "shot.0002.exr")

    FakeRenderer.instances = []
    code, out, _ = run(capsys, "render", "shot.usda", "--frames", "0-2", "--resume")
    assert code == 0 and FakeRenderer.instances == [] and "already complete" in out


def test_keyboard_interrupt_reports_complete_frames(fake, capsys):
    """^C: exit 130, the message names the frames already written; no partial file."""
    FakeRenderer.interrupt_at = 3.0
    code, out, err = run(capsys, "render", "shot.usda", "--frames", "0-5", "--quiet")
    assert code == 130
    assert "0-2" in err and "3 of 6" in err and "--resume" in err
    assert sorted(p.name for p in fake.path.glob("*.exr")) == ["shot.0000.exr", "shot.0001.exr", "shot.0002.exr"]
    assert not [p for p in fake.path.iterdir() if p.name.endswith(".tmp")]


def test_internal_error_exit_1(fake, capsys, monkeypatch):
    """An unexpected exception is exit 1 with one 'internal error' line (traceback only
    with WARP_ST_DEBUG)."""
    monkeypatch.delenv("WARP_ST_DEBUG", raising=False)

    def boom(self, frame):
        raise ZeroDivisionError("kaboom")

    monkeypatch.setattr(FakeRenderer, "render", boom)
    code, _, err = run(capsys, "render", "shot.usda")
    assert code == 1
    assert err.startswith("warp-st: internal error:") and "kaboom" in err and "Traceback" not in err
    monkeypatch.setenv("WARP_ST_DEBUG", "1")
    code, _, err = run(capsys, "render", "shot.usda")
    assert code == 1 and "Traceback" in err


# --- inspect --------------------------------------------------------------------


@pytest.fixture
def sample_exr(tmp_path):
    """A 6 x 4 EXR: body 1 (/World/Ship) on the left half, background on the right."""
    h, w = 4, 6
    rgba = np.zeros((h, w, 4), np.float32)
    rgba[:, :3] = (0.25, 0.5, 0.75, 1.0)
    hit = np.zeros((h, w), bool)
    hit[:, :3] = True
    origin = 1.0e9
    image = Image(
        rgba=rgba,
        depth=np.where(hit, 7.5, np.inf),
        event_time=np.where(hit, origin - 7.5, np.nan),
        proper_time=np.where(hit, 3.25, np.nan),
        doppler=np.where(hit, 1.5, np.nan),
        object_id=np.where(hit, 1, 0),
        source_time=np.where(hit, origin - 7.5, np.nan),
        camera_time=origin,
        frame=920,
        id_manifest={1: "/World/Ship"},
        metadata={"stage": "ship.usda"},
    )
    path = tmp_path / "sample.exr"
    exr.write_exr(image, path)
    return path


def test_inspect_header_and_stats(sample_exr, capsys):
    code, out, err = run(capsys, "inspect", str(sample_exr))
    assert code == 0, err
    assert "spacetime:timeOrigin: 1000000000.0" in out
    assert "spacetime:version: " + warp_st.__version__ in out
    assert "compression: ZIP_COMPRESSION" in out
    assert "1: /World/Ship" in out
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.startswith("  ") and len(line.split()) == 8}
    # channel type min max mean nan +inf -inf
    assert rows["Z"][1:] == ["FLOAT", "7.5", "7.5", "7.5", "0", "12", "0"]
    assert rows["spacetime.eventTime"][2:5] == ["999999992.5"] * 3
    assert rows["spacetime.doppler"][5] == "12"  # NaN on the 12 background pixels
    assert rows["objectId"][1:4] == ["UINT", "0", "1"]


def test_inspect_pixel(sample_exr, capsys):
    code, out, _ = run(capsys, "inspect", str(sample_exr), "--pixel", "1", "2")
    assert code == 0
    assert "/World/Ship" in out
    assert "999999992.5" in out and "relative -7.5" in out and "1.5" in out
    code, out, _ = run(capsys, "inspect", str(sample_exr), "--pixel", "5", "0")
    assert code == 0 and "background" in out


@pytest.mark.parametrize("pixel", [("6", "0"), ("0", "4"), ("-1", "0")])
def test_inspect_pixel_out_of_range(sample_exr, capsys, pixel):
    code, _, err = run(capsys, "inspect", str(sample_exr), "--pixel", *pixel)
    assert_usage_error(code, err, "outside")


def _pixels_of(png: Path, colour) -> np.ndarray:
    """Mask of the PNG's pixels within 1/255 of ``colour`` (matplotlib writes 8 bits)."""
    import matplotlib.image

    rgb = matplotlib.image.imread(png)[..., :3]
    return (np.abs(rgb - np.asarray(colour[:3])) <= 1.0 / 255).all(axis=-1)


def _check_false_colour_png(png: Path, cmap_name: str, value_at: float) -> None:
    """The sample's left half (its hits) in the colour map at ``value_at``, its right half
    (background) in grey, side by side and of equal size; and a colour bar right of them:
    the map's low end (only in the bar) below its high end, the middle between them."""
    import matplotlib

    cmap = matplotlib.colormaps[cmap_name]
    hits, grey = _pixels_of(png, cmap(value_at)), _pixels_of(png, (0.5, 0.5, 0.5))
    assert hits.shape[1] >= 500, hits.shape  # the picture alone is at least 5 inches at 100 dpi
    # a data pixel is tens of PNG pixels wide; the hit half and the background half match
    assert hits.sum() > 10000 and abs(int(hits.sum()) - int(grey.sum())) < 0.05 * grey.sum(), (hits.sum(), grey.sum())
    hit_cols, grey_cols = np.median(np.nonzero(hits)[1]), np.median(np.nonzero(grey)[1])
    assert hit_cols < grey_cols, "hits must be left of the background"
    # the bar's ends are drawn with an edge; 5% in from each end every map entry is ~1 row
    low, mid, high = (_pixels_of(png, cmap(x)) for x in (0.05, 0.5, 0.95))
    assert low.sum() > 10, "no colour bar (the map's low end is nowhere)"
    cols = np.nonzero(low)[1]
    assert cols.min() > grey_cols, "the colour bar must be right of the image"
    bar = slice(cols.min(), cols.max() + 1)  # the bar's columns (antialiased text elsewhere matches too)
    rows = [np.nonzero(m[:, bar])[0].mean() for m in (high, mid, low)]
    assert rows[0] < rows[1] < rows[2], rows  # image rows grow downwards: high on top


def test_inspect_png(sample_exr, tmp_path, capsys):
    """--channel NAME --png OUT.png writes a PNG (its signature) that shows the channel:
    Doppler 1.5 on the hits is the top of the RdBu log scale centred on 1 (the scale spans
    [1/1.5, 1.5]); eventTime, a single value t - t_c = -7.5, is the middle of viridis
    (the one value is widened to ±0.5); background grey; a colour bar in map order."""
    png = tmp_path / "doppler.png"
    code, _, err = run(capsys, "inspect", str(sample_exr), "--channel", "spacetime.doppler", "--png", str(png))
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    _check_false_colour_png(png, "RdBu", 1.0)
    png2 = tmp_path / "time.png"
    assert run(capsys, "inspect", str(sample_exr), "--channel", "spacetime.eventTime", "--png", str(png2))[0] == 0
    _check_false_colour_png(png2, "viridis", 0.5)


def test_inspect_bad_input(sample_exr, tmp_path, capsys):
    """Unknown channel, --png without --channel, unwritable PNG path, corrupt EXR: exit 2."""
    code, _, err = run(capsys, "inspect", str(sample_exr), "--channel", "spacetime.warp", "--png", "x.png")
    assert_usage_error(code, err, "unknown channel")
    code, _, err = run(capsys, "inspect", str(sample_exr), "--png", str(tmp_path / "x.png"))
    assert_usage_error(code, err, "--channel")
    code, _, err = run(capsys, "inspect", str(sample_exr), "--channel", "Z", "--png", str(tmp_path / "no" / "x.png"))
    assert_usage_error(code, err, "does not exist")
    assert not (tmp_path / "x.png").exists()
    bad = tmp_path / "bad.exr"
    bad.write_bytes(sample_exr.read_bytes()[:300])
    code, _, err = run(capsys, "inspect", str(bad))
    assert_usage_error(code, err, "bad.exr")
    code, _, err = run(capsys, "inspect", str(tmp_path / "missing.exr"))
    assert_usage_error(code, err, "missing.exr")


# --- validate (real USD reader) -----------------------------------------------------


def test_validate_bad_scene(tmp_path, capsys):
    """A coupled body at |v| = 1.5 is bad input: exit 2, one line naming the file."""
    path = tmp_path / "ftl.usda"
    path.write_text(BAD_SCENE)
    code, _, err = run(capsys, "validate", str(path))
    assert_usage_error(code, err, "ftl.usda")


def test_validate_good_scene(tmp_path, capsys):
    path = tmp_path / "tiny.usda"
    path.write_text(TINY_SCENE)
    code, out, err = run(capsys, "validate", str(path))
    assert code == 0, err
    assert out.strip() == f"{path}: ok: 0 errors, 0 warnings; 1 bodies, 1 cameras, 1 lights"


def test_validate_missing_file(tmp_path, capsys):
    code, _, err = run(capsys, "validate", str(tmp_path / "none.usda"))
    assert_usage_error(code, err, "none.usda")


# --- render with the real renderer ----------------------------------------------------


@pytest.fixture
def tiny_scene(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "tiny.usda"
    path.write_text(TINY_SCENE)
    return path


def test_real_render_three_frames(tiny_scene, capsys):
    """real renderer: --frames 0-2 at 32 x 24 makes three complete EXRs with SPEC channels."""
    code, out, err = run(capsys, "render", str(tiny_scene), "-o", "OUT.####.exr", "--frames", "0-2",
                         "--width", "32", "--height", "24", "--quiet")
    assert code == 0, err
    names = sorted(p.name for p in tiny_scene.parent.glob("OUT.*.exr"))
    assert names == ["OUT.0000.exr", "OUT.0001.exr", "OUT.0002.exr"]
    for i, name in enumerate(names):
        img = warp_st.read_exr(tiny_scene.parent / name)
        assert (img.width, img.height) == (32, 24)
        assert img.frame == float(i)
        assert img.id_manifest == {1: "/World/Mover"}


def test_real_render_missing_scene(tmp_path, monkeypatch, capsys):
    """real renderer: a missing scene is exit 2 and writes nothing."""
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "render", "absent.usda", "-o", "OUT.####.exr", "--frames", "0-2")
    assert_usage_error(code, err, "absent.usda")
    assert list(tmp_path.iterdir()) == []


def test_real_render_resume(tiny_scene, capsys):
    """real renderer: --resume keeps a complete frame (mtime unchanged) and renders the rest."""
    args = ["render", str(tiny_scene), "-o", "OUT.####.exr", "--width", "32", "--height", "24", "--quiet"]
    assert run(capsys, *args, "--frames", "0")[0] == 0
    first = tiny_scene.parent / "OUT.0000.exr"
    os.utime(first, (1_000_000_000, 1_000_000_000))
    code, _, err = run(capsys, *args, "--frames", "0-1", "--resume")
    assert code == 0, err
    assert first.stat().st_mtime == 1_000_000_000
    assert exr.is_complete_exr(tiny_scene.parent / "OUT.0001.exr")


def test_progress_bar_on_a_terminal(fake, capsys, monkeypatch):
    """On a terminal the frames get a tqdm bar on stderr instead of per-frame lines."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    code, out, err = run(capsys, "render", "shot.usda", "--frames", "0-1")
    assert code == 0, err
    assert "frame 0:" not in out and "2/2" in err
