"""What a frame writes: one or more EXR files, each with all channels or a chosen, renamed set.

A :class:`FrameJob` is the unit a sequence renders (locally or on a farm worker): a frame
(USD time code) and its :class:`Output` files. Planning turns an output pattern
(``OUT.####.exr``) or a stage's UsdRender products into jobs, checking every name before
anything is rendered. Products: see docs/usd_render_products.md.

Run identity (``--resume``): every file a sequence writes carries ``spacetime:run``, the
canonical JSON of what its run rendered (:func:`run_identity`, :func:`output_identity`):
the writer's software version, the stage (its root layer's sha256; None for a scene held
in memory, which nothing can check) and ``noReferences``, every Renderer option given
except those that never change a pixel (:data:`NON_PIXEL_OPTIONS`; an option left out is
the stage's own, which its hash pins), the frame and the channel set. A file is kept only
when its record equals the current run's (:func:`resume_check`). The record holds what
was asked, not what it resolved to: ``--samples 4`` on a stage whose own is 4 still differs
from leaving it out, so such a frame is rendered again (never kept wrongly). Only the root
layer is hashed: an edit in a referenced or sublayered file is not seen.
"""
from __future__ import annotations

import enum
import json
from dataclasses import dataclass
from pathlib import Path

from warp_st.core.conventions import DEFAULT_RESOLUTION
from warp_st.core.frames import expand_output, frame_label, has_frame_pattern
from warp_st.core.scene import RenderProduct, Scene, SceneError
from warp_st.core.version import __version__
from warp_st.output import cryptomatte
from warp_st.output.channels import CHANNEL_NAMES, LOW_TIME_CHANNELS
from warp_st.output.film import OutputChannel

__all__ = ["Output", "FrameJob", "OutputPlanError", "plan_pattern", "plan_products", "single_view",
           "check_jobs", "job_complete", "resume_check", "run_identity", "output_identity",
           "NON_PIXEL_OPTIONS", "write_outputs"]

#: Renderer keywords that never change a pixel, so not part of a run's identity: the
#: memory limit (a refusal, never a different image) and the tile threads (pixels are
#: independent of how the rows are shared out).
NON_PIXEL_OPTIONS = frozenset({"max_memory", "threads"})


@dataclass(frozen=True)
class Output:
    """One EXR file of a frame.

    channels: None writes every docs/spec.md §4 channel under its own name; otherwise
        :class:`~warp_st.output.film.OutputChannel` items ``(exr_name, source_channel, half)``,
        ``source_channel`` a name from :data:`warp_st.output.film.CHANNEL_NAMES` (OpenEXR stores
        the channels sorted by name).
    camera, resolution: the view this file needs (a product's own camera prim path
        and (width, height)); None: the run's camera / resolution.
    """

    path: Path
    channels: tuple[OutputChannel, ...] | None = None
    camera: str | None = None
    resolution: tuple[int, int] | None = None


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


def plan_products(scene: Scene, frames: list[float], *, camera: str | None = None,
                  size_given: bool = False) -> list[FrameJob]:
    """One output per product per frame from the stage's UsdRender products.

    productName is evaluated at each frame's time code, ``#`` runs / ``%04d`` in it are
    replaced by the frame number, and a relative name is relative to the working
    directory (as husk and hdPrman hand it to the file system). ``camera`` (the command
    line's) and ``size_given`` (``--width``/``--height``) override every product's own.
    """
    settings = scene.settings
    run_camera = camera or settings.camera or scene.default_camera
    run_resolution = settings.resolution or DEFAULT_RESOLUTION
    jobs = []
    for frame in frames:
        outputs = []
        for product in scene.products:
            own_camera = None if camera or product.camera == run_camera else product.camera
            own_size = None if size_given or product.resolution == run_resolution else product.resolution
            outputs.append(Output(Path(expand_output(product.name_at(frame), frame)), _channels(product),
                                  own_camera, own_size))
        jobs.append(FrameJob(frame, tuple(outputs)))
    _check_product_names(scene, jobs)
    check_jobs(jobs, what="the stage's render products")
    return jobs


def _channels(product: RenderProduct) -> tuple[OutputChannel, ...]:
    return tuple(OutputChannel(name, source, var.half) for var in product.vars for name, source in var.channels)


