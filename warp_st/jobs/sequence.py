"""Many frames, or many scenes, through one engine: the command line, Dask farms and sweeps.

:func:`render_sequence` renders frames of one stage to files; :func:`sweep` renders one
frame of a scene per parameter value. Both cut the work into tasks (a frame and the files
it writes) that :func:`run_task` renders, in this process or on Dask workers
(:mod:`warp_st.jobs.farm`). A process builds its :class:`~warp_st.rendering.renderer.Renderer` (extrusion
and 4D BVH) once and keeps it for every task of the same stage, frames and options. The
renderer is always built for the whole list of frames to render, and the EXR metadata comes
from the caller, so a frame's bytes do not depend on which process rendered it.

Reporting: a tqdm bar on stderr (frames, ETA, Mrays/s) when stderr is a terminal, and one
record per finished frame (:meth:`FrameResult.record`) to ``log``: a callable, a text file
or a path (JSON lines, appended). A process that builds a renderer adds a ``build`` record.
"""
from __future__ import annotations

import json
import os
import sys
import time
import uuid
from dataclasses import dataclass, replace
from pathlib import Path

from warp_st.core.scene import Scene
from warp_st.jobs import farm
from warp_st.jobs.tasks import FrameResult, StageFile, _Generated, _InMemory, _Task, forget_renderer, run_task
from warp_st.output.plan import FrameJob, Output, check_jobs, job_complete, plan_pattern, resume_check, run_identity
from warp_st.usd.reader import load_scene

__all__ = ["StageFile", "FrameResult", "SequenceResult", "SweepResult", "render_sequence", "sweep"]


@dataclass
class SequenceResult:
    """frames: one entry per planned frame, in plan order. seconds: wall time of the call.
    workers: Dask worker processes used (0: rendered in this process)."""

    frames: list[FrameResult]
    seconds: float
    workers: int = 0

    @property
    def rendered(self) -> list[float]:
        return [f.frame for f in self.frames if f.status != "skipped"]

    @property
    def skipped(self) -> list[float]:
        return [f.frame for f in self.frames if f.status == "skipped"]

    @property
    def files(self) -> list[str]:
        return [name for f in self.frames for name in f.files]

    @property
    def mrays_per_s(self) -> float:
        """Camera rays of the rendered frames per second of wall time."""
        rays = sum(f.rays for f in self.frames if f.status != "skipped")
        return rays / self.seconds / 1e6 if self.seconds > 0 else 0.0


@dataclass
class SweepResult:
    """values and, per value, ``measure(image)`` (or the Image when no measure was given)."""

    values: list
    results: list
    frames: list[FrameResult]
    seconds: float
    workers: int = 0


# --- the task, wherever it runs ------------------------------------------------------------

class _Report:
    """The progress bar and the log sink of one call."""

    def __init__(self, total: int, progress: bool, log, unit: str):
        self.total, self.unit = total, unit
        self.use_bar = bool(progress) and total > 0 and sys.stderr.isatty()
        self.bar = None
        self.rays = 0
        self.start = time.perf_counter()
        self._close = None
        if log is None or callable(log):
            self.sink = log
        else:
            fh = log if hasattr(log, "write") else open(log, "a", encoding="utf-8")
            self._close = None if fh is log else fh

            def sink(record, fh=fh):
                fh.write(json.dumps(record) + "\n")
                fh.flush()

            self.sink = sink

    def open_bar(self) -> None:
        if self.use_bar and self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, unit=self.unit, file=sys.stderr, dynamic_ncols=True)

    def emit(self, record: dict) -> None:
        if self.sink is None:
            return
        if self.bar is None:
            self.sink(record)
            return
        from tqdm import tqdm

        with tqdm.external_write_mode(file=sys.stdout):
            self.sink(record)

    def frame(self, result: FrameResult) -> None:
        if result.status != "skipped":
            self.open_bar()
            if self.bar is not None:
                from warp_st.core.frames import frame_label

                self.rays += result.rays
                rate = self.rays / max(time.perf_counter() - self.start, 1e-9) / 1e6
                self.bar.set_postfix_str(f"frame {frame_label(result.frame)}, {rate:.2f} Mrays/s", refresh=False)
                self.bar.update(1)
        self.emit(result.record())

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        if self._close is not None:
            self._close.close()


