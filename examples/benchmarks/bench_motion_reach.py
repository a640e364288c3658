#!/usr/bin/env python3
"""Issue 18's visibility clipping of animated bodies: pieces, database build, frame time.

A benchmark, not a test: it asserts nothing. For each animated example
(``examples/animation/*.usda`` whose bodies USD moves) and each frame set (one frame, and
a sequence of ``--sequence`` frames ending at it), a ``Renderer`` is built at ``--size``
and every frame rendered: the animated bodies' pieces (``describe()["animated_segments"]``),
the database build (the renderer's construction; kernels compiled beforehand) and the
median frame time. Run it from another checkout (``PYTHONPATH=<checkout>``) for the
numbers before the clipping; ``--unclipped`` cuts every chunk with this checkout's code.

    python3 examples/benchmarks/bench_motion_reach.py
    python3 examples/benchmarks/bench_motion_reach.py --unclipped
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchlib.machine import cpu_model  # noqa: E402

EXAMPLES = ("circular_orbit", "spinning_rod", "rolling_wheel", "hyperbolic_rocket")


def measure(name: str, frames: list[float], width: int, height: int) -> dict:
    import warp_st
    from warp_st.rendering import database_cache
    from warp_st.rendering.renderer import Renderer

    scene = warp_st.load(str(ROOT / "examples" / "animation" / f"{name}.usda"))
    database_cache.clear()
    t0 = time.perf_counter()
    renderer = Renderer(scene, frames=frames, width=width, height=height)
    build = time.perf_counter() - t0
    times = []
    for f in frames:
        t1 = time.perf_counter()
        renderer.render(f)
        times.append(time.perf_counter() - t1)
    return {"pieces": renderer.describe()["animated_segments"], "build_s": build,
            "frame_ms": 1e3 * statistics.median(times)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--frame", type=float, default=70.0, help="the single frame, and the sequence's last")
    ap.add_argument("--sequence", type=int, default=10, help="frames of the sequence (one apart)")
    ap.add_argument("--unclipped", action="store_true", help="cut every chunk (this checkout's code)")
    ap.add_argument("--examples", default=",".join(EXAMPLES))
    args = ap.parse_args(argv)
    width, height = (int(x) for x in args.size.split("x"))
    import warp_st

    if args.unclipped:
        from warp_st.rendering import renderer as renderer_module
        renderer_module.motion_reach = lambda scene, margins, **_: {}
    warp_st.render(warp_st.load(str(ROOT / "examples" / "animation" / "spinning_rod.usda")), frame=0.0,
                   width=8, height=8)  # kernels compiled and loaded
    print(f"CPU: {cpu_model()}")
    print(f"warp_st from {Path(warp_st.__file__).resolve().parents[1]}{' (unclipped)' if args.unclipped else ''}, "
          f"{width} x {height}")
    print("| example | frames | pieces | database build s | frame ms |")
    print("|---|---|---|---|---|")
    sequence = [args.frame - k for k in range(args.sequence - 1, -1, -1)]
    for name in args.examples.split(","):
        for label, frames in ((f"{args.frame:g}", [args.frame]), (f"{sequence[0]:g}-{sequence[-1]:g}", sequence)):
            r = measure(name, frames, width, height)
            print(f"| {name} | {label} | {r['pieces']:,} | {r['build_s']:.2f} | {r['frame_ms']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
