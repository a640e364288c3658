#!/usr/bin/env python3
"""Wall time of a sequence in this process against Dask LocalClusters (a benchmark, not a test).

Renders the same frames with :func:`warp_st.render_sequence` in this process (``workers=0``)
and on LocalClusters of N worker processes, each mode ``--runs`` times, and prints a markdown
table of median wall times (cluster start-up, the workers' stage loads and BVH builds and
every EXR write included), with the build and per-frame medians from the JSON records.

    python3 examples/benchmarks/bench_farm.py                        # parade, 20 frames, 320x180
    python3 examples/benchmarks/bench_farm.py --frames 0-47 --width 640 --height 360 --workers 1,2,4

Run it on an idle machine: the table records the load average before and after.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
for _path in (HERE, ROOT):  # benchlib, and warp_st from this checkout when it is not installed
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))
os.environ.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))


def _median(values):
    return statistics.median(values) if values else float("nan")


def measure(scene: str, frames: list[float], workers: int, width: int, height: int, folder: Path) -> dict:
    """One run: wall seconds, median build seconds and median per-frame seconds."""
    from warp_st import render_sequence

    records: list[dict] = []
    start = time.perf_counter()
    result = render_sequence(scene, frames, str(folder / f"w{workers}.####.exr"), workers=workers,
                             progress=False, log=records.append, width=width, height=height)
    wall = time.perf_counter() - start
    assert len(result.rendered) == len(frames)
    return {
        "wall": wall,
        "build": _median([r["seconds"] for r in records if r["event"] == "build"]),
        "frame": _median([r["seconds"] for r in records if r["event"] == "frame"]),
    }


def main(argv=None) -> int:
    from benchlib.machine import cpu_model
    from warp_st.core.frames import parse_frames

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=str(ROOT / "usd_scenes" / "relativistic_parade.usda"))
    parser.add_argument("--frames", type=parse_frames, default=parse_frames("0-19"))
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    parser.add_argument("--workers", default="1,2", help="comma-separated LocalCluster sizes (0 = this process)")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args(argv)
    modes = [0] + [int(w) for w in args.workers.split(",") if int(w) > 0]

    load_before = os.getloadavg()
    rows = {m: [] for m in modes}
    with tempfile.TemporaryDirectory() as tmp:
        for run in range(args.runs):  # interleaved, so a change in the machine's load hits every mode
            for m in modes:
                rows[m].append(measure(args.scene, args.frames, m, args.width, args.height, Path(tmp)))
                print(f"run {run + 1}/{args.runs}, workers {m}: {rows[m][-1]['wall']:.2f} s", file=sys.stderr)
    load_after = os.getloadavg()

    local = _median([r["wall"] for r in rows[0]])
    print(f"{len(args.frames)} frames of {Path(args.scene).name} at {args.width}x{args.height}, "
          f"{os.cpu_count()} cores ({cpu_model()}), median of {args.runs} runs; "
          f"load average {load_before[0]:.2f} before, {load_after[0]:.2f} after\n")
    print("| mode | wall s (median) | min-max | build s | s per frame (one process) | vs this process |")
    print("|---|---:|---:|---:|---:|---:|")
    for m in modes:
        walls = [r["wall"] for r in rows[m]]
        name = "this process" if m == 0 else f"LocalCluster, {m} worker{'s' if m > 1 else ''}"
        wall = _median(walls)
        print(f"| {name} | {wall:.2f} | {min(walls):.2f}-{max(walls):.2f} | "
              f"{_median([r['build'] for r in rows[m]]):.2f} | {_median([r['frame'] for r in rows[m]]):.3f} | "
              f"{local / wall:.2f}x |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