def _execute(tasks: list[_Task], scene, report: _Report, *, workers: int, scheduler):
    """Run ``tasks`` here (``workers`` 0, no scheduler) or on a Dask farm; returns
    (results, values, worker processes used)."""
    results: list[FrameResult | None] = [None] * len(tasks)
    values: list = [None] * len(tasks)

    def done(i, result, build, value, status="rendered"):
        if build is not None:
            report.emit(build)
        if status != result.status:
            result = FrameResult(result.frame, status, result.files, result.seconds, result.rays,
                                 result.worker, result.value)
        results[i], values[i] = result, value
        report.frame(result)

    try:
        if scheduler is None and workers == 0:
            for i, task in enumerate(tasks):
                done(i, *run_task(task, scene))
        else:
            report.open_bar()
            cwd = os.getcwd()
            workers = farm.run([replace(t, cwd=cwd) for t in tasks], scene, workers=workers,
                               scheduler=scheduler, done=done)
            # Every frame must end complete: a frame whose worker was lost too often, or
            # whose files this process cannot see, is rendered again here.
            for i, task in enumerate(tasks):
                if results[i] is None or (task.job is not None and not job_complete(task.job, task.run)):
                    done(i, *run_task(task, scene), status="recovered")
    finally:
        forget_renderer()
    return results, values, workers


# --- public API ---------------------------------------------------------------------------


def _source(scene_or_path, no_references: bool, stage_light_speed):
    if isinstance(scene_or_path, (str, os.PathLike)):
        return StageFile(scene_or_path, no_references=no_references, light_speed=stage_light_speed), None
    if stage_light_speed is not None and not (isinstance(scene_or_path, StageFile)
                                              and scene_or_path.light_speed == stage_light_speed):
        raise ValueError("stage_light_speed applies to a stage path or a Usd.Stage (a Scene or a "
                         "StageFile already has its light speed)")
    if isinstance(scene_or_path, StageFile):
        return scene_or_path, None
    if isinstance(scene_or_path, Scene):
        return _InMemory(uuid.uuid4().hex), scene_or_path
    # a Usd.Stage: read it here, ship the Scene
    return _InMemory(uuid.uuid4().hex), load_scene(scene_or_path, light_speed=stage_light_speed)


def _workers(workers: int | None, scheduler, n_tasks: int) -> int:
    if workers is None and scheduler is None:
        return farm.default_workers(n_tasks)
    if workers is not None and (int(workers) != workers or workers < 0):
        raise ValueError(f"workers must be an integer >= 0, got {workers!r}")
    return int(workers or 0)


def _options(render_options: dict) -> tuple:
    return tuple(sorted((k, v) for k, v in render_options.items() if v is not None))


