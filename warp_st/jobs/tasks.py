"""Render tasks: one frame of one scene, with where the scene comes from and what to write.

:func:`run_task` renders a task in this process, building its
:class:`~warp_st.rendering.renderer.Renderer` (extrusion and 4D BVH) once and keeping it for
every task of the same stage, frames and options. :mod:`warp_st.jobs.sequence` plans tasks and
:mod:`warp_st.jobs.farm` ships them to Dask workers; both import this module, not each other.
"""
from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

from warp_st.core.hashing import file_hash
from warp_st.core.native_output import held_diagnostics
from warp_st.core.scene import Scene, SceneError
from warp_st.output.plan import FrameJob, write_outputs
from warp_st.rendering.renderer import Renderer
from warp_st.usd.reader import load_scene

__all__ = ["StageFile", "FrameResult", "run_task", "forget_renderer"]


class StageFile:
    """A stage file that each process loads for itself (farm workers: a shared filesystem).

    sha256: ``sha256:HEX`` of the file (computed when not given); a worker that reads
    other bytes refuses rather than render a different stage. scene: the Scene already
    loaded from it in this process (used here, never sent to a worker). light_speed: the
    stage's light speed when not its own (``load_scene``'s, e.g. ``"30m/s"``).
    """

    def __init__(self, path, *, no_references: bool = False, sha256: str | None = None, scene=None,
                 light_speed: str | None = None):
        self.name = os.fspath(path)
        self.path = os.path.abspath(self.name)
        self.no_references = bool(no_references)
        self.light_speed = light_speed  # None: the stage's own (docs/spec.md §3.1)
        self.sha256 = sha256 or file_hash(Path(self.path))
        self.scene = scene

    @property
    def key(self) -> tuple:
        return ("file", self.path, self.sha256, self.no_references, self.light_speed)

    def load(self):
        if self.scene is None:
            if file_hash(Path(self.path)) != self.sha256:
                raise SceneError(f"{self.path}: the file changed since the sequence started "
                                 f"(expected {self.sha256})")
            with warnings.catch_warnings():  # reported once, by the process that planned the work
                warnings.simplefilter("ignore")
                self.scene = load_scene(self.path, no_references=self.no_references, light_speed=self.light_speed)
        return self.scene

    def __getstate__(self):
        return {**self.__dict__, "scene": None}


@dataclass(frozen=True)
class _InMemory:
    """A Scene object handed in by the caller; it travels beside the task (see ``run_task``)."""

    token: str

    @property
    def key(self) -> tuple:
        return ("scene", self.token)


@dataclass(frozen=True)
class _Generated:
    """The scene ``make_scene(value)`` of a sweep, made in the process that renders it."""

    make_scene: object
    value: object
    token: str
    index: int

    @property
    def key(self) -> tuple:
        return ("sweep", self.token, self.index)

    def load(self):
        made = self.make_scene(self.value)
        return made if isinstance(made, Scene) else load_scene(made)


@dataclass(frozen=True)
class _Task:
    """One frame to render: where its scene comes from, what to write, what to send back."""

    source: object  # StageFile | _InMemory | _Generated
    frames: tuple[float, ...] | None  # what the renderer is built for (None: the stage's start frame)
    frame: float | None
    job: FrameJob | None
    options: tuple = ()  # sorted (name, value) Renderer keywords
    metadata: tuple = ()  # (key, value) header items stamped on the image
    measure: object = None
    keep_image: bool = False
    value: object = None  # the sweep value, for the record
    cwd: str | None = None  # relative output names are relative to this folder (the planner's)
    run: str | None = None  # the run identity stamped on the files (warp_st.output.plan.run_identity)


@dataclass(frozen=True)
class FrameResult:
    """What happened to one frame.

    status: ``rendered``; ``skipped`` (already complete, ``resume``); ``recovered`` (its
    worker was lost or its files missing, so this process rendered it again).
    rays: camera rays (pixels x samples). seconds: render + write time.
    """

    frame: float
    status: str
    files: tuple[str, ...] = ()
    seconds: float = 0.0
    rays: int = 0
    worker: str = "local"
    value: object = None

    @property
    def mrays_per_s(self) -> float:
        return self.rays / self.seconds / 1e6 if self.seconds > 0 else 0.0

    def record(self) -> dict:
        """The JSON log line of this frame."""
        rec = {"event": "frame", "frame": self.frame, "status": self.status, "files": list(self.files),
               "seconds": round(self.seconds, 4), "rays": self.rays, "mrays_per_s": round(self.mrays_per_s, 3),
               "worker": self.worker, "time": round(time.time(), 3)}
        if self.value is not None:
            rec["value"] = self.value if isinstance(self.value, (int, float, str, bool)) else repr(self.value)
        return rec


#: This process's renderer: (key, Renderer). One at a time, so memory stays one database.
_RENDERER: dict = {}


def _renderer(task: _Task, scene):
    key = (task.source.key, task.frames, task.options)
    if key in _RENDERER:
        return _RENDERER[key], None
    _RENDERER.clear()
    start = time.perf_counter()
    if scene is None:
        scene = task.source.load()
    with held_diagnostics():  # USD's messages while the camera is evaluated: one line each
        renderer = Renderer(scene, frames=None if task.frames is None else list(task.frames), **dict(task.options))
    build = {"seconds": round(time.perf_counter() - start, 4), **(renderer.describe() or {})}
    _RENDERER[key] = renderer
    return renderer, build


def forget_renderer() -> None:
    """Drop this process's cached renderer (its 4D database)."""
    _RENDERER.clear()


def run_task(task: _Task, scene=None, *, worker: str = "local", threads: int | None = None):
    """Render ``task`` (building or reusing this process's renderer), write its files.

    scene: the Scene of an in-memory source. Returns ``(FrameResult, build, value)``:
    build is the renderer's description when this call built it, else None; value is
    ``measure(image)``, the image (``keep_image``) or None.
    """
    renderer, build = _renderer(task, scene)
    if build is not None:
        build = {"event": "build", "worker": worker, **build}
    start = time.perf_counter()
    image = renderer.render(task.frame) if threads is None else renderer.render(task.frame, threads=threads)
    image.metadata.update(dict(task.metadata))
    files: tuple[str, ...] = ()
    if task.job is not None:
        write_outputs(image, task.job if task.cwd is None else _rooted(task.job, task.cwd), task.run)
        files = tuple(str(o.path) for o in task.job.outputs)
    seconds = time.perf_counter() - start
    rays = image.width * image.height * int(getattr(renderer, "samples", 1))
    result = FrameResult(image.frame, "rendered", files, seconds, rays, worker, task.value)
    value = task.measure(image) if task.measure is not None else (image if task.keep_image else None)
    return result, build, value


def _rooted(job: FrameJob, cwd: str) -> FrameJob:
    """``job`` with relative output names joined to ``cwd``."""
    return replace(job, outputs=tuple(replace(o, path=Path(cwd) / o.path) for o in job.outputs))


# --- reporting on the planning side ---------------------------------------------------------
