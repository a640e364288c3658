"""Sequences on Dask workers (warp_st.jobs.farm): the same bytes as one process, no frame lost to
a killed worker, ^C then --resume through the command line; and the engine's final check,
which renders here whatever a farm did not deliver.

Each LocalCluster costs a second or two of start-up (worker processes importing Warp and
USD); the file starts three, and two command lines start their own (about 15 s in all).
"""
import logging
import os
import signal
import sys
from pathlib import Path

import distributed
import pytest
from cli_helpers import no_temp_files, resume_renders_the_rest, signal_after

import warp_st
from warp_st.jobs import farm
from warp_st.jobs.tasks import run_task
from warp_st.output import exr

ROOT = Path(__file__).resolve().parents[2]
PARADE = ROOT / "usd_scenes" / "relativistic_parade.usda"
sys.path.insert(0, str(ROOT / "examples"))  # before any worker starts: they import sweep_beta by name
import sweep_beta  # noqa: E402

FRAMES = list(range(20))
SIZE = dict(width=64, height=36)


def _files(folder: Path, prefix: str) -> dict[str, bytes]:
    return {p.name[len(prefix):]: p.read_bytes() for p in sorted(folder.glob(prefix + ".*.exr"))}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The 20 frames rendered in this process: {".0000.exr": bytes, ...}."""
    folder = tmp_path_factory.mktemp("reference")
    warp_st.render_sequence(str(PARADE), FRAMES, str(folder / "ref.####.exr"), workers=0, progress=False, **SIZE)
    files = _files(folder, "ref")
    assert len(files) == 20
    return files


def test_local_cluster_of_two_matches_one_process(reference, tmp_path):
    """A LocalCluster of 2 workers writes the 20 frames byte for byte as this process does;
    each worker builds its renderer once and both render frames."""
    records = []
    result = warp_st.render_sequence(str(PARADE), FRAMES, str(tmp_path / "farm.####.exr"), workers=2,
                                     log=records.append, progress=False, **SIZE)
    assert result.workers == 2 and result.rendered == [float(f) for f in FRAMES]
    assert _files(tmp_path, "farm") == reference
    builds = [r["worker"] for r in records if r["event"] == "build"]
    frames = [r for r in records if r["event"] == "frame"]
    assert len(builds) == len(set(builds)) == 2
    assert {r["worker"] for r in frames} == set(builds) and all(r["status"] == "rendered" for r in frames)
    assert sorted(r["frame"] for r in frames) == [float(f) for f in FRAMES]


def _executing(dask_worker) -> list:
    """Keys of the tasks a worker is running now (for client.run)."""
    return [ts.key for ts in dask_worker.state.executing]


def test_sweep_on_workers_matches_this_process():
    """sweep on a LocalCluster of 2: each value made and measured on a worker, the same
    measurements (hit pixels per objectId) as in this process, in the order of the values."""
    import numpy as np

    def hits(image):
        return {int(k): int(n) for k, n in zip(*np.unique(image.object_id, return_counts=True))}

    kw = dict(frame=0, width=512, height=2, measure=hits, progress=False)
    values = [0.1, 0.5, 0.9, 0.99]
    here = warp_st.sweep(sweep_beta.make_scene, values, workers=0, **kw)
    there = warp_st.sweep(sweep_beta.make_scene, values, workers=2, **kw)
    assert there.workers == 2 and there.values == values and there.results == here.results
    assert {f.worker for f in there.frames} != {"local"}


def test_killed_worker_loses_no_frame(reference, tmp_path):
    """SIGKILL one of 2 workers (of a cluster reached by its scheduler address) while it
    renders: Dask hands its frames to the others, every frame is reported once and every
    file is complete and byte-identical to one process's."""
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, memory_limit=0,
                                       dashboard_address=None, silence_logs=logging.CRITICAL)
    client = distributed.Client(cluster, set_as_default=False)
    killed = {}
    records = []

    def log(record):
        records.append(record)
        if killed or record["event"] != "frame" or len(records) < 4:
            return
        busy = [w for w, keys in client.run(_executing).items() if keys]
        if busy:
            pid = client.run(os.getpid, workers=busy[:1])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.update(worker=busy[0], pid=pid, at=len(records))

    try:
        result = warp_st.render_sequence(str(PARADE), FRAMES, str(tmp_path / "farm.####.exr"),
                                         scheduler=cluster.scheduler_address, log=log, progress=False, **SIZE)
        assert killed, "no worker was busy when the test tried to kill one"
        alive = set(client.nthreads())
    finally:
        client.close()
        cluster.close()
    assert killed["worker"] not in alive  # it really died (its restart has a new address)
    frames = [r for r in records if r["event"] == "frame"]
    assert sorted(r["frame"] for r in frames) == [float(f) for f in FRAMES]  # each exactly once
    assert any(r["event"] == "frame" for r in records[killed["at"]:])  # frames went on after the kill
    assert result.rendered == [float(f) for f in FRAMES]
    assert _files(tmp_path, "farm") == reference
    leftovers = [p.name for p in tmp_path.iterdir() if not p.name.startswith("farm.")]
    assert all(n.endswith(f".{killed['pid']}.tmp") for n in leftovers), leftovers  # only the victim's temp


