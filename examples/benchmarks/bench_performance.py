#!/usr/bin/env python3
"""Speed against error: performance benchmarks of warp_st (a benchmark, not a test).

Suites (``--suites``, default all), every number measured by this script:

- ``scaling``: extrusion, BVH build and render time from ~10^3 to ~10^6 tetrahedra at
  a fixed resolution (a grid of moving UV spheres, unlit; a cloud of moving cubes, lit);
- ``sequence``: a frame sequence from one database (``Renderer(scene, frames=[...])``
  then ``render(f)``) against rebuilding per frame (``warp_st.render(scene, frame=f)``);
- ``precision``: float32 against float64 kernels on the analytic moving sphere
  (``warp_st.core.lorentz.sphere_hit``), at t = 0 and shifted to t = 10^6: time against the
  error of Z and eventTime (total, and beyond the tessellation's own bound);
- ``tessellation``: UV-sphere segments 16...512 against the measured silhouette and
  depth error in pixels and the render time, and the adaptive choice;
- ``slices``: the time-segment length of long extrusions (segments in which a body sweeps
  1/32 to 8 times its size, and the default rule ``extrude.segment_sweep``) against
  tetrahedra, box size and time;
- ``needs``: no lights means no shadow rays, no mirrors means no reflection rays,
  clipping to the visible window keeps long sequences small, and how much of the lit
  windows an image needs (the slack of the bound);
- ``adaptive``: the shipped parade scene with adaptive sphere tessellation against the
  fixed 64 segments, at several resolutions.

    python examples/benchmarks/bench_performance.py --quick      # smoke run, < 1 min with a warm kernel cache
    python examples/benchmarks/bench_performance.py              # full run, several minutes
    python examples/benchmarks/bench_performance.py --suites scaling,precision --runs 7 --json perf.json

Prints the CPU model and one summary table (markdown) on stdout, progress on stderr, and
writes the full report (``--out``, default this checkout's docs/performance.md) with its
plots (``--images``, default ``images/`` next to the report: perf_scaling.png,
perf_error.png). Run it on an idle machine: the report records the load average at start
and end.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
for _path in (HERE, ROOT):  # benchlib, and warp_st from this checkout when it is not installed
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))
os.environ.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))

from benchlib.suites import SUITES  # noqa: E402  (numpy only: no warp / pxr import until a suite runs)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="tiny sizes for a smoke run (< 1 min with a warm kernel cache)")
    p.add_argument("--suites", default=",".join(SUITES), help=f"comma-separated subset of {','.join(SUITES)}")
    p.add_argument("--runs", type=int, default=None, help="timed renders per measurement, median (default 5; --quick 1)")
    p.add_argument("--width", type=int, default=None, help="image width of the scaling suite (default 320; --quick 64)")
    p.add_argument("--height", type=int, default=None, help="image height of the scaling suite (default 180; --quick 36)")
    p.add_argument("--out", metavar="FILE.md", default=str(ROOT / "docs" / "performance.md"),
                   help="markdown report (default: this checkout's docs/performance.md)")
    p.add_argument("--images", metavar="DIR", default=None, help="plot directory (default: images/ next to --out)")
    p.add_argument("--json", metavar="FILE.json", help="also write the raw numbers")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    args = p.parse_args(argv)
    if args.runs is None:
        args.runs = 1 if args.quick else 5
    if args.runs < 1:
        p.error("--runs must be >= 1")
    args.width = args.width or (64 if args.quick else 320)
    args.height = args.height or (36 if args.quick else 180)
    args.suites = [s.strip() for s in args.suites.split(",") if s.strip()]
    bad = [s for s in args.suites if s not in SUITES]
    if bad:
        p.error(f"unknown suite(s) {bad}; choose from {list(SUITES)}")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    from benchlib import report
    from benchlib.machine import load_average, machine_info
    from benchlib.suites import Bench
    from warp_st.rendering.renderer import init_warp

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    t_start = time.perf_counter()
    wp = init_warp()
    machine = machine_info()
    log(f"bench_performance: suites {args.suites}, runs {args.runs}{', quick' if args.quick else ''}; "
        f"kernel cache {wp.config.kernel_cache_dir}")
    bench = Bench(args, log)
    results, seconds = {}, {}
    for name in args.suites:
        t0 = time.perf_counter()
        log(f"[{name}]")
        results[name] = getattr(bench, name)()
        seconds[name] = time.perf_counter() - t0
    machine["loadavg_end"] = load_average()

    out = Path(args.out)
    images = Path(args.images) if args.images else out.parent / "images"
    try:
        images_rel = os.path.relpath(images, out.parent)
    except ValueError:
        images_rel = str(images)
    if not args.no_plots:
        report.make_plots(results, images, log)
    text, table = report.markdown(results, seconds, machine, args, images_rel.replace(os.sep, "/"))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f"CPU: {machine['cpu']} ({machine['usable_cores']} usable cores)")
    print("\n".join(table))
    log(f"wrote {out} in {time.perf_counter() - t_start:.1f} s")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps({"machine": machine, "options": vars(args), "seconds": seconds,
                                               "results": results}, indent=2, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
