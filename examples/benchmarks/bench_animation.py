"""Render time against error of the animation pieces (issue 18 item 1; a benchmark: it asserts nothing).

Each animated example (examples/animation/*.usda) is rendered at a few ``pixels``
tolerances of ``warp_st.spacetime.animation`` (the renderer's rule is 0.5: pieces of
uniform motion within half a pixel of USD's surface in every frame). Per tolerance it
prints the motion segments (pieces), the time to cut them, build the database and render
the frames (one cold run per tolerance: the database is built anew for new pieces; kernels
are compiled once beforehand), and the measured error against a reference rendered at a
much finer tolerance: the pixels whose objectId differs (the silhouette moved), as a
fraction of the animated body's pixels, and the median eventTime difference over the
pixels both renders see the body in (the tail is the grazing pixels at the silhouette,
where a tiny shift of the surface moves the hit far along the ray). Writes a table (stdout, and ``--out`` markdown) and
the curve time -> error (``--plot`` PNG, matplotlib).

    python3 examples/benchmarks/bench_animation.py                       # 160 x 90, 2 frames each
    python3 examples/benchmarks/bench_animation.py --quick               # smoke run
    python3 examples/benchmarks/bench_animation.py --plot docs/images/animation_time_error.png
"""
from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchlib.machine import cpu_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "animation"
#: Frames rendered per example (where the body is in view and moving).
FRAMES = {"circular_orbit": (35.0, 50.0), "rolling_wheel": (56.0, 60.0),
          "spinning_rod": (40.0, 50.0), "hyperbolic_rocket": (20.0, 50.0)}
TOLERANCES = (4.0, 2.0, 1.0, 0.5)
REFERENCE = 1.0 / 8.0


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=90)
    p.add_argument("--quick", action="store_true", help="tiny images, two tolerances, one frame")
    p.add_argument("--scenes", default=",".join(FRAMES), help="comma-separated example names")
    p.add_argument("--out", type=Path, help="also write the table as markdown here")
    p.add_argument("--plot", type=Path, help="write the time -> error curve as a PNG here")
    return p.parse_args(argv)


def render_at(scene, frames, width, height, pixels):
    """(pieces, seconds, images) of ``frames`` with the pieces within ``pixels`` pixels."""
    from warp_st.rendering import renderer as renderer_module
    from warp_st.spacetime.animation import animation_cuts, piece_count

    renderer_module.animation_cuts = functools.partial(animation_cuts, pixels=pixels)
    try:
        t0 = time.perf_counter()
        r = renderer_module.Renderer(scene, frames=list(frames), width=width, height=height)
        images = [r.render(f) for f in frames]
        seconds = time.perf_counter() - t0
    finally:
        renderer_module.animation_cuts = animation_cuts
    pieces = sum(piece_count(rows) for _i, rows in r.animation)
    return pieces, seconds, images


def errors(images, reference, ids):
    """(fraction of the body's reference pixels whose objectId differs, median eventTime difference)."""
    wrong = body = 0
    dts = [np.zeros(0)]
    for img, ref in zip(images, reference):
        mine, theirs = np.isin(img.object_id, ids), np.isin(ref.object_id, ids)
        wrong += int(((img.object_id != ref.object_id) & (mine | theirs)).sum())
        body += int(theirs.sum())
        both = mine & theirs
        dts.append(np.abs(img.event_time[both].astype(np.float64) - ref.event_time[both]))
    dts = np.concatenate(dts)
    return wrong / max(body, 1), float(np.median(dts)) if dts.size else 0.0


def measure(names, width, height, tolerances, frames_of):
    import warp_st

    rows = []
    for name in names:
        scene = warp_st.load(str(EXAMPLES / f"{name}.usda"))
        ids = [i + 1 for i, b in enumerate(scene.bodies) if b.motion is not None]
        frames = frames_of(name)
        render_at(scene, frames[:1], 16, 9, 2.0)  # compile the kernels once, outside the timings
        print(f"{name}: reference at {REFERENCE:g} px", file=sys.stderr)
        ref_pieces, ref_seconds, reference = render_at(scene, frames, width, height, REFERENCE)
        for pixels in tolerances:
            print(f"{name}: {pixels:g} px", file=sys.stderr)
            pieces, seconds, images = render_at(scene, frames, width, height, pixels)
            wrong, dt = errors(images, reference, ids)
            rows.append({"scene": name, "pixels": pixels, "pieces": pieces, "seconds": seconds,
                         "wrong": wrong, "event_dt": dt, "reference_pieces": ref_pieces,
                         "reference_seconds": ref_seconds})
    return rows


def table(rows, width, height, frames) -> str:
    lines = [f"CPU: {cpu_model()}", f"{width} x {height}, {frames} frames per scene; error against the "
             f"pieces at {REFERENCE:g} px", "",
             "| scene | tolerance (px) | segments | time (s) | objectId differs (of body px) | median eventTime diff |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['pixels']:g} | {r['pieces']} | {r['seconds']:.2f} | "
                     f"{100 * r['wrong']:.2f} % | {r['event_dt']:.3g} |")
    return "\n".join(lines)


def plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=120)
    for name in dict.fromkeys(r["scene"] for r in rows):
        mine = [r for r in rows if r["scene"] == name]
        ax.plot([r["seconds"] for r in mine], [100 * r["wrong"] for r in mine], "o-", label=name)
        for r in mine:
            ax.annotate(f"{r['pixels']:g}", (r["seconds"], 100 * r["wrong"]), fontsize=7,
                        textcoords="offset points", xytext=(3, 3))
    ax.set_xscale("log")
    ax.set_xlabel("cut + build + render time (s, log)")
    ax.set_ylabel("objectId pixels differing from the reference (%)")
    ax.set_title(f"animation pieces: time against error (labels: tolerance in px)\n{cpu_model()}", fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    args = parse_args(argv)
    names = [n for n in args.scenes.split(",") if n]
    width, height, tolerances = args.width, args.height, TOLERANCES
    frames_of = FRAMES.get
    if args.quick:
        width, height, tolerances = 48, 27, (2.0, 0.5)
        frames_of = lambda name: FRAMES[name][1:2]  # noqa: E731
    rows = measure(names, width, height, tolerances, frames_of)
    text = table(rows, width, height, len(frames_of(names[0])))
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    if args.plot:
        plot(rows, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
