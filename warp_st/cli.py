"""The ``warp-st`` command line (SPEC §6): thin commands over the public API.

    warp-st render SCENE.usda [-o OUT.exr | -o OUT.####.exr] [--frame N | --frames 1-240x2]
                   [--camera /Path] [--width W --height H] [--max-depth D] [--samples S]
                   [--precision float32|float64] [--light-speed finite|infinite]
                   [--resume] [--quiet]
    warp-st inspect OUT.exr [--pixel X Y] [--channel NAME --png OUT.png]
    warp-st validate SCENE.usda

Exit status: 0 success; 2 bad input (one line ``warp-st: error: ...`` on stderr, no
traceback, nothing written); 1 internal error (traceback with WARP_ST_DEBUG set);
130 interrupted (the message says which frames are complete).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import re
import shlex
import sys
import time
import traceback
from pathlib import Path

import numpy as np

from .scene import SceneError

__all__ = ["main", "parse_frames", "expand_output", "has_frame_pattern", "format_frame"]

PROG = "warp-st"


class UsageError(Exception):
    """Bad input detected by the command line itself: exit 2 with one line."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors as one line (no usage block) through UsageError."""

    def error(self, message):  # noqa: D102 - argparse API
        raise UsageError(message)


# --- frames and output names ---------------------------------------------------

_RANGE = re.compile(r"^\s*(-?\d+)\s*-\s*(-?\d+)\s*(?:x\s*(\d+))?\s*$")
_NUMBER = re.compile(r"^\s*-?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?\s*$")


def parse_frames(text: str) -> list[float]:
    """Frames from ``A-B[xStep]`` ranges (inclusive, integers) and numbers, comma separated.

    ``"1-240x2"`` -> 1, 3, ..., 239; ``"1,5,10-20x5"`` -> 1, 5, 10, 15, 20. Single
    items may be fractional time codes. Duplicates are dropped, order is kept.
    Raises argparse.ArgumentTypeError (exit 2) on a malformed or empty range.
    """
    frames: list[float] = []
    for item in text.split(","):
        if not item.strip():
            raise argparse.ArgumentTypeError(f"bad frame list {text!r}: empty item")
        m = _RANGE.match(item)
        if m:
            first, last = int(m.group(1)), int(m.group(2))
            step = int(m.group(3)) if m.group(3) is not None else 1
            if step < 1:
                raise argparse.ArgumentTypeError(f"bad frame range {item.strip()!r}: step must be >= 1")
            if last < first:
                raise argparse.ArgumentTypeError(
                    f"bad frame range {item.strip()!r}: end {last} is before start {first}"
                )
            frames.extend(float(f) for f in range(first, last + 1, step))
        elif _NUMBER.match(item):
            frames.append(_finite_frame(item))
        else:
            raise argparse.ArgumentTypeError(
                f"bad frame list {text!r}: expected N, A-B or A-BxStep items separated by commas"
            )
    return list(dict.fromkeys(frames))


def _finite_frame(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad frame {text!r}: not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"bad frame {text!r}: must be finite")
    return value


_PATTERN = re.compile(r"#+|%0?(\d*)d")


def has_frame_pattern(name: str) -> bool:
    """True if ``name`` has a ``####`` run or a ``%04d`` printf pattern."""
    return _PATTERN.search(name) is not None


def format_frame(frame: float, width: int) -> str:
    """Zero-padded frame number; fractional time codes keep their fraction (``0001.5``)."""
    frame = float(frame)
    if frame.is_integer():
        return f"{int(frame):0{width}d}"
    text = np.format_float_positional(abs(frame), trim="-")
    whole, frac = text.split(".")
    sign = "-" if frame < 0 else ""
    return sign + whole.zfill(max(width - len(sign), 0)) + "." + frac


def expand_output(pattern: str, frame: float) -> str:
    """Replace every ``#`` run (width = its length) and ``%0Nd`` by the frame number."""

    def repl(m: re.Match) -> str:
        if m.group(0).startswith("#"):
            width = len(m.group(0))
        else:
            width = int(m.group(1)) if m.group(1) else 0
        return format_frame(frame, width)

    return _PATTERN.sub(repl, pattern)


def _frame_label(frame: float) -> str:
    return str(int(frame)) if float(frame).is_integer() else repr(float(frame))


