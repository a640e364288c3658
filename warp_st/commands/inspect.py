"""``warp-st inspect``: an EXR's header and channel statistics, one pixel, false-colour PNGs,
a contact sheet of a sequence, and the difference of two EXRs (docs/inspect_validate.md).

    warp-st inspect OUT.exr                                   header, idManifest, statistics
    warp-st inspect OUT.exr --pixel X Y                       every channel at a pixel, the hit prim
    warp-st inspect OUT.exr --channel NAME [--png OUT.png]    one channel's statistics / false colour
    warp-st inspect A.exr B.exr ... --contact-sheet OUT.png   a grid of thumbnails (also OUT.####.exr
                                                              with --frames, or a quoted glob)
    warp-st inspect A.exr --diff B.exr [--metric M] [--tolerance T] [--threshold E]

Exit status: 0; 2 on bad input (one line); ``--diff`` exits 1 when the files differ by
more than the tolerance, or in size or channels (as cmp(1) and diff(1) do).
"""
from __future__ import annotations

import glob
import re
from pathlib import Path

import numpy as np

from warp_st.commands.common import UsageError, int_arg, non_negative_float, positive_int
from warp_st.output.plot import BEAUTY


def add_arguments(parser) -> None:
    """The options of ``warp-st inspect``."""
    from warp_st.commands.inspect_diff import METRICS
    from warp_st.core.frames import parse_frames

    parser.add_argument("exr", metavar="OUT.exr", nargs="+",
                        help="the EXR; several (or an OUT.####.exr pattern, or a quoted glob) with --contact-sheet")
    parser.add_argument("--pixel", nargs=2, type=int_arg, metavar=("X", "Y"),
                        help="print every channel at column X, row Y (row 0 at the top) and the hit prim")
    parser.add_argument("--channel", metavar="NAME",
                        help="channel for statistics, --png, --contact-sheet or --diff (RGB: the beauty, sRGB-encoded)")
    parser.add_argument("--png", metavar="OUT.png", help="write a false-colour PNG of --channel")
    sheet = parser.add_argument_group("contact sheet")
    sheet.add_argument("--contact-sheet", metavar="OUT.png",
                       help="write a grid of thumbnails of --channel (default RGB) of every EXR given")
    sheet.add_argument("--frames", type=parse_frames, metavar="A-B[xS],...",
                       help="frames of an OUT.####.exr pattern for --contact-sheet")
    sheet.add_argument("--columns", type=positive_int, metavar="N", help="thumbnails per row (default ~sqrt(count))")
    diff = parser.add_argument_group("difference")
    diff.add_argument("--diff", metavar="B.exr", help="compare OUT.exr with B.exr channel by channel")
    diff.add_argument("--metric", choices=METRICS,
                      help="metric held against --tolerance (default max-abs)")
    diff.add_argument("--tolerance", type=non_negative_float, metavar="T",
                      help="largest allowed value of --metric on every channel (default 0: identical)")
    diff.add_argument("--threshold", type=non_negative_float, metavar="E",
                      help="a pixel differs when |a - b| > E (for 'differing' and the fraction metric; default 0)")


# --- statistics -------------------------------------------------------------------------


def _fmt(value, dtype) -> str:
    """Exact shortest text of a numpy scalar (float32 prints as float32, not widened),
    whatever another library set NumPy's printing to (colour-science sets its 1.13 mode)."""
    dtype = np.dtype(dtype)
    if dtype.kind in "ui":
        return str(int(value))
    with np.printoptions(legacy=False):
        return str(dtype.type(value))


def _stats_row(name: str, plane: np.ndarray) -> str:
    kind = {"u": "UINT", "f": "HALF" if plane.dtype == np.float16 else "FLOAT"}.get(plane.dtype.kind, str(plane.dtype))
    if plane.dtype.kind == "f":
        finite = plane[np.isfinite(plane)]
        nan = int(np.isnan(plane).sum())
        pinf = int(np.isposinf(plane).sum())
        ninf = int(np.isneginf(plane).sum())
    else:
        finite, nan, pinf, ninf = plane.ravel(), 0, 0, 0
    if finite.size:
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


def _print_summary(image, path: Path) -> None:
    from warp_st.output.exr import read_header

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


# --- one pixel ----------------------------------------------------------------------------


def _prim_for(image, object_id: int) -> str:
    if object_id == 0:
        return "none (background)"
    return image.id_manifest.get(object_id, f"unknown (objectId {object_id} not in idManifest)")


def _print_pixel(image, path: Path, x: int, y: int) -> None:
    from warp_st.output.plot import spec_of

    print(f"{path}: pixel x={x} y={y}")
    print(f"  camera time t_c = {image.camera_time!r}, frame {image.frame!r}, "
          f"spacetime:timeOrigin = {image.time_origin!r}")
    for name in image.channel_names:
        plane = image.channel(name)
        value = plane[y, x]
        text = _fmt(value, plane.dtype)
        spec = spec_of(name)
        if spec is not None and spec.relative_time and np.isfinite(value):
            relative = _fmt(image.file_channel(name)[y, x], np.float32)
            lookback = float(image.camera_time) - float(value)
            text += f"  (relative {relative}; t_c - t = {lookback!r})"
        print(f"  {name:<22} {text}")
    if "objectId" in image.channel_names:
        object_id = int(image.object_id[y, x])
        print(f"  prim: {_prim_for(image, object_id)}")


# --- inputs -------------------------------------------------------------------------------

_HASHES = re.compile(r"#+|%0?\d*d")  # as warp_st.core.frames