def _check_product_names(scene: Scene, jobs: list[FrameJob]) -> None:
    """Each product names a distinct, writable file at every frame (else a one-line error
    naming the stage, the product and productName)."""
    check_product_clashes(scene.source, scene.products, jobs)
    from warp_st.output.exr import check_output_path

    for job in jobs:  # unwritable names: name the product that asks for them
        for product, output in zip(scene.products, job.outputs):
            try:
                check_output_path(output.path)
            except OSError as exc:
                raise OutputPlanError(str(SceneError.at(scene.source, product.prim_path, "productName",
                                                        exc.strerror or str(exc)))) from None


def product_paths(products, frames) -> list[FrameJob]:
    """The file each product names at each frame (``#``/``%04d`` expanded), as jobs."""
    return [FrameJob(f, tuple(Output(Path(expand_output(p.name_at(f), f))) for p in products)) for f in frames]


def check_product_clashes(source: str, products, jobs: list[FrameJob]) -> None:
    """OutputPlanError naming the product when two frames or two products share a file."""
    seen: dict[Path, tuple[RenderProduct, float]] = {}
    for job in jobs:
        for product, output in zip(products, job.outputs):
            if output.path in seen:
                other, frame = seen[output.path]
                clash = (f"the frames {frame_label(frame)} and {frame_label(job.frame)}" if other is product
                         else f"{other.prim_path} at frame {frame_label(frame)}")
                raise OutputPlanError(str(SceneError.at(
                    source, product.prim_path, "productName",
                    f"{str(output.path)!r} is also the file of {clash}; time-sample productName "
                    "or put a #### frame pattern in it")))
            seen[output.path] = (product, job.frame)


def single_view(jobs: list[FrameJob]) -> tuple[str | None, tuple[int, int] | None]:
    """The one (camera, resolution) every output of ``jobs`` needs (None: the run's).

    Raises OutputPlanError when the outputs need several views: one run renders one.
    """
    views = {(o.camera, o.resolution) for job in jobs for o in job.outputs}
    if len(views) > 1:
        run_camera, run_size = "the run's camera", "the run's size"
        described = "; ".join(f"{c or run_camera} at {'x'.join(map(str, r)) if r else run_size}"
                              for c, r in sorted(views, key=str))
        raise OutputPlanError(f"the render products need {len(views)} different views ({described}); "
                              "one run renders one: give --camera / --width --height to render them all "
                              "from one view")
    return next(iter(views), (None, None))


def check_jobs(jobs: list[FrameJob], what: str = "outputs") -> None:
    """Every file name distinct and writable (its folder exists); raises OutputPlanError."""
    from warp_st.output.exr import check_output_path

    paths = [o.path for job in jobs for o in job.outputs]
    if len(set(paths)) != len(paths):
        raise OutputPlanError(f"{what} gives several frames the same file name")
    for path in paths:
        try:
            check_output_path(path)
        except OSError as exc:
            raise OutputPlanError(exc.strerror or str(exc)) from None


def _plain(value):
    """``value`` as JSON data: enums by value, tuples as lists."""
    if isinstance(value, enum.Enum):
        return _plain(value.value)
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # a NumPy scalar
        return value.item()
    return value


def _canonical(record: dict) -> str:
    return json.dumps(record, sort_keys=True, separators=(",", ":"))


def run_identity(stage: str | None, options: dict, *, no_references: bool = False,
                 light_speed: str | None = None) -> str:
    """What a run renders, common to all its files, as canonical JSON (see the module docstring).

    stage: the root layer's ``sha256:HEX`` (None: a scene in memory). options: the
    Renderer keywords; None values (the stage's own) and :data:`NON_PIXEL_OPTIONS` are left out.
    light_speed: the stage's light speed when the run sets it (``--light-speed 30m/s``).
    """
    kept = {name: _plain(value) for name, value in options.items()
            if value is not None and name not in NON_PIXEL_OPTIONS}
    if light_speed is not None:
        kept["stageLightSpeed"] = str(light_speed)
    return _canonical({"stage": stage, "noReferences": bool(no_references), "options": kept})