def _frames_label(frames: list[float]) -> str:
    """Compact list: consecutive integers grouped as ranges ("0-2, 5, 7.5")."""
    if not frames:
        return "none"
    parts: list[str] = []
    run: list[int] = []

    def flush():
        if run:
            parts.append(str(run[0]) if len(run) == 1 else f"{run[0]}-{run[-1]}")
            run.clear()

    for f in sorted(frames):
        if float(f).is_integer() and (not run or int(f) == run[-1] + 1):
            run.append(int(f))
            continue
        flush()
        if float(f).is_integer():
            run.append(int(f))
        else:
            parts.append(_frame_label(f))
    flush()
    return ", ".join(parts)


# --- argument parsing ----------------------------------------------------------


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def _non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not math.isfinite(value) or value < 0.0:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def _non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def _size_arg(text: str) -> int:
    from .limits import parse_size

    try:
        return parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _int_arg(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(
        prog=PROG,
        description="Special-relativistic spacetime renderer: USD scenes -> EXR frames.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{render,inspect,validate}")

    r = sub.add_parser("render", help="render frames of a USD scene to EXR files", prog=f"{PROG} render")
    r.add_argument("scene", metavar="SCENE.usda", help="the USD stage to render")
    r.add_argument(
        "-o", "--output", metavar="OUT.exr",
        help="output file; '#' runs or %%04d are replaced by the frame number "
        "(default: <scene stem>.exr, or <scene stem>.####.exr with --frames)",
    )
    frames = r.add_mutually_exclusive_group()
    frames.add_argument("--frame", type=_finite_frame, metavar="N",
                        help="USD time code to render (default: the stage's start time code, else 0)")
    frames.add_argument("--frames", type=parse_frames, metavar="A-B[xS],...",
                        help="frames to render: inclusive ranges with optional step, comma separated")
    r.add_argument("--camera", metavar="/Path", help="camera prim path")
    r.add_argument("--width", type=_positive_int, metavar="W", help="image width in pixels")
    r.add_argument("--height", type=_positive_int, metavar="H", help="image height in pixels")
    r.add_argument("--max-depth", type=_non_negative_int, metavar="D", help="mirror reflection bounces")
    r.add_argument("--samples", type=_positive_int, metavar="S", help="samples per pixel")
    r.add_argument("--shutter", type=_non_negative_float, metavar="T",
                   help="camera-time interval [t_c, t_c + T] sampled for 4D motion blur (needs --samples > 1)")
    r.add_argument("--doppler-color", action="store_true", default=None,
                   help="shift each surface's colour by its Doppler factor D (off by default)")
    r.add_argument("--searchlight", action="store_true", default=None,
                   help="scale radiance by D^4, the searchlight effect (off by default)")
    r.add_argument("--precision", choices=("float32", "float64"), help="scalar type of the kernels")
    r.add_argument("--light-speed", choices=("finite", "infinite"), help="finite (c = 1) or infinite light speed")
    r.add_argument("--resume", action="store_true", help="skip frames whose output is already a complete EXR")
    r.add_argument("--max-memory", type=_size_arg, metavar="SIZE",
                   help="refuse (exit 2) a render whose estimated memory exceeds SIZE, e.g. 8G or 512M "
                   "(default: 75%% of the physical memory)")
    r.add_argument("--no-references", action="store_true",
                   help="compose only the file's own layers: ignore references and payloads (untrusted stages)")
    r.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")

    i = sub.add_parser("inspect", help="print an EXR's header, channel statistics or a pixel",
                       prog=f"{PROG} inspect")
    i.add_argument("exr", metavar="OUT.exr")
    i.add_argument("--pixel", nargs=2, type=_int_arg, metavar=("X", "Y"),
                   help="print every channel at column X, row Y (row 0 at the top)")
    i.add_argument("--channel", metavar="NAME", help="channel for statistics or --png (RGB: the beauty, sRGB-encoded)")
    i.add_argument("--png", metavar="OUT.png", help="write a false-colour PNG of --channel")

    v = sub.add_parser("validate", help="load a scene and report what it contains", prog=f"{PROG} validate")
    v.add_argument("scene", metavar="SCENE.usda")
    v.add_argument("--no-references", action="store_true",
                   help="compose only the file's own layers: ignore references and payloads")

    from .bench import add_arguments as _bench_arguments  # no warp / pxr import until it runs

    b = sub.add_parser("bench", help="measure speed against error; write docs/performance.md and plots",
                       prog=f"{PROG} bench")
    _bench_arguments(b)
    return parser


# --- render --------------------------------------------------------------------


def _plan_outputs(args, scene_path: Path, frames: list[float], frames_given: bool) -> list[Path]:
    pattern = args.output
    if pattern is None:
        pattern = f"{scene_path.stem}.####.exr" if frames_given else f"{scene_path.stem}.exr"
    if len(frames) > 1 and not has_frame_pattern(pattern):
        raise UsageError(
            f"{len(frames)} frames need a frame pattern in the output name "
            f"(e.g. OUT.####.exr or OUT.%04d.exr), got {pattern!r}"
        )
    outputs = [Path(expand_output(pattern, f)) for f in frames]
    if len(set(outputs)) != len(outputs):
        raise UsageError(f"output pattern {pattern!r} gives several frames the same file name")
    from .exr import check_output_path

    for out in outputs:
        try:
            check_output_path(out)
        except OSError as exc:
            raise UsageError(exc.strerror or str(exc)) from None
    return outputs


@contextlib.contextmanager
def _held_diagnostics():
    """Hold back the reader's Python warnings and what USD prints on fd 2 during the block.

    On bad input only the one error line is printed (SPEC §6), so what was held is
    dropped when the block raises; on success it is printed (each warning as one line).
    """
    import tempfile
    import warnings

    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # pragma: no cover - no fd 2
        saved = None
    with tempfile.TemporaryFile() as sink, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if saved is not None:
            os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            if saved is not None:
                sys.stderr.flush()
                os.dup2(saved, 2)
                os.close(saved)
        sink.seek(0)
        native = sink.read().decode("utf-8", "replace").rstrip()
    if native:
        print(native, file=sys.stderr)
    for w in caught:
        print(f"{PROG}: warning: {' '.join(str(w.message).split())}", file=sys.stderr)


@contextlib.contextmanager
def _address_space_cap(budget: int | None):
    """Lower the soft RLIMIT_AS to the current size + ``budget`` for the block (Linux).

    A corrupt .usdc can make USD's crate reader allocate and touch tens of GiB (the
    fuzzer found one that drew the OOM killer); under the cap the allocation fails and
    USD reports the file as corrupt instead. Restored afterwards; a no-op where
    unsupported.
    """
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        with open("/proc/self/statm") as fh:
            current = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (ImportError, OSError, ValueError, AttributeError):
        yield
        return
    cap = current + int(budget) if budget else None
    if cap is None or (soft != resource.RLIM_INFINITY and soft <= cap) or (
            hard != resource.RLIM_INFINITY and hard < cap):
        yield
        return
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


_CRATE_MAGIC = b"PXR-USDC"
_ASSET = re.compile(rb"@([^@\n]+)@")


def _uses_crate_layers(path: Path, depth: int = 0, seen: set | None = None) -> bool:
    """True if ``path`` or a layer its text names (transitively, 16 deep) is a binary crate file."""
    seen = set() if seen is None else seen
    try:
        path = path.resolve()
        if path in seen or depth > 16 or not path.is_file():
            return False
        seen.add(path)
        with open(path, "rb") as fh:
            data = fh.read(64 << 20)
    except (OSError, ValueError):  # unreadable, or a name with a NUL byte
        return False
    if data.startswith(_CRATE_MAGIC):
        return True
    for match in _ASSET.finditer(data):
        name = match.group(1).decode("utf-8", "replace")
        if _uses_crate_layers(path.parent / name, depth + 1, seen):
            return True
    return False


_PROBE = """
import resource, sys
budget = int(sys.argv[3])
if budget:
    try:
        resource.setrlimit(resource.RLIMIT_AS, (budget, resource.getrlimit(resource.RLIMIT_AS)[1]))
    except (ValueError, OSError):
        pass
import warp_st
try:
    warp_st.load(sys.argv[1], no_references=sys.argv[2] == "1")
except Exception:
    sys.exit(3)
"""


def _probe_in_child(scene_path: Path, no_references: bool, budget: int | None) -> None:
    """Read the stage once in a child process before reading it here.

    USD's binary (crate) reader can crash on a corrupt file (the fuzzer found
    segmentation faults inside ``Usd.Stage.Open``); a crash of the child becomes a
    SceneError instead of taking this process down. Errors the child reports are left
    for the in-process read to report with its usual message.
    """
    import signal
    import subprocess

    import warp_st

    env = dict(os.environ)
    package_root = str(Path(warp_st.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    cap = str(int(budget) if budget else 0)  # a runaway read aborts the child, not the machine
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE, str(scene_path), "1" if no_references else "0", cap],
                              env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, timeout=600)
    except subprocess.TimeoutExpired:
        raise SceneError(f"{scene_path}: reading it did not finish in 600 s; the file may be corrupt") from None
    except OSError:
        return  # no child processes here: read in-process as before
    if proc.returncode < 0:
        name = signal.Signals(-proc.returncode).name if -proc.returncode in signal.valid_signals() else str(-proc.returncode)
        raise SceneError(f"{scene_path}: USD crashed reading it ({name}): the file or a binary layer it uses "
                         "is corrupt")


def _load(scene_path: Path, no_references: bool, max_memory: int | None = None):
    """warp_st.load with its diagnostics held back (see _held_diagnostics) and its
    memory capped (see _address_space_cap); stages with binary layers are first read
    in a child process (see _probe_in_child)."""
    import warp_st
    from .limits import default_max_memory

    if _uses_crate_layers(scene_path):
        _probe_in_child(scene_path, no_references, default_max_memory())

    # Reading needs far less than rendering; the cap only stops runaway reads. (A low cap
    # is worse than none: USD aborts on some failed allocations instead of reporting them.)
    budget = max(filter(None, (max_memory, default_max_memory())), default=None)
    with _held_diagnostics(), _address_space_cap(budget):
        try:
            return warp_st.load(str(scene_path), no_references=no_references)
        except MemoryError:
            raise SceneError(f"{scene_path}: reading it needs more memory than the limit "
                             "(--max-memory); the file may be corrupt") from None


def _file_hash(path: Path) -> str:
    """sha256 of the file's bytes (the stage's root layer), as ``sha256:HEX``."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return f"sha256:{digest.hexdigest()}"


def _options_text(args) -> str:
    names = ("camera", "width", "height", "max_depth", "samples", "shutter", "doppler_color", "searchlight",
             "precision", "light_speed", "no_references")
    return " ".join(f"{n}={getattr(args, n)}" for n in names if getattr(args, n) not in (None, False))


def _cmd_render(args, argv: list[str]) -> int:
    import warp_st
    from .conventions import LightSpeed, Precision
    from .exr import is_complete_exr

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
        _plan_outputs(args, scene_path, frames, frames_given)
    stage_hash = _file_hash(scene_path)
    scene = _load(scene_path, args.no_references, args.max_memory)
    if frames is None:
        frames = [float(scene.frame_range[0])] if scene.frame_range is not None else [0.0]
    outputs = _plan_outputs(args, scene_path, frames, frames_given)

    complete: list[float] = []
    todo: list[tuple[float, Path]] = []
    for frame, out in zip(frames, outputs):
        if args.resume and is_complete_exr(out):
            complete.append(frame)
            if not args.quiet:
                print(f"frame {_frame_label(frame)}: complete, skipped ({out})")
        else:
            todo.append((frame, out))
    if not todo:
        if not args.quiet:
            print(f"all {len(frames)} frame(s) already complete")
        return 0

    try:
        from .renderer import Renderer

        with _held_diagnostics():  # the camera is evaluated per frame here
            renderer = Renderer(
                scene,
                frames=[f for f, _ in todo],
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
            for frame, out in todo:
                start = time.perf_counter()
                image = renderer.render(frame)
                for key, value in metadata.items():
                    image.metadata.setdefault(key, value)
                image.write_exr(out)
                complete.append(frame)
                seconds = time.perf_counter() - start
                if bar is not None:
                    bar.set_postfix_str(f"frame {_frame_label(frame)} {seconds:.2f}s")
                    bar.update(1)
                elif not args.quiet:
                    print(f"frame {_frame_label(frame)}: {seconds:.2f} s -> {out}", flush=True)
        finally:
            if bar is not None:
                bar.close()
    except KeyboardInterrupt as exc:
        print(
            f"{PROG}: {_interruption(exc)}; frames complete: {_frames_label(complete)} "
            f"({len(complete)} of {len(frames)}); rerun with --resume to continue",
            file=sys.stderr,
        )
        return _interrupted_status(exc)
    except OSError as exc:  # e.g. disk full: the frames written so far are complete
        _error(f"{exc}; frames complete: {_frames_label(complete)} ({len(complete)} of {len(frames)}); "
               "rerun with --resume to continue")
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1
    return 0


# --- inspect -------------------------------------------------------------------


def _fmt(value, dtype) -> str:
    """Exact shortest text of a numpy scalar (float32 prints as float32, not widened)."""
    dtype = np.dtype(dtype)
    if dtype.kind == "u":
        return str(int(value))
    return str(dtype.type(value))


def _stats_row(name: str, plane: np.ndarray) -> str:
    kind = "UINT" if plane.dtype.kind == "u" else "FLOAT"
    if plane.dtype.kind == "f":
        finite = plane[np.isfinite(plane)]
        nan = int(np.isnan(plane).sum())
        pinf = int(np.isposinf(plane).sum())
        ninf = int(np.isneginf(plane).sum())
    else:
        finite, nan, pinf, ninf = plane, 0, 0, 0
    if finite.size:
        if plane.dtype.kind == "u":
            lo, hi = str(int(finite.min())), str(int(finite.max()))
        else:
            lo, hi = _fmt(finite.min(), plane.dtype), _fmt(finite.max(), plane.dtype)
        digits = 16 if plane.dtype == np.float64 else 9
        mean = f"{float(np.mean(finite, dtype=np.float64)):.{digits}g}"
    else:
        lo = hi = mean = "-"
    return f"  {name:<22} {kind:<5} {lo:>20} {hi:>20} {mean:>22} {nan:>7} {pinf:>7} {ninf:>7}"


def _print_stats(image, names) -> None:
    print(f"  {'channel':<22} {'type':<5} {'min':>20} {'max':>20} {'mean':>22} {'nan':>7} {'+inf':>7} {'-inf':>7}")
    for name in names:
        print(_stats_row(name, image.channel(name)))


def _prim_for(image, object_id: int) -> str:
    if object_id == 0:
        return "none (background)"
    return image.id_manifest.get(object_id, f"unknown (objectId {object_id} not in idManifest)")


BEAUTY = "RGB"


def _write_beauty_png(image, png_path: Path) -> None:
    """The beauty as an 8-bit sRGB PNG (linear values clipped to [0, 1], no colour bar)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .exr import atomic_output

    linear = np.clip(np.nan_to_num(image.rgba[..., :3].astype(np.float64)), 0.0, 1.0)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)
    with atomic_output(png_path) as fh:
        plt.imsave(fh, srgb, format="png")


