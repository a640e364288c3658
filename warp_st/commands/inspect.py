"""``warp-st inspect``: an EXR's header, channel statistics, one pixel, false-colour PNGs."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .common import UsageError, int_arg


def add_arguments(parser) -> None:
    """The options of ``warp-st inspect``."""
    parser.add_argument("exr", metavar="OUT.exr")
    parser.add_argument("--pixel", nargs=2, type=int_arg, metavar=("X", "Y"),
                        help="print every channel at column X, row Y (row 0 at the top)")
    parser.add_argument("--channel", metavar="NAME", help="channel for statistics or --png (RGB: the beauty, sRGB-encoded)")
    parser.add_argument("--png", metavar="OUT.png", help="write a false-colour PNG of --channel")


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

    from ..exr import atomic_output

    linear = np.clip(np.nan_to_num(image.rgba[..., :3].astype(np.float64)), 0.0, 1.0)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)
    with atomic_output(png_path) as fh:
        plt.imsave(fh, srgb, format="png")


def _write_png(image, exr_path: Path, name: str, png_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..exr import atomic_output
    from ..film import channel_spec

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


def run(args) -> int:
    from ..exr import check_output_path, read_exr, read_header
    from ..film import CHANNEL_NAMES

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