def _sequence(args) -> list[Path]:
    """The EXRs of --contact-sheet: as given, a ``####`` pattern over --frames (or every
    file the pattern matches), or a glob."""
    from warp_st.core.frames import expand_output, has_frame_pattern

    if len(args.exr) > 1:
        if args.frames is not None:
            raise UsageError("--frames needs a single OUT.####.exr pattern")
        return [Path(p) for p in args.exr]
    name = args.exr[0]
    if has_frame_pattern(name):
        if args.frames is not None:
            return [Path(expand_output(name, f)) for f in args.frames]
        parts = _HASHES.split(name)  # the frame runs are the separators
        regex = re.compile("^" + r"(-?\d+(?:\.\d+)?)".join(re.escape(p) for p in parts) + "$")
        found = sorted((float(m.group(1)), p) for p in glob.glob(_HASHES.sub("*", name))
                       if (m := regex.match(p)))
        if not found:
            raise UsageError(f"no file matches {name}")
        return [Path(p) for _, p in found]
    if args.frames is not None:
        raise UsageError("--frames needs an OUT.####.exr pattern")
    if glob.has_magic(name):
        found = sorted(glob.glob(name))
        if not found:
            raise UsageError(f"no file matches {name}")
        return [Path(p) for p in found]
    return [Path(name)]


def _check_channel(image, path: Path, name: str | None) -> None:
    if name is None or name == BEAUTY:
        return
    if name not in image.channel_names:
        raise UsageError(f"{path}: unknown channel {name!r}; it has {', '.join(image.channel_names)}")


def _check_png(path) -> None:
    from warp_st.output.exr import check_output_path

    try:
        check_output_path(path)
    except OSError as exc:
        raise UsageError(exc.strerror or str(exc)) from None


# --- the command ------------------------------------------------------------------------------


def run(args) -> int:
    modes = [m for m, on in (("--pixel", args.pixel is not None), ("--png", args.png), ("--diff", args.diff),
                             ("--contact-sheet", args.contact_sheet)) if on]
    exclusive = [m for m in modes if m in ("--diff", "--contact-sheet")]
    if exclusive and len(modes) > 1:
        raise UsageError(f"{exclusive[0]} cannot be combined with {', '.join(m for m in modes if m != exclusive[0])}")
    if args.contact_sheet:
        return _contact_sheet(args)
    if len(args.exr) > 1:
        raise UsageError("several EXRs are only taken with --contact-sheet")
    if args.frames is not None or args.columns is not None:
        raise UsageError("--frames and --columns go with --contact-sheet")
    if args.diff:
        return _diff(args)
    if (args.metric, args.tolerance, args.threshold) != (None, None, None):
        raise UsageError("--metric, --tolerance and --threshold go with --diff")
    return _single(args)


def _single(args) -> int:
    from warp_st.output.film import read_exr
    from warp_st.output.plot import write_beauty_png, write_channel_png

    path = Path(args.exr[0])
    if args.png and not args.channel:
        raise UsageError("--png needs --channel NAME")
    if args.channel == BEAUTY and not args.png:
        raise UsageError("--channel RGB is only for pictures (--png, --contact-sheet); for numbers use R, G, B")
    image = read_exr(path)
    _check_channel(image, path, args.channel)
    if args.pixel is not None:
        x, y = args.pixel
        if not (0 <= x < image.width and 0 <= y < image.height):
            raise UsageError(
                f"pixel ({x}, {y}) is outside the {image.width} x {image.height} image "
                f"(x in 0..{image.width - 1}, y in 0..{image.height - 1})"
            )
    if args.png:
        _check_png(args.png)
    if args.pixel is not None:
        _print_pixel(image, path, *args.pixel)
    elif args.channel is not None and not args.png:
        _print_stats(image, [args.channel])
    elif not args.png:
        _print_summary(image, path)
    if args.png:
        if args.channel == BEAUTY:
            write_beauty_png(image, Path(args.png))
        else:
            write_channel_png(image, path, args.channel, Path(args.png))
        print(f"wrote {args.png}")
    return 0


def _contact_sheet(args) -> int:
    from warp_st.output.film import read_exr
    from warp_st.output.plot import write_contact_sheet

    channel = args.channel or BEAUTY
    paths = _sequence(args)
    _check_png(args.contact_sheet)
    images = []
    for path in paths:
        image = read_exr(path)
        _check_channel(image, path, channel)
        images.append(image)
    rows, cols = write_contact_sheet(images, [p.name for p in paths], channel, Path(args.contact_sheet), args.columns)
    print(f"wrote {args.contact_sheet}: {channel} of {len(images)} EXR(s), {rows} x {cols} grid (rows x columns)")
    return 0


def _diff(args) -> int:
    from warp_st.commands.inspect_diff import compare, report
    from warp_st.output.film import read_exr

    path_a, path_b = Path(args.exr[0]), Path(args.diff)
    if args.channel == BEAUTY:
        raise UsageError("--diff compares channels: use R, G, B (and A) rather than RGB")
    image_a, image_b = read_exr(path_a), read_exr(path_b)
    channels = None
    if args.channel is not None:
        _check_channel(image_a, path_a, args.channel)
        _check_channel(image_b, path_b, args.channel)
        channels = [args.channel]
    comparison = compare(image_a, image_b, channels, args.threshold or 0.0)
    lines, ok = report(comparison, str(path_a), str(path_b), args.metric or "max-abs", args.tolerance or 0.0)
    print(f"{path_a} vs {path_b}")
    if image_a.id_manifest != image_b.id_manifest:
        print("note: the idManifests differ: the same objectId may name different prims")
    for line in lines:
        print(line)
    return 0 if ok else 1