def _write_png(image, exr_path: Path, name: str, png_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .exr import atomic_output
    from .film import channel_spec

    spec = channel_spec(name)
    plane = image.channel(name)
    label = spec.units
    if spec.relative_time:
        plane = plane - image.time_origin
        label = f"{spec.units}\nrelative to spacetime:timeOrigin = {image.time_origin!r}"
    data = np.ma.masked_invalid(np.asarray(plane, dtype=np.float64))
    # grey: NaN / inf (the background of most AOVs)
    cmap = plt.get_cmap("tab20" if name == "objectId" else "viridis").with_extremes(bad="0.5")
    dpi = 100
    fig_w = max(4.0, min(12.0, image.width / dpi + 1.5))
    fig_h = max(3.0, fig_w * image.height / max(image.width, 1))
    fig, ax = plt.subplots(figsize=(fig_w, fig_h), dpi=dpi)
    try:
        shown = ax.imshow(data, cmap=cmap, interpolation="nearest")
        bar = fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.04)
        bar.set_label(label)
        ax.set_title(f"{exr_path.name}: {name}")
        ax.set_xlabel("x (pixels)")
        ax.set_ylabel("y (pixels)")
        with atomic_output(png_path) as fh:
            fig.savefig(fh, format="png", bbox_inches="tight")
    finally:
        plt.close(fig)


