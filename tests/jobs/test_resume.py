"""``--resume`` keeps only what this run would write (issue 15, Deliver 5).

Law: a frame's file is kept only when it is a complete EXR whose ``spacetime:run`` record
equals the current run's: software version, stage file (its sha256), every option that
changes pixels, frame and channel set. Anything else is rendered again, and a ``stale``
log record (and a stderr line) names the field that differs. Options that never change a
pixel (the memory limit) and the command line's own text do not count.

Every check goes through the real command line (``warp_st.commands.cli.main``) or the
Python API ``render_sequence``, at 16 x 12 pixels. No numeric tolerances: what is compared
is exact (file bytes, mtimes, image sizes, header text, log records).
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import OpenEXR
import pytest

import warp_st
from warp_st.commands.cli import main
from warp_st.jobs import farm, sequence
from warp_st.jobs.tasks import run_task
from warp_st.output import exr, plan
from warp_st.output.film import OutputChannel
from warp_st.output.plan import FrameJob, Output

#: Two cameras (the stage's own is the first), a sphere, a light: the smallest stage in
#: which every field of the run record can be made to differ.
STAGE = """#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 2
)

def Xform "World"
{
    def Camera "CamA"
    {
        double3 xformOp:translate = (0, 0, 8)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def Camera "CamB"
    {
        double3 xformOp:translate = (1, 0, 8)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def Sphere "Ball" (
        prepend apiSchemas = ["SpacetimeBodyAPI"]
    )
    {
        double radius = 1
        custom double4 spacetime:fourVelocity = (1, 0.3, 0, 0)
    }

    def DistantLight "Sun"
    {
        float inputs:angle = 0
        float inputs:intensity = 3.1415927
    }
}
"""

SIZE = ["--width", "16", "--height", "12"]
PATTERN = "f.####.exr"


@pytest.fixture
def folder(tmp_path, monkeypatch):
    (tmp_path / "s.usda").write_text(STAGE)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def render(*extra: str, frames: str = "0-1") -> int:
    return main(["render", "s.usda", "--frames", frames, "-o", PATTERN, "--quiet", *extra])


def records(path: Path = Path("run.jsonl")) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def frame_status(log: list[dict]) -> dict[float, str]:
    return {r["frame"]: r["status"] for r in log if r["event"] == "frame"}


def stale(log: list[dict]) -> dict[float, str]:
    return {r["frame"]: r["reason"] for r in log if r["event"] == "stale"}


def run_record(path) -> dict:
    return json.loads(warp_st.read_exr(path).metadata["run"])


def forge(path: Path, change) -> None:
    """Write ``path`` again after ``change(header, planes)`` (a forged file)."""
    with OpenEXR.File(str(path), separate_channels=True) as f:
        header = dict(f.header())
        planes = {name: ch.pixels.copy() for name, ch in f.channels().items()}
    change(header, planes)
    OpenEXR.File(header, planes).write(str(path))


def test_resolution_issue_scenario(folder):
    """The issue's case: frames 0-1 at 16x12, then 0-2 at 24x18 with --resume: nothing stays
    at 16x12, and the log says the width and height differ."""
    assert render(*SIZE) == 0
    assert render("--width", "24", "--height", "18", "--resume", "--log", "run.jsonl", frames="0-2") == 0
    log = records()
    assert frame_status(log) == {0.0: "rendered", 1.0: "rendered", 2.0: "rendered"}
    for frame in (0.0, 1.0):
        assert "height: file 12, this run 18" in stale(log)[frame]
        assert "width: file 16, this run 24" in stale(log)[frame]
    assert 2.0 not in stale(log)  # a missing file needs no reason
    for f in range(3):
        image = warp_st.read_exr(folder / f"f.{f:04d}.exr")
        assert (image.width, image.height) == (24, 18)


@pytest.mark.parametrize("option, field", [
    (["--samples", "2"], "samples"),
    (["--camera", "/World/CamB"], "camera"),
    (["--max-depth", "1"], "max_depth"),
    (["--light-speed", "infinite"], "light_speed"),
    (["--doppler-color"], "doppler_color"),
    (["--no-references"], "noReferences"),
])
def test_an_option_that_changes_pixels(folder, capsys, option, field):
    """A frame written without the option is rendered again when the option is given; the
    stale record and the stderr line name the option."""
    assert render(*SIZE) == 0
    assert render(*SIZE, *option, "--resume", "--log", "run.jsonl") == 0
    log = records()
    assert frame_status(log) == {0.0: "rendered", 1.0: "rendered"}
    assert set(stale(log)) == {0.0, 1.0}
    assert all(f"{field}: file " in reason for reason in stale(log).values()), stale(log)
    assert capsys.readouterr().err == ""  # --quiet: no stale lines either
    assert render(*SIZE, *option, "--resume", "--log", "again.jsonl") == 0  # now they match
    assert set(frame_status(records(Path("again.jsonl"))).values()) == {"skipped"}


def test_the_stale_line_on_stderr(folder, capsys):
    """Without --quiet the reason is one stderr line per frame."""
    assert render(*SIZE, frames="0") == 0
    assert main(["render", "s.usda", "--frames", "0", "-o", PATTERN, *SIZE, "--samples", "2", "--resume"]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert lines == [("warp-st: frame 0: rendering again: f.0000.exr: written by another run "
                      "(samples: file the stage's own, this run 2)")], lines


def test_stage_changed(folder):
    """An edited stage (another sha256) makes every frame stale, whatever the options."""
    assert render(*SIZE) == 0
    before = run_record(folder / "f.0000.exr")["stage"]
    (folder / "s.usda").write_text(STAGE.replace("double radius = 1", "double radius = 1.5"))
    assert render(*SIZE, "--resume", "--log", "run.jsonl") == 0
    log = records()
    assert frame_status(log) == {0.0: "rendered", 1.0: "rendered"}
    assert all(f'stage: file "{before}", this run "sha256:' in r for r in stale(log).values()), stale(log)
    assert run_record(folder / "f.0000.exr")["stage"] != before


def test_matching_frames_are_kept_untouched(folder):
    """Same run (another command line text, another --max-memory): the files keep their
    bytes and mtime; only the missing frame is rendered."""
    assert render(*SIZE) == 0
    kept = {f: (folder / f"f.{f:04d}.exr") for f in (0, 1)}
    before = {f: (p.read_bytes(), p.stat().st_mtime_ns) for f, p in kept.items()}
    assert render(*SIZE, "--max-memory", "4G", "--resume", "--log", "run.jsonl", frames="0-2") == 0
    log = records()
    assert frame_status(log) == {0.0: "skipped", 1.0: "skipped", 2.0: "rendered"} and stale(log) == {}
    assert {f: (p.read_bytes(), p.stat().st_mtime_ns) for f, p in kept.items()} == before
    assert run_record(folder / "f.0002.exr") == {**run_record(kept[0]), "frame": 2.0}


def test_float64_frames_are_kept(folder):
    """A float64 run's files hold its time residuals (spacetime.eventTimeLow, ...): they are
    what that run writes, so the same run keeps them."""
    assert render(*SIZE, "--precision", "float64") == 0
    kept = folder / "f.0000.exr"
    assert "spacetime.eventTimeLow" in exr.read_file(kept)["extra"]
    before = (kept.read_bytes(), kept.stat().st_mtime_ns)
    assert render(*SIZE, "--precision", "float64", "--resume", "--log", "run.jsonl") == 0
    log = records()
    assert set(frame_status(log).values()) == {"skipped"} and stale(log) == {}
    assert (kept.read_bytes(), kept.stat().st_mtime_ns) == before


def test_version_forged(folder):
    """A file whose record names another software version is rendered again; so is one
    without a record (an older version or another tool)."""
    assert render(*SIZE) == 0

    def other_version(header, planes):
        record = json.loads(header[exr.ATTR_RUN])
        header[exr.ATTR_RUN] = json.dumps({**record, "version": "0.0.1"})

    forge(folder / "f.0000.exr", other_version)
    forge(folder / "f.0001.exr", lambda header, planes: header.pop(exr.ATTR_RUN))
    assert render(*SIZE, "--resume", "--log", "run.jsonl") == 0
    log = records()
    assert frame_status(log) == {0.0: "rendered", 1.0: "rendered"}
    assert f'version: file "0.0.1", this run "{warp_st.__version__}"' in stale(log)[0.0]
    assert "has no spacetime:run record" in stale(log)[1.0]


def test_frame_forged(folder):
    """A file holding another frame's record (renamed by hand) is not that frame."""
    assert render(*SIZE) == 0
    (folder / "f.0001.exr").replace(folder / "f.0000.exr")
    assert render(*SIZE, "--resume", "--log", "run.jsonl", frames="0") == 0
    assert "frame: file 1.0, this run 0.0" in stale(records())[0.0]


def _jobs(folder: Path, channels) -> list[FrameJob]:
    return [FrameJob(float(f), (Output(folder / f"p.{f:04d}.exr", channels),)) for f in (0, 1)]


RGBA = tuple(OutputChannel(c, c) for c in "RGBA")
RGBA_HALF = tuple(OutputChannel(c, c, True) for c in "RGBA")


def api(folder: Path, jobs, **kw):
    log: list[dict] = []
    result = warp_st.render_sequence(str(folder / "s.usda"), output=jobs, workers=0, resume=True, log=log.append,
                                     progress=False, width=16, height=12, **kw)
    return result, log


def test_channel_set(folder):
    """Python API, same stage and options: files of another channel set are rendered again,
    whether names differ (all channels asked, RGBA written) or only the storage (HALF)."""
    api(folder, _jobs(folder, RGBA))
    result, log = api(folder, _jobs(folder, None))
    assert result.rendered == [0.0, 1.0]
    assert all("lacks the channel(s) Z" in r for r in stale(log).values()), stale(log)

    api(folder, _jobs(folder, RGBA))
    result, log = api(folder, _jobs(folder, RGBA_HALF))
    assert result.rendered == [0.0, 1.0]
    assert all('channels: file [["R", "R", false]' in r for r in stale(log).values()), stale(log)
    result, log = api(folder, _jobs(folder, RGBA_HALF))
    assert result.skipped == [0.0, 1.0] and stale(log) == {}


def test_extra_channels_forged(folder):
    """A file holding more channels than its record names is not this run's file."""
    api(folder, _jobs(folder, RGBA))
    forge(folder / "p.0000.exr", lambda header, planes: planes.update(extra=planes["R"].copy()))
    result, log = api(folder, _jobs(folder, RGBA))
    assert result.rendered == [0.0] and result.skipped == [1.0]
    assert "holds other channels (extra)" in stale(log)[0.0]


def test_scene_in_memory_is_never_trusted(folder):
    """A Scene has no file to hash: resume renders every frame again and says why."""
    scene = warp_st.load(folder / "s.usda")
    jobs = _jobs(folder, None)
    warp_st.render_sequence(scene, output=jobs, workers=0, progress=False, width=16, height=12)
    log: list[dict] = []
    result = warp_st.render_sequence(scene, output=jobs, workers=0, resume=True, log=log.append, progress=False,
                                     width=16, height=12)
    assert result.rendered == [0.0, 1.0]
    assert all("held in memory" in r for r in stale(log).values()), stale(log)


def test_farm_worker_of_another_version_is_recovered(folder, monkeypatch):
    """The planner checks every farm frame against its own run record: a frame written by
    a worker running another version is rendered again here ("recovered")."""

    def other_worker(tasks, scene, *, workers, scheduler, done):
        with monkeypatch.context() as m:
            m.setattr(plan, "__version__", "9.9.9")  # that worker's software
            for i, task in enumerate(tasks):
                done(i, *run_task(replace(task, cwd=None), scene))
        return workers

    monkeypatch.setattr(farm, "run", other_worker)
    log: list[dict] = []
    jobs = _jobs(folder, None)
    result = sequence.render_sequence(str(folder / "s.usda"), output=jobs, workers=2, log=log.append,
                                      progress=False, width=16, height=12)
    assert [f.status for f in result.frames] == ["recovered", "recovered"]
    assert run_record(jobs[0].outputs[0].path)["version"] == warp_st.__version__


def test_an_image_written_again_is_no_runs_output(folder):
    """A frame read back and written again (edited, say) loses its run record, so resume
    renders it again rather than trust the edit."""
    assert render(*SIZE, frames="0") == 0
    path = folder / "f.0000.exr"
    assert exr.ATTR_RUN in exr.read_header(path)
    warp_st.read_exr(path).write_exr(path)
    assert exr.ATTR_RUN not in exr.read_header(path)
    assert render(*SIZE, "--resume", "--log", "run.jsonl", frames="0") == 0
    assert "has no spacetime:run record" in stale(records())[0.0]
