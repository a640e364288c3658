"""Thesis Fig. 4.6: four flanges converging, then crossing at 0.866c on a mirrored background.

Renders the three modes of ``usd_scenes/mirrors/`` (one row each) at five frames
(columns: approaching, converging, crossing, departing, leaving) into one PNG strip:

- top: infinite light speed, classical flanges (what conventional rendering shows);
- middle: finite light speed, Lorentz-decoupled flanges (retardation and classical
  aberration only; camera 18.675 time units ahead, the stage-to-camera light delay);
- bottom: finite light speed, Lorentz-coupled flanges (contracted to half width, which
  the light delay turns into Terrell rotation).

Each mode is one ``Renderer``: its 4D database is built once and the five frames only move
the camera along its time axis. The mirror shows each flange from behind by light that
travelled further, so in the finite-c rows the reflections lag behind the flanges.

    python examples/mirrored_flanges.py [--out docs/images/mirrors_fig4_6.png]
                                        [--width 160 --height 120] [--quick]
                                        [--aovs docs/images/mirrors_aovs.png]

``--aovs`` also writes the light-transport AOVs of the relativistic crossing frame:
beauty, the first hit's lookback t_c - eventTime, the extra delay the mirrors add
eventTime - sourceTime, and the bounce count.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import warp_st  # noqa: E402
from warp_st.rendering.renderer import Renderer  # noqa: E402

SCENES = ROOT / "usd_scenes" / "mirrors"
MODES = (
    ("infinite", "infinite c, classical"),
    ("decoupled", "finite c, decoupled"),
    ("coupled", "finite c, relativistic"),
)
FRAMES = (0, 30, 60, 90, 120)  # camera times -6, -3, 0, 3, 6 (+ 18.675 with finite c)
COLUMNS = ("approaching", "converging", "crossing", "departing", "leaving")


def to_srgb(rgb: np.ndarray) -> np.ndarray:
    """Linear beauty -> 8-bit sRGB (clipped)."""
    x = np.clip(rgb, 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return (srgb * 255.0 + 0.5).astype(np.uint8)


def render_strip(width: int, height: int, *, quiet: bool = False) -> tuple[np.ndarray, dict]:
    """The 3 x 5 tiles as one sRGB array (rows: modes, columns: frames) and statistics."""
    rows, stats = [], {}
    for mode, _label in MODES:
        scene = warp_st.load(SCENES / f"flanges_{mode}.usda")
        t0 = time.perf_counter()
        renderer = Renderer(scene, frames=FRAMES, width=width, height=height)
        tiles = [renderer.render(f) for f in FRAMES]
        stats[mode] = {
            "seconds": time.perf_counter() - t0,
            "tetrahedra": renderer.stats.tetrahedra,
            "camera_times": [t.camera_time for t in tiles],
            "max_bounces": int(max(t.bounces.max() for t in tiles)),
        }
        rows.append(np.concatenate([to_srgb(t.rgba[..., :3]) for t in tiles], axis=1))
        if not quiet:
            s = stats[mode]
            print(f"{mode:9s}: {len(FRAMES)} frames {width}x{height} in {s['seconds']:.1f} s "
                  f"({s['tetrahedra']} tetrahedra), camera times "
                  + ", ".join(f"{t:g}" for t in s["camera_times"]))
    return np.concatenate(rows, axis=0), stats


def save_figure(strip: np.ndarray, width: int, height: int, out: Path) -> None:
    """The strip with row and column labels (matplotlib, Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dpi = 100
    margin_l, margin_t = 1.3, 0.3  # inches
    fig_w = strip.shape[1] / dpi + margin_l + 0.05
    fig_h = strip.shape[0] / dpi + margin_t + 0.05
    fig = plt.figure(figsize=(fig_w, fig_h), dpi=dpi)
    ax = fig.add_axes([margin_l / fig_w, 0.05 / fig_h, strip.shape[1] / dpi / fig_w, strip.shape[0] / dpi / fig_h])
    ax.imshow(strip, interpolation="nearest")
    ax.set_xticks([(i + 0.5) * width for i in range(len(FRAMES))])
    ax.set_xticklabels([f"{c}\nframe {f}" for c, f in zip(COLUMNS, FRAMES)], fontsize=7)
    ax.xaxis.set_ticks_position("top")
    ax.set_yticks([(i + 0.5) * height for i in range(len(MODES))])
    ax.set_yticklabels([label for _m, label in MODES], fontsize=7)
    ax.tick_params(length=0, pad=2)
    for side in ax.spines.values():
        side.set_visible(False)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, bbox_inches="tight", pad_inches=0.05)
    plt.close(fig)


def save_aovs(out: Path, width: int, height: int, mode: str = "coupled", frame: int = 60) -> None:
    """Beauty, t_c - eventTime, eventTime - sourceTime and bounces of one frame, side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = warp_st.load(SCENES / f"flanges_{mode}.usda")
    img = Renderer(scene, frames=[frame], width=width, height=height).render(frame)
    t_c = img.camera_time
    panels = [
        ("beauty (sRGB)", to_srgb(img.rgba[..., :3]), None, None),
        ("t_c - eventTime (first hit)", t_c - img.event_time, "viridis", "time units"),
        ("eventTime - sourceTime (mirror delay)", img.event_time - img.source_time, "magma", "time units"),
        ("bounces", img.bounces.astype(float), "cividis", "reflections"),
    ]
    fig, axes = plt.subplots(1, 4, figsize=(4 * width / 100 + 1.6, height / 100 + 0.9), dpi=100)
    for ax, (title, data, cmap, unit) in zip(axes, panels):
        shown = ax.imshow(data, cmap=cmap, interpolation="nearest")
        ax.set_title(title, fontsize=8)
        ax.set_axis_off()
        if cmap is not None:
            bar = fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.02)
            bar.ax.tick_params(labelsize=6)
            bar.set_label(unit, fontsize=6)
    fig.suptitle(f"flanges_{mode}.usda, frame {frame} (t_c = {t_c:g}); NaN / background: white", fontsize=8)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100, bbox_inches="tight", pad_inches=0.05)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "images" / "mirrors_fig4_6.png"))
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=120)
    parser.add_argument("--quick", action="store_true", help="tiny tiles (64 x 48): a smoke test")
    parser.add_argument("--aovs", default=None, help="also write the AOV panel of the relativistic crossing frame")
    args = parser.parse_args(argv)
    width, height = (64, 48) if args.quick else (args.width, args.height)
    strip, _stats = render_strip(width, height)
    out = Path(args.out)
    save_figure(strip, width, height, out)
    print(f"wrote {out} ({strip.shape[1]} x {strip.shape[0]} px of tiles)")
    if args.aovs:
        save_aovs(Path(args.aovs), 2 * width, 2 * height)
        print(f"wrote {args.aovs}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