def _cmd_inspect(args) -> int:
    from .exr import check_output_path, read_exr, read_header
    from .film import CHANNEL_NAMES

    path = Path(args.exr)
    if args.png and not args.channel:
        raise UsageError("--png needs --channel NAME")
    if args.channel == BEAUTY and args.png:
        image = read_exr(path)
        check_output_path(args.png)
        _write_beauty_png(image, Path(args.png))
        print(f"wrote {args.png}")
        return 0
    if args.channel is not None and args.channel not in CHANNEL_NAMES:
        raise UsageError(f"unknown channel {args.channel!r}; known: {', '.join(CHANNEL_NAMES)}")
    image = read_exr(path)
    if args.channel is not None and args.channel not in image.channel_names:
        raise UsageError(f"{path}: has no channel {args.channel!r}")
    if args.pixel is not None:
        x, y = args.pixel
        if not (0 <= x < image.width and 0 <= y < image.height):
            raise UsageError(
                f"pixel ({x}, {y}) is outside the {image.width} x {image.height} image "
                f"(x in 0..{image.width - 1}, y in 0..{image.height - 1})"
            )
    if args.png:
        try:
            check_output_path(args.png)
        except OSError as exc:
            raise UsageError(exc.strerror or str(exc)) from None

    if args.pixel is not None:
        x, y = args.pixel
        print(f"{path}: pixel x={x} y={y}")
        for name in image.channel_names:
            plane = image.channel(name)
            text = _fmt(plane[y, x], plane.dtype)
            spec_rel = name in ("spacetime.eventTime", "spacetime.sourceTime")
            if spec_rel and np.isfinite(plane[y, x]):
                text += f"  (relative {_fmt(image.file_channel(name)[y, x], np.float32)})"
            print(f"  {name:<22} {text}")
        object_id = int(image.object_id[y, x])
        print(f"  prim: {_prim_for(image, object_id)}")
    elif args.channel is not None and not args.png:
        _print_stats(image, [args.channel])
    elif not args.png:
        print(f"file: {path}")
        print(f"size: {image.width} x {image.height}")
        print("header:")
        for key, value in read_header(path).items():
            print(f"  {key}: {value}")
        if image.id_manifest:
            print("idManifest (objectId -> prim path):")
            for object_id, prim in sorted(image.id_manifest.items()):
                print(f"  {object_id}: {prim}")
        print("channels (min / max / mean over finite values; eventTime, sourceTime absolute):")
        _print_stats(image, image.channel_names)
    if args.png:
        _write_png(image, path, args.channel, Path(args.png))
        print(f"wrote {args.png}")
    return 0


