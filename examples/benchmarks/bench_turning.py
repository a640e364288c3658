#!/usr/bin/env python3
"""The spinning rod as pieces of uniform motion against per-vertex worldlines (0.8.0).

A benchmark, not a test: it asserts nothing. For ``examples/animation/spinning_rod.usda`` at
``--size`` and ``--frame`` it builds a ``Renderer`` with ``primitive="rigid"`` (the pieces)
and with the default (the watertight worldlines of ``spacetime/turning.py``, as
tetrahedra leaves of the rigid path), and prints the primitive, the database's bytes, the pieces or sample
intervals (``describe()["animated_segments"]``), the tetrahedra, the build (kernels
compiled beforehand) and the fastest of ``--repeat`` frame renders
(docs/design/turning-bodies.md).

    python3 examples/benchmarks/bench_turning.py --size 640x360
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchlib.machine import cpu_model  # noqa: E402

ROD = ROOT / "examples" / "animation" / "spinning_rod.usda"


def measure(primitive, frame: float, width: int, height: int, repeat: int) -> dict:
    import warp_st
    from warp_st.rendering import database_cache
    from warp_st.rendering.renderer import Renderer

    scene = warp_st.load(str(ROD))
    database_cache.clear()
    t0 = time.perf_counter()
    renderer = Renderer(scene, frames=[frame], width=width, height=height, primitive=primitive)
    build = time.perf_counter() - t0
    times = []
    for _ in range(repeat):
        t1 = time.perf_counter()
        renderer.render(frame)
        times.append(time.perf_counter() - t1)
    d = renderer.describe()
    return {"primitive": renderer.primitive, "database_mb": renderer.database.nbytes / 1e6,
            "segments": d["animated_segments"], "tetrahedra": d["tetrahedra"], "build_s": build,
            "frame_s": min(times)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--frame", type=float, default=30.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    width, height = (int(x) for x in args.size.split("x"))
    import warp_st

    warp_st.render(warp_st.load(str(ROD)), frame=args.frame, width=16, height=9)  # compile outside the timings
    warp_st.render(warp_st.load(str(ROD)), frame=args.frame, width=16, height=9, primitive="rigid")
    print(f"CPU: {cpu_model()}; spinning_rod frame {args.frame:g} at {width} x {height}")
    print("| model | primitive | database MB | pieces / sample intervals | tetrahedra | build s | frame s |")
    print("|---|---|---|---|---|---|---|")
    for label, primitive in (("pieces", "rigid"), ("worldlines", None)):
        r = measure(primitive, args.frame, width, height, args.repeat)
        print(f"| {label} | {r['primitive']} | {r['database_mb']:.1f} | {r['segments']} | {r['tetrahedra']} | "
              f"{r['build_s']:.2f} | {r['frame_s']:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
