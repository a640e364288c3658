"""What a frame writes: one or more EXR files, each with all channels or a chosen, renamed set.

A :class:`FrameJob` is the unit a sequence renders (locally or on a farm worker): a frame
(USD time code) and its :class:`Output` files. Planning turns an output pattern
(``OUT.####.exr``) or a stage's UsdRender products into jobs, checking every name before
anything is rendered. Products: see docs/usd_render_products.md.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from warp_st.core.conventions import DEFAULT_RESOLUTION
from warp_st.core.frames import expand_output, frame_label, has_frame_pattern
from warp_st.core.scene import RenderProduct, Scene, SceneError
from warp_st.output.film import REQUIRED_CHANNELS, OutputChannel

__all__ = ["Output", "FrameJob", "OutputPlanError", "plan_pattern", "plan_products", "single_view",
           "check_jobs", "job_complete", "write_outputs"]


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


def job_complete(job: FrameJob) -> bool:
    """True when every output of the frame is already a complete EXR holding the channels
    it asks for (R, G, B, A for an all-channel output) (``--resume``)."""
    from warp_st.output.exr import is_complete_exr

    return all(is_complete_exr(o.path, REQUIRED_CHANNELS if o.channels is None else [c.name for c in o.channels])
               for o in job.outputs)


def write_outputs(image, job: FrameJob) -> None:
    """Write every file of ``job`` from the rendered ``image`` (each atomically, each with
    its channels); the outputs share one view (see :func:`single_view`)."""
    for output in job.outputs:
        image.write_exr(output.path, output.channels)
