"""``warp-st render``: frames of a stage to EXR files, atomically, resumable."""
from __future__ import annotations

import os
import shlex
import sys
import time
import traceback
from pathlib import Path

from ..frames import finite_frame, frame_label, frames_label, parse_frames
from .common import (PROG, UsageError, error, interrupted_status, interruption, non_negative_float,
                     non_negative_int, positive_int, size_arg)
from ..outputs import FrameJob, OutputPlanError, job_complete, plan_pattern, write_outputs
from .load import file_hash, held_diagnostics, load


def add_arguments(parser) -> None:
    """The options of ``warp-st render``."""
    parser.add_argument("scene", metavar="SCENE.usda", help="the USD stage to render")
    parser.add_argument(
        "-o", "--output", metavar="OUT.exr",
        help="output file; '#' runs or %%04d are replaced by the frame number "
        "(default: <scene stem>.exr, or <scene stem>.####.exr with --frames)",
    )
    frames = parser.add_mutually_exclusive_group()
    frames.add_argument("--frame", type=finite_frame, metavar="N",
                        help="USD time code to render (default: the stage's start time code, else 0)")
    frames.add_argument("--frames", type=parse_frames, metavar="A-B[xS],...",
                        help="frames to render: inclusive ranges with optional step, comma separated")
    parser.add_argument("--camera", metavar="/Path", help="camera prim path")
    parser.add_argument("--width", type=positive_int, metavar="W", help="image width in pixels")
    parser.add_argument("--height", type=positive_int, metavar="H", help="image height in pixels")
    parser.add_argument("--max-depth", type=non_negative_int, metavar="D", help="mirror reflection bounces")
    parser.add_argument("--samples", type=positive_int, metavar="S", help="samples per pixel")
    parser.add_argument("--shutter", type=non_negative_float, metavar="T",
                        help="camera-time interval [t_c, t_c + T] sampled for 4D motion blur (needs --samples > 1)")
    parser.add_argument("--doppler-color", action="store_true", default=None,
                        help="shift each surface's colour by its Doppler factor D (off by default)")
    parser.add_argument("--searchlight", action="store_true", default=None,
                        help="scale radiance by D^4, the searchlight effect (off by default)")
    parser.add_argument("--precision", choices=("float32", "float64"), help="scalar type of the kernels")
    parser.add_argument("--light-speed", choices=("finite", "infinite"), help="finite (c = 1) or infinite light speed")
    parser.add_argument("--resume", action="store_true", help="skip frames whose output is already a complete EXR")
    parser.add_argument("--max-memory", type=size_arg, metavar="SIZE",
                        help="refuse (exit 2) a render whose estimated memory exceeds SIZE, e.g. 8G or 512M "
                   "(default: 75%% of the physical memory)")
    parser.add_argument("--no-references", action="store_true",
                        help="compose only the file's own layers: ignore references and payloads (untrusted stages)")
    parser.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")

def plan_outputs(args, scene_path: Path, frames: list[float], frames_given: bool) -> list[FrameJob]:
    """The frame jobs of ``-o`` (default ``<scene stem>.exr`` / ``<scene stem>.####.exr``)."""
    pattern = args.output
    if pattern is None:
        pattern = f"{scene_path.stem}.####.exr" if frames_given else f"{scene_path.stem}.exr"
    try:
        return plan_pattern(pattern, frames)
    except OutputPlanError as exc:
        raise UsageError(str(exc)) from None


def _options_text(args) -> str:
    names = ("camera", "width", "height", "max_depth", "samples", "shutter", "doppler_color", "searchlight",
             "precision", "light_speed", "no_references")
    return " ".join(f"{n}={getattr(args, n)}" for n in names if getattr(args, n) not in (None, False))


def run(args, argv: list[str]) -> int:
    from ..conventions import LightSpeed, Precision

    scene_path = Path(args.scene)
    if not scene_path.is_file():
        raise UsageError(f"{scene_path}: no such file")
    frames_given = args.frames is not None
    if frames_given:
        frames = list(args.frames)
    elif args.frame is not None:
        frames = [float(args.frame)]
    else:
        frames = None  # the stage's start time code: known once it is loaded
    if frames is not None:  # check the output names before the (slower) load
        plan_outputs(args, scene_path, frames, frames_given)
    stage_hash = file_hash(scene_path)
    scene = load(scene_path, args.no_references, args.max_memory)
    if frames is None:
        frames = [float(scene.frame_range[0])] if scene.frame_range is not None else [0.0]
    jobs = plan_outputs(args, scene_path, frames, frames_given)

    complete: list[float] = []
    todo: list[FrameJob] = []
    for job in jobs:
        if args.resume and job_complete(job):
            complete.append(job.frame)
            if not args.quiet:
                names = ", ".join(str(o.path) for o in job.outputs)
                print(f"frame {frame_label(job.frame)}: complete, skipped ({names})")
        else:
            todo.append(job)
    if not todo:
        if not args.quiet:
            print(f"all {len(frames)} frame(s) already complete")
        return 0

    try:
        from ..renderer import Renderer

        with held_diagnostics():  # the camera is evaluated per frame here
            renderer = Renderer(
                scene,
                frames=[job.frame for job in todo],
                camera=args.camera,
                width=args.width,
                height=args.height,
                max_depth=args.max_depth,
                samples=args.samples,
                shutter=args.shutter,
                doppler_color=args.doppler_color,
                searchlight=args.searchlight,
                precision=Precision(args.precision) if args.precision else None,
                light_speed=LightSpeed(args.light_speed) if args.light_speed else None,
                # None: the Renderer's default limit (75% of the physical memory)
                **({"max_memory": args.max_memory} if args.max_memory is not None else {}),
            )
        if not args.quiet:
            stats = renderer.describe() or {}
            if stats:
                print("scene: " + ", ".join(f"{k}={v}" for k, v in stats.items()))

        metadata = {"stage": str(scene_path), "stageHash": stage_hash, "commandLine": shlex.join([PROG, *argv])}
        options = _options_text(args)
        if options:
            metadata["options"] = options

        use_bar = not args.quiet and sys.stderr.isatty()
        bar = None
        if use_bar:
            from tqdm import tqdm

            bar = tqdm(total=len(todo), unit="frame", file=sys.stderr, dynamic_ncols=True)
        try:
            for job in todo:
                frame = job.frame
                start = time.perf_counter()
                image = renderer.render(frame)
                for key, value in metadata.items():
                    image.metadata.setdefault(key, value)
                write_outputs(image, job)
                out = ", ".join(str(o.path) for o in job.outputs)
                complete.append(frame)
                seconds = time.perf_counter() - start
                if bar is not None:
                    bar.set_postfix_str(f"frame {frame_label(frame)} {seconds:.2f}s")
                    bar.update(1)
                elif not args.quiet:
                    print(f"frame {frame_label(frame)}: {seconds:.2f} s -> {out}", flush=True)
        finally:
            if bar is not None:
                bar.close()
    except KeyboardInterrupt as exc:
        print(
            f"{PROG}: {interruption(exc)}; frames complete: {frames_label(complete)} "
            f"({len(complete)} of {len(frames)}); rerun with --resume to continue",
            file=sys.stderr,
        )
        return interrupted_status(exc)
    except OSError as exc:  # e.g. disk full: the frames written so far are complete
        error(f"{exc}; frames complete: {frames_label(complete)} ({len(complete)} of {len(frames)}); "
               "rerun with --resume to continue")
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1
    return 0


