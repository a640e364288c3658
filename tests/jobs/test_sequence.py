"""The sequence engine in this process (warp_st.jobs.sequence): one renderer per sequence, every
frame written and equal to a direct render, one JSON record per frame, the progress bar only
on a terminal, --resume, interruption, sweeps; and the command line's --log."""
import hashlib
import importlib.util
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

import warp_st
from warp_st.commands import cli
from warp_st.jobs import tasks
from warp_st.output import exr
from warp_st.rendering.renderer import Renderer

ROOT = Path(__file__).resolve().parents[2]
PARADE = ROOT / "usd_scenes" / "relativistic_parade.usda"
SIZE = dict(width=48, height=27)
FRAME_KEYS = {"event", "frame", "status", "files", "seconds", "rays", "mrays_per_s", "worker", "time"}


def _example(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


sweep_beta = _example("sweep_beta")  # its make_scene: two rods moving at beta


def _same_image(a, b) -> bool:
    return all(np.array_equal(a.channel(n), b.channel(n), equal_nan=True) for n in exr.CHANNEL_NAMES)


def _frames(records, status=None):
    return [r for r in records if r["event"] == "frame" and (status is None or r["status"] == status)]


def test_sequence_builds_once_and_each_frame_equals_a_direct_render(tmp_path):
    """Four frames: one build record, one frame record per frame in order, each file equal
    (every channel, bit for bit) to Renderer(all frames).render(frame); the header names the
    stage as given and its sha256."""
    records = []
    frames = [0.0, 1.0, 2.0, 3.0]
    result = warp_st.render_sequence(str(PARADE), frames, str(tmp_path / "f.####.exr"), workers=0,
                                     log=records.append, progress=False, **SIZE)
    assert [r["event"] for r in records] == ["build"] + ["frame"] * 4
    assert result.rendered == frames and result.skipped == [] and result.workers == 0
    direct = Renderer(warp_st.load(str(PARADE)), frames=frames, **SIZE)
    digest = "sha256:" + hashlib.sha256(PARADE.read_bytes()).hexdigest()
    for frame, record in zip(frames, _frames(records)):
        assert set(record) == FRAME_KEYS
        path = tmp_path / f"f.{int(frame):04d}.exr"
        assert record["frame"] == frame and record["status"] == "rendered" and record["worker"] == "local"
        assert record["files"] == [str(path)]
        assert record["rays"] == 48 * 27  # one sample per pixel
        assert record["mrays_per_s"] == pytest.approx(record["rays"] / record["seconds"] / 1e6, rel=0.02)
        image = warp_st.read_exr(path)
        assert _same_image(image, direct.render(frame))
        assert image.metadata["stage"] == str(PARADE) and image.metadata["stageHash"] == digest
    assert tasks._RENDERER == {}  # the database is released when the call returns


def test_json_log_file_appends_and_resume_skips(tmp_path):
    """log=PATH appends JSON lines; with resume the complete frames are skipped (their files
    untouched) and only the missing ones are rendered, by a renderer built for them."""
    log = tmp_path / "run.jsonl"
    pattern = str(tmp_path / "f.####.exr")
    warp_st.render_sequence(str(PARADE), [0, 1], pattern, workers=0, log=log, progress=False, **SIZE)
    first = tmp_path / "f.0000.exr"
    os.utime(first, (1_000_000_000, 1_000_000_000))
    result = warp_st.render_sequence(str(PARADE), [0, 1, 2], pattern, workers=0, resume=True, log=log,
                                     progress=False, **SIZE)
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert [(r["event"], r.get("status")) for r in lines] == [
        ("build", None), ("frame", "rendered"), ("frame", "rendered"),
        ("frame", "skipped"), ("frame", "skipped"), ("build", None), ("frame", "rendered")]
    assert result.skipped == [0.0, 1.0] and result.rendered == [2.0]
    assert first.stat().st_mtime == 1_000_000_000
    assert exr.is_complete_exr(tmp_path / "f.0002.exr")


def test_progress_bar_only_on_a_terminal(tmp_path, capsys, monkeypatch):
    """Not a terminal: nothing on stderr. A terminal: a tqdm bar with the frame count and Mrays/s."""
    kw = dict(workers=0, **SIZE)
    warp_st.render_sequence(str(PARADE), [0, 1], str(tmp_path / "a.####.exr"), **kw)
    assert capsys.readouterr() == ("", "")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    warp_st.render_sequence(str(PARADE), [0, 1], str(tmp_path / "b.####.exr"), **kw)
    out, err = capsys.readouterr()
    assert out == "" and "2/2" in err and "Mrays/s" in err
    warp_st.render_sequence(str(PARADE), [0, 1], str(tmp_path / "c.####.exr"), progress=False, **kw)
    assert capsys.readouterr() == ("", "")


def test_interrupt_leaves_only_complete_files(tmp_path):
    """^C during the third frame's report: the two written frames are complete, nothing else
    (no temporary file) is left, and the renderer is released."""

    def log(record):
        if record["event"] == "frame" and record["frame"] == 2.0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        warp_st.render_sequence(str(PARADE), range(5), str(tmp_path / "f.####.exr"), workers=0, log=log,
                                progress=False, **SIZE)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["f.0000.exr", "f.0001.exr", "f.0002.exr"]
    assert all(exr.is_complete_exr(tmp_path / n) for n in names)
    assert tasks._RENDERER == {}


def test_sweep_renders_each_value_from_its_own_scene(tmp_path):
    """sweep: one build per value, files named by {value}, measure applied where the image
    was rendered; the measurement equals that of a direct render of make_scene(value), and
    without measure the images come back."""
    values = [0.2, 0.9]
    records = []

    def hits(image):
        return {int(k): int(n) for k, n in zip(*np.unique(image.object_id, return_counts=True))}

    kw = dict(frame=0, width=256, height=4)
    result = warp_st.sweep(sweep_beta.make_scene, values, output=str(tmp_path / "rods_{value:.1f}.exr"),
                           measure=hits, workers=0, log=records.append, progress=False, **kw)
    assert [r["event"] for r in records] == ["build", "frame"] * 2
    assert [r["value"] for r in _frames(records)] == values
    assert result.values == values
    for value, measured in zip(values, result.results):
        direct = warp_st.render(warp_st.load(sweep_beta.make_scene(value)), **kw)
        assert measured == hits(direct) and set(measured) == {0, 1, 2}
        assert _same_image(warp_st.read_exr(tmp_path / f"rods_{value:.1f}.exr"), direct)
    images = warp_st.sweep(sweep_beta.make_scene, values, workers=0, progress=False, **kw).results
    assert [hits(im) for im in images] == result.results


def test_cli_log_stdout_and_file(tmp_path, monkeypatch, capsys):
    """--log - prints only JSON lines on stdout; --log FILE appends them and keeps the usual lines."""
    monkeypatch.chdir(tmp_path)
    argv = ["render", str(PARADE), "-o", "f.####.exr", "--frames", "0-1", "--width", "32", "--height", "18"]
    assert cli.main(argv + ["--log", "-"]) == 0
    out, err = capsys.readouterr()
    lines = [json.loads(line) for line in out.splitlines()]
    assert [r["event"] for r in lines] == ["build", "frame", "frame"] and err == ""
    assert cli.main(argv + ["--resume", "--log", "run.jsonl"]) == 0
    out, _ = capsys.readouterr()
    assert out.count("complete, skipped") == 2 and "already complete" in out
    logged = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()]
    assert [r["status"] for r in logged] == ["skipped", "skipped"]


@pytest.mark.parametrize("extra, needle", [
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not allowed"),
    (["--log", "nowhere/run.jsonl"], "nowhere"),
    (["--workers", "-1"], "--workers"),
    (["--camera", "/Nope", "--log", "run.jsonl"], "/Nope"),
])
def test_cli_farm_and_log_bad_input(tmp_path, monkeypatch, capsys, extra, needle):
    """Bad farm / log options, or a bad option with a log: exit 2, one line naming the
    problem, nothing written (not even the log)."""
    monkeypatch.chdir(tmp_path)
    code = cli.main(["render", str(PARADE), "-o", "f.####.exr", "--frames", "0-1", *extra])
    _, err = capsys.readouterr()
    assert code == 2 and err.startswith("warp-st: error:") and needle in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []
