"""``warp-st render``: frames of a stage to EXR files, atomically, resumable."""
from __future__ import annotations

import json
import os
import shlex
import sys
import time
import traceback
from pathlib import Path

from warp_st.commands.common import (
    PROG,
    UsageError,
    error,
    interrupted_status,
    interruption,
    non_negative_float,
    non_negative_int,
    positive_int,
    size_arg,
    stage_light_speed_arg,
)
from warp_st.commands.load import load
from warp_st.core.frames import finite_frame, frame_label, frames_label, parse_frames
from warp_st.core.hashing import file_hash
from warp_st.jobs.farm import LOCAL_FRAMES, MIN_CORES
from warp_st.output.plan import FrameJob, OutputPlanError, job_complete, plan_pattern, plan_products, single_view


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
    parser.add_argument("--cryptomatte", action="store_true", default=None,
                        help="also write the CryptoObject and CryptoMaterial Cryptomatte layers (prim-path mattes "
                        "for compositors; coverage from --samples)")
    parser.add_argument("--precision", choices=("float32", "float64"), help="scalar type of the kernels")
    parser.add_argument("--light-speed", type=light_speed_arg, metavar="C",
                        help="the speed of light: a value with a unit, e.g. 299792458m/s or 2units/timecode "
                        "('physical': 299792458m/s in the stage's metersPerUnit and timeCodesPerSecond), or "
                        "'infinite' (no light-travel time) or 'finite' (the stage's own). Default: 1 unit per time "
                        "code on stages that use the spacetime schemas, else physical (docs/spec.md §3.1)")
    parser.add_argument("--quadrics", choices=("exact", "tessellated"),
                        help="UsdGeom.Spheres traced as exact ellipsoids (the float32 default) or as triangles "
                        "within half a pixel (the only choice with --precision float64)")
    parser.add_argument("--resume", action="store_true",
                        help="skip frames whose output is already a complete EXR written by the same run (version, "
                        "stage file, options that change pixels, channels); any other is rendered again")
    parser.add_argument("--max-memory", type=size_arg, metavar="SIZE",
                        help="refuse (exit 2) a render whose estimated memory exceeds SIZE, e.g. 8G or 512M "
                   "(default: 75%% of the physical memory)")
    parser.add_argument("--no-references", action="store_true",
                        help="compose only the file's own layers: ignore references and payloads (untrusted stages)")
    parser.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")
    farm = parser.add_mutually_exclusive_group()
    farm.add_argument("--workers", type=non_negative_int, metavar="N",
                      help="render on a local Dask cluster of N worker processes; 0: in this process "
                      f"(default: in this process for up to {LOCAL_FRAMES} frames or on fewer than {MIN_CORES} "
                      "cores, else one worker per core)")
    farm.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                      help="render on the workers of a running Dask scheduler (shared filesystem: see docs/pipeline.md)")
    parser.add_argument("--log", metavar="FILE.jsonl",
                        help="append one JSON line per frame to FILE ('-': print them on stdout instead of the "
                        "usual lines)")

def light_speed_arg(text: str):
    """``finite`` / ``infinite`` (a light-speed mode), else the stage's light speed."""
    return text if text in ("finite", "infinite") else stage_light_speed_arg(text)


def _light_speed_mode(args):
    return args.light_speed if isinstance(args.light_speed, str) else None


def _stage_light_speed(args) -> str | None:
    return None if args.light_speed is None or isinstance(args.light_speed, str) else str(args.light_speed)


def plan_outputs(args, scene_path: Path, frames: list[float], frames_given: bool, scene=None) -> list[FrameJob]:
    """The frame jobs of ``-o`` (every channel; default ``<scene stem>.exr`` /
    ``<scene stem>.####.exr``), or without ``-o`` those of the loaded ``scene``'s UsdRender
    products (see docs/usd_render_products.md); ``--camera`` / ``--width`` / ``--height``
    override the products' own."""
    pattern = args.output
    if pattern is None:
        pattern = f"{scene_path.stem}.####.exr" if frames_given else f"{scene_path.stem}.exr"
    try:
        if args.output is None and scene is not None and scene.products:
            jobs = plan_products(scene, frames, camera=args.camera,
                                 size_given=args.width is not None or args.height is not None)
            try:
                single_view(jobs)
            except OutputPlanError as exc:
                raise OutputPlanError(f"{scene.source}: {exc}") from None
            return jobs
        return plan_pattern(pattern, frames)
    except OutputPlanError as exc:
        raise UsageError(str(exc)) from None


def _options_text(args) -> str:
    names = ("camera", "width", "height", "max_depth", "samples", "shutter", "doppler_color", "searchlight",
             "cryptomatte", "precision", "light_speed", "quadrics", "no_references")
    return " ".join(f"{n}={getattr(args, n)}" for n in names if getattr(args, n) not in (None, False))


def run(args, argv: list[str]) -> int:
    from warp_st.core.conventions import LightSpeed, Precision
    from warp_st.jobs.sequence import StageFile, render_sequence

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
    if frames is not None and args.output is not None:  # check -o names before the (slower) load
        plan_outputs(args, scene_path, frames, frames_given)
    if args.log not in (None, "-"):
        from warp_st.output.exr import check_output_path

        try:
            check_output_path(args.log)
        except OSError as exc:
            raise UsageError(f"--log: {exc.strerror or exc}") from None
    stage_hash = file_hash(scene_path)
    scene = load(scene_path, args.no_references, args.max_memory, light_speed=_stage_light_speed(args),
                 camera=args.camera, frames=frames)
    if frames is None:
        frames = [float(scene.frame_range[0])] if scene.frame_range is not None else [0.0]
    jobs = plan_outputs(args, scene_path, frames, frames_given, scene)
    camera, size = single_view(jobs)  # render products' own view, else the run's

    options = dict(
        camera=camera or args.camera,
        width=size[0] if size else args.width,
        height=size[1] if size else args.height,
        max_depth=args.max_depth,
        samples=args.samples,
        shutter=args.shutter,
        doppler_color=args.doppler_color,
        searchlight=args.searchlight,
        cryptomatte=args.cryptomatte,
        precision=Precision(args.precision) if args.precision else None,
        light_speed=LightSpeed(_light_speed_mode(args)) if _light_speed_mode(args) else None,
        quadrics=args.quadrics,
        max_memory=args.max_memory,  # None: the Renderer's default limit (75% of the physical memory)
    )
    metadata = {"stage": str(scene_path), "stageHash": stage_hash, "commandLine": shlex.join([PROG, *argv])}
    options_text = _options_text(args)
    if options_text:
        metadata["options"] = options_text

    console = _Console(args)
    started = time.time()
    try:
        result = render_sequence(
            StageFile(scene_path, no_references=args.no_references, sha256=stage_hash, scene=scene,
                      light_speed=_stage_light_speed(args)),
            output=jobs, workers=args.workers, scheduler=args.scheduler, resume=args.resume,
            progress=not args.quiet, log=console, metadata=metadata, **options)
    except KeyboardInterrupt as exc:
        complete = _complete(console, jobs, started)
        print(
            f"{PROG}: {interruption(exc)}; frames complete: {frames_label(complete)} "
            f"({len(complete)} of {len(frames)}); rerun with --resume to continue",
            file=sys.stderr,
        )
        return interrupted_status(exc)
    except BrokenPipeError:  # stdout's reader went away: the command line ends quietly
        raise
    except OSError as exc:  # e.g. disk full: the frames written so far are complete
        complete = _complete(console, jobs, started)
        error(f"{exc}; frames complete: {frames_label(complete)} ({len(complete)} of "
              f"{len(frames)}); rerun with --resume to continue")
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1
    finally:
        console.close()
    if not result.rendered and console.human:
        print(f"all {len(frames)} frame(s) already complete")
    return 0


def _complete(console, jobs, since: float) -> list[float]:
    """Frames reported complete, plus those whose files this run finished without a record
    yet (a signal can land between a frame's rename and its record): complete EXRs
    written since the run started."""
    done = set(console.complete)
    for job in jobs:
        if job.frame not in done and job_complete(job):
            try:
                if all(os.stat(o.path).st_mtime >= since for o in job.outputs):
                    done.add(job.frame)
            except OSError:
                pass
    return sorted(done)


class _Console:
    """The records of a run (``warp_st.jobs.sequence``) as lines: human ones on stdout, JSON lines
    appended to ``--log FILE`` or, with ``--log -``, on stdout instead of the human ones."""

    def __init__(self, args):
        self.json_stdout = args.log == "-"
        self.quiet = args.quiet
        self.human = not args.quiet and not self.json_stdout
        self.bar = not args.quiet and sys.stderr.isatty()  # the per-frame lines give way to it
        self.path = None if args.log in (None, "-") else args.log  # opened at the first record
        self.file = None
        self.complete: list[float] = []
        self.described = False

    def __call__(self, record: dict) -> None:
        line = json.dumps(record)
        if self.path is not None:
            if self.file is None:
                self.file = open(self.path, "a", encoding="utf-8")
            self.file.write(line + "\n")
            self.file.flush()
        if self.json_stdout:
            print(line, flush=True)
        if record["event"] == "frame":
            self.complete.append(record["frame"])
        if record["event"] == "stale":
            if not self.quiet:
                print(f"{PROG}: frame {frame_label(record['frame'])}: rendering again: {record['reason']}",
                      file=sys.stderr, flush=True)
            return
        if not self.human:
            return
        if record["event"] == "build":
            if not self.described:  # one line for the stage, however many workers build it
                self.described = True
                stats = {k: v for k, v in record.items() if k not in ("event", "worker", "seconds")}
                print("scene: " + ", ".join(f"{k}={v}" for k, v in stats.items()), flush=True)
            return
        label, names = frame_label(record["frame"]), ", ".join(record["files"])
        if record["status"] == "skipped":
            print(f"frame {label}: complete, skipped ({names})", flush=True)
        elif record["status"] == "recovered":
            print(f"frame {label}: {record['seconds']:.2f} s -> {names} (rendered here: its worker was lost "
                  "or its files were missing)", flush=True)
        elif not self.bar:
            print(f"frame {label}: {record['seconds']:.2f} s -> {names}", flush=True)

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