def output_identity(run: str, frame: float, output: Output) -> str:
    """The ``spacetime:run`` record of one file of ``run``: with this process's software
    version, the frame and the channel set (``"all"``, or ``[name, source, half]`` items)."""
    channels = "all" if output.channels is None else [[c.name, c.source, bool(c.half)] for c in output.channels]
    return _canonical({**json.loads(run), "version": __version__, "frame": float(frame), "channels": channels})


_STAGE_OWN = "the stage's own"


def _shown(record: dict, key: str, default: str) -> str:
    return json.dumps(record[key]) if key in record else default


def _differences(found: dict, expected: dict) -> list[str]:
    """``key: file X, this run Y`` for every field (options one by one) that differs."""
    diffs = []
    for key in sorted(set(found) | set(expected)):
        a, b = found.get(key), expected.get(key)
        if key == "options" and isinstance(a, dict) and isinstance(b, dict):
            diffs += [f"{name}: file {_shown(a, name, _STAGE_OWN)}, this run {_shown(b, name, _STAGE_OWN)}"
                      for name in sorted(set(a) | set(b)) if a.get(name) != b.get(name)]
        elif key not in found or key not in expected or a != b:
            diffs.append(f"{key}: file {_shown(found, key, 'none')}, this run {_shown(expected, key, 'none')}")
    return diffs


def _output_problem(output: Output, frame: float, run: str | None) -> str | None:
    """Why ``output`` is not a file ``run`` would write (None: it is); ``missing`` when absent."""
    from warp_st.output.exr import ATTR_RUN, completeness

    names = CHANNEL_NAMES if output.channels is None else tuple(c.name for c in output.channels)
    why, header, present = completeness(output.path, names)
    if why is not None or run is None:
        return why
    others = set(present) - set(names)
    if output.channels is None:  # an all-channel file also holds the Cryptomatte layers its run computed
        others = {c for c in others if not any(cryptomatte.is_rank_channel(c, lay) for lay in cryptomatte.LAYERS)}
        # and a float64 run's time residuals (the run record's precision tells the two apart)
        others -= set(LOW_TIME_CHANNELS.values())
    if others:
        return f"holds other channels ({', '.join(sorted(others))}) than this run writes"
    expected = json.loads(output_identity(run, frame, output))
    if expected["stage"] is None:
        return "the scene is held in memory: nothing to check the file against (give a stage file to resume)"
    text = header.get(ATTR_RUN)
    if not isinstance(text, str):
        return "has no spacetime:run record (written by another tool or an older version)"
    try:
        found = json.loads(text)
    except ValueError:
        found = None
    if not isinstance(found, dict):
        return "its spacetime:run record is damaged"
    diffs = _differences(found, expected)
    return f"written by another run ({'; '.join(diffs)})" if diffs else None


def resume_check(job: FrameJob, run: str | None) -> tuple[bool, list[str]]:
    """(complete, reasons) for ``--resume``: complete when every output of ``job`` is a
    complete EXR holding its channels and, with ``run`` (:func:`run_identity`), exactly
    those channels and a ``spacetime:run`` record equal to this run's. reasons: ``PATH:
    why`` for each existing file that is not kept (a missing file needs no reason)."""
    problems = [(o.path, _output_problem(o, job.frame, run)) for o in job.outputs]
    return (all(why is None for _, why in problems),
            [f"{path}: {why}" for path, why in problems if why not in (None, "missing")])


def job_complete(job: FrameJob, run: str | None = None) -> bool:
    """True when every output of the frame is already a complete EXR holding the channels
    it asks for (all of them for an all-channel output) and, given ``run``, written by
    this run (see :func:`resume_check`)."""
    return resume_check(job, run)[0]


def write_outputs(image, job: FrameJob, run: str | None = None) -> None:
    """Write every file of ``job`` from the rendered ``image`` (each atomically, each with
    its channels and, given ``run`` (:func:`run_identity`), its ``spacetime:run`` record);
    the outputs share one view (see :func:`single_view`)."""
    from warp_st.output.exr import write_exr

    for output in job.outputs:
        write_exr(image, output.path, output.channels,
                  run=None if run is None else output_identity(run, job.frame, output))