def test_frames_a_farm_does_not_deliver_are_rendered_here(reference, tmp_path, monkeypatch):
    """If the farm reports only some frames (KilledWorker) or its files are not visible here,
    the engine renders those frames in this process ("recovered"): all complete, same bytes."""

    def lossy_run(tasks, scene, *, workers, scheduler, done):
        for i, task in enumerate(tasks):
            if i % 3 == 0:
                continue  # lost with its worker
            done(i, *run_task(task, scene, worker="fake"))
            if i % 3 == 1:
                os.unlink(Path(task.cwd) / task.job.outputs[0].path)  # written where we cannot see it
        return 2

    monkeypatch.setattr(farm, "run", lossy_run)
    records = []
    result = warp_st.render_sequence(str(PARADE), FRAMES, str(tmp_path / "farm.####.exr"), workers=2,
                                     log=records.append, progress=False, **SIZE)
    statuses = {r["frame"]: r["status"] for r in records if r["event"] == "frame" and r["worker"] == "local"}
    assert sorted(statuses) == [float(f) for f in FRAMES if f % 3 != 2]
    assert set(statuses.values()) == {"recovered"}
    assert {f.frame for f in result.frames if f.status == "recovered"} == set(statuses)
    assert _files(tmp_path, "farm") == reference


def test_default_workers_rule(monkeypatch):
    """workers=None: this process up to LOCAL_FRAMES frames or below MIN_CORES cores, else one per core."""
    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    assert farm.default_workers(farm.LOCAL_FRAMES) == 0 and farm.default_workers(farm.LOCAL_FRAMES + 1) == 8
    monkeypatch.setattr(os, "cpu_count", lambda: farm.MIN_CORES - 1)
    assert farm.default_workers(1000) == 0


def _frames_in(label: str) -> list[int]:
    """Frames of a frames_label text such as "0-2, 5"."""
    frames = []
    for part in label.split(", "):
        first, _, last = part.partition("-")
        frames.extend(range(int(first), int(last or first) + 1))
    return frames


#: Frames of the interrupted farm run.
FARM_FRAMES = 60


def test_cli_interrupt_then_resume_on_workers(tmp_path):
    """warp-st render --workers 2: SIGINT after the first file stops with exit 130 and one
    line naming complete frames (the frames the workers hold are finished: no temporary
    file is left); --resume then renders exactly the missing frames. FARM_FRAMES frames of
    96 x 54 take two workers well over a second, so the signal arrives mid-run even on a
    loaded machine (40 once finished first there)."""
    argv = [sys.executable, "-m", "warp_st", "render", str(PARADE), "-o", "seq.####.exr",
            "--frames", f"0-{FARM_FRAMES - 1}",
            "--width", "96", "--height", "54", "--workers", "2"]
    code, err = signal_after(argv, tmp_path, lambda: bool(list(tmp_path.glob("seq.*.exr"))), signal.SIGINT)
    assert code == 130, err
    (line,) = err.splitlines()
    assert line.startswith("warp-st: interrupted; frames complete: ") and "--resume" in line, line
    listed = _frames_in(line.split("frames complete: ")[1].split(" (")[0])
    written = sorted(tmp_path.glob("seq.*.exr"))
    assert 1 <= len(written) < FARM_FRAMES, "SIGINT came too late to test anything"
    assert all(exr.is_complete_exr(p) for p in written)
    # Every frame the message names is complete (a worker may have started one more in the
    # instant between the interrupt and the cancel: it is complete but not named).
    assert listed and {f"seq.{f:04d}.exr" for f in listed} <= {p.name for p in written}
    assert f"({len(listed)} of {FARM_FRAMES})" in line
    no_temp_files(tmp_path)
    before = {p.name: p.read_bytes() for p in written}
    resume_renders_the_rest(argv, tmp_path, before, FARM_FRAMES)