# --- validate ------------------------------------------------------------------


def _cmd_validate(args) -> int:
    import warp_st

    scene_path = Path(args.scene)
    if not scene_path.is_file():
        raise UsageError(f"{scene_path}: no such file")
    scene = _load(scene_path, args.no_references)
    print(f"ok: {len(scene.bodies)} bodies, {len(scene.cameras)} cameras, {len(scene.lights)} lights")
    return 0


# --- entry point ---------------------------------------------------------------


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGHUP) delivered to the command line: stop like ^C, exit 128 + signal."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _interruption(exc: BaseException) -> str:
    if isinstance(exc, Terminated):
        import signal

        return f"terminated by {signal.Signals(exc.signum).name}"
    return "interrupted"


def _interrupted_status(exc: BaseException) -> int:
    return 128 + exc.signum if isinstance(exc, Terminated) else 130


@contextlib.contextmanager
def _terminate_as_interrupt():
    """While the command runs, SIGTERM / SIGHUP raise :class:`Terminated` in the main thread
    (so outputs are finished or rolled back exactly as on ^C); the old handlers come back after."""
    import signal

    def handler(signum, frame):
        raise Terminated(signum)

    saved = {}
    for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is None:
            continue
        try:
            saved[sig] = signal.signal(sig, handler)
        except (ValueError, OSError):  # not the main thread, or not supported here
            pass
    try:
        yield
    finally:
        for sig, old in saved.items():
            with contextlib.suppress(ValueError, OSError):
                signal.signal(sig, old)


def _error(message: str) -> None:
    message = " ".join(str(message).split())  # one line, always
    print(f"{PROG}: error: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Run ``warp-st`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    with _terminate_as_interrupt():
        return _main(argv)


def _main(argv: list[str]) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.command is None:
            raise UsageError("a command is required: render, inspect or validate (see --help)")
        if args.command == "render":
            return _cmd_render(args, argv)
        if args.command == "inspect":
            return _cmd_inspect(args)
        if args.command == "bench":
            from . import bench

            return bench.run(bench._finish_args(args, parser.error))
        return _cmd_validate(args)
    except SystemExit as exc:  # --help / --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except UsageError as exc:
        _error(str(exc))
        return 2
    except SceneError as exc:
        _error(str(exc))
        return 2
    except KeyboardInterrupt as exc:
        print(f"{PROG}: {_interruption(exc)}", file=sys.stderr)
        return _interrupted_status(exc)
    except OSError as exc:  # e.g. disk full while writing: not a bug, not bad input
        _error(str(exc))
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1
    except Exception as exc:  # noqa: BLE001 - the last resort of a command line
        print(f"{PROG}: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