def render_sequence(scene_or_path, frames=None, output=None, *, workers: int | None = None, scheduler=None,
                    resume: bool = False, progress: bool = True, log=None, metadata: dict | None = None,
                    no_references: bool = False, stage_light_speed=None, **render_options) -> SequenceResult:
    """Render ``frames`` of a stage to EXR files; returns a :class:`SequenceResult`.

    scene_or_path: a stage path (farm workers load it themselves), a :class:`StageFile`,
        a :class:`~warp_st.core.scene.Scene` or a ``Usd.Stage`` (sent to workers pickled).
    frames: USD time codes (default: the stage's start frame); ignored when ``output``
        is a list of :class:`~warp_st.output.plan.FrameJob`.
    output: a pattern such as ``"out/shot.####.exr"``, or planned FrameJobs.
    workers: None: this process for short sequences, else one Dask worker per core
        (see :func:`warp_st.jobs.farm.default_workers`); 0: this process; N: a local Dask
        cluster of N worker processes. scheduler: a Dask scheduler address
        (``tcp://HOST:PORT``) or a ``distributed.Client``; workers need the same files.
    resume: skip frames whose files are already complete EXRs written by this same run:
        same software version, stage file (sha256), options that change pixels, frame
        and channels (their ``spacetime:run`` header, see :mod:`warp_st.output.plan`). A file
        that differs is rendered again, after a ``{"event": "stale", "frame", "files",
        "reason"}`` record naming what differs. A scene in memory cannot be checked: every
        frame is rendered.
    progress: a tqdm bar on stderr when it is a terminal. log: see the module docstring.
    metadata: EXR header items (``spacetime:<key>``) for every frame (default: the
        stage path and its sha256 when a path is given).
    stage_light_speed: the stage's speed of light when not its own (``load_scene``'s
        ``light_speed``, e.g. ``"30m/s"``, docs/spec.md §1.1), for a stage path or a
        ``Usd.Stage``; ``light_speed`` stays the renderer's finite / infinite mode.
    render_options: :class:`~warp_st.rendering.renderer.Renderer` keywords (width, camera, ...).
    """
    start = time.perf_counter()
    source, scene = _source(scene_or_path, no_references, stage_light_speed)
    if isinstance(output, (list, tuple)):
        jobs = list(output)
    else:
        if frames is None:
            loaded = scene if scene is not None else source.load()
            frames = [float(loaded.frame_range[0]) if loaded.frame_range else 0.0]
        frames = [float(f) for f in frames]
        if output is None:  # <stage stem>.exr / <stage stem>.####.exr, as the command line
            name = Path(source.name if isinstance(source, StageFile) else str(scene.source)).stem
            output = f"{name}.####.exr" if len(frames) > 1 else f"{name}.exr"
        jobs = plan_pattern(os.fspath(output), frames)
    if metadata is None:
        metadata = {"stage": source.name, "stageHash": source.sha256} if isinstance(source, StageFile) else {}

    stage_file = isinstance(source, StageFile)
    run = run_identity(source.sha256 if stage_file else None, render_options,
                       no_references=stage_file and source.no_references,
                       light_speed=source.light_speed if stage_file else None)
    skipped: dict[int, FrameResult] = {}
    stale: dict[int, list[str]] = {}
    todo: list[int] = []
    for i, job in enumerate(jobs):
        complete, stale[i] = resume_check(job, run) if resume else (False, [])
        if complete:
            skipped[i] = FrameResult(job.frame, "skipped", tuple(str(o.path) for o in job.outputs))
        else:
            todo.append(i)
    report = _Report(len(todo), progress, log, "frame")
    try:
        for i, job in enumerate(jobs):
            if i in skipped:
                report.frame(skipped[i])
            elif stale[i]:
                report.emit({"event": "stale", "frame": job.frame, "files": [str(o.path) for o in job.outputs],
                             "reason": "; ".join(stale[i])})
        if not todo:
            return SequenceResult([skipped[i] for i in range(len(jobs))], time.perf_counter() - start)
        frame_list = tuple(jobs[i].frame for i in todo)
        options, items = _options(render_options), tuple(metadata.items())
        tasks = [_Task(source, frame_list, jobs[i].frame, jobs[i], options, items, run=run) for i in todo]
        workers = _workers(workers, scheduler, len(tasks))
        results, _, n_workers = _execute(tasks, scene, report, workers=workers, scheduler=scheduler)
    finally:
        report.close()
    by_index = dict(skipped)
    by_index.update(zip(todo, results))
    return SequenceResult([by_index[i] for i in range(len(jobs))], time.perf_counter() - start, n_workers)


def sweep(make_scene, values, *, frame: float | None = None, output: str | None = None, measure=None,
          workers: int | None = None, scheduler=None, progress: bool = True, log=None,
          **render_options) -> SweepResult:
    """Render one frame of ``make_scene(value)`` for each value (a parameter study).

    make_scene: value -> Scene, stage path or ``Usd.Stage``; called in the process that
        renders the value (with a farm it must pickle: a module-level function).
    output: a file name with ``{value}`` (e.g. ``"beta_{value:.2f}.exr"``), or None to
        write nothing. measure: image -> anything picklable, computed where the image
        was rendered; without it the results are the Images themselves.
    Every value gets its own renderer (extrusion and BVH); see :func:`render_sequence`
    for ``workers``, ``scheduler``, ``progress``, ``log`` and ``render_options``.
    """
    start = time.perf_counter()
    values = list(values)
    token = uuid.uuid4().hex
    jobs: list[FrameJob | None] = [None] * len(values)
    if output is not None:
        jobs = [FrameJob(frame, (Output(Path(output.format(value=v))),)) for v in values]
        check_jobs(jobs, what=f"sweep output {output!r}")
    frames = None if frame is None else (float(frame),)
    options = _options(render_options)
    tasks = [_Task(_Generated(make_scene, v, token, i), frames, None if frame is None else float(frame), job,
                   options, (), measure, measure is None, v)
             for i, (v, job) in enumerate(zip(values, jobs))]
    report = _Report(len(tasks), progress, log, "value")
    try:
        results, outcomes, n_workers = _execute(tasks, None, report, workers=_workers(workers, scheduler, len(tasks)),
                                                scheduler=scheduler)
    finally:
        report.close()
    return SweepResult(values, outcomes, results, time.perf_counter() - start, n_workers)
