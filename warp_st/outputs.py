"""What a frame writes: one or more EXR files, each with all channels or a chosen, renamed set.

A :class:`FrameJob` is the unit a sequence renders (locally or on a farm worker): a frame
(USD time code) and its :class:`Output` files. Planning turns an output pattern
(``OUT.####.exr``) or a stage's UsdRender products into jobs, checking every name before
anything is rendered.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .frames import expand_output, has_frame_pattern

__all__ = ["Output", "FrameJob", "OutputPlanError", "plan_pattern", "check_jobs", "job_complete", "write_outputs"]


@dataclass(frozen=True)
class Output:
    """One EXR file of a frame.

    ``channels``: None writes every SPEC §4 channel under its own name; otherwise pairs
    ``(exr_name, source_channel)`` in file order, ``source_channel`` a name from
    :data:`warp_st.film.CHANNEL_NAMES`.
    """

    path: Path
    channels: tuple[tuple[str, str], ...] | None = None


@dataclass(frozen=True)
class FrameJob:
    """A frame and the files it writes."""

    frame: float
    outputs: tuple[Output, ...]


class OutputPlanError(ValueError):
    """Output names that cannot work (no frame pattern for many frames, clashes, unwritable)."""


def plan_pattern(pattern: str, frames: list[float]) -> list[FrameJob]:
    """One all-channel output per frame from ``pattern`` (``#`` runs / ``%04d`` = frame number)."""
    if len(frames) > 1 and not has_frame_pattern(pattern):
        raise OutputPlanError(
            f"{len(frames)} frames need a frame pattern in the output name "
            f"(e.g. OUT.####.exr or OUT.%04d.exr), got {pattern!r}"
        )
    jobs = [FrameJob(f, (Output(Path(expand_output(pattern, f))),)) for f in frames]
    check_jobs(jobs, what=f"output pattern {pattern!r}")
    return jobs


def check_jobs(jobs: list[FrameJob], what: str = "outputs") -> None:
    """Every file name distinct and writable (its folder exists); raises OutputPlanError."""
    from .exr import check_output_path

    paths = [o.path for job in jobs for o in job.outputs]
    if len(set(paths)) != len(paths):
        raise OutputPlanError(f"{what} gives several frames the same file name")
    for path in paths:
        try:
            check_output_path(path)
        except OSError as exc:
            raise OutputPlanError(exc.strerror or str(exc)) from None


def job_complete(job: FrameJob) -> bool:
    """True when every output of the frame is already a complete EXR (``--resume``)."""
    from .exr import is_complete_exr

    return all(is_complete_exr(o.path) for o in job.outputs)


def write_outputs(image, job: FrameJob) -> None:
    """Write every file of ``job`` from the rendered ``image`` (each atomically)."""
    for output in job.outputs:
        image.write_exr(output.path)
