#!/usr/bin/env python3
"""Speed against error (a benchmark, not a test): the script behind ``warp-st bench``.

Runs the suites of :mod:`warp_st.bench` (scaling 10^3..10^6 tetrahedra, sequence reuse,
float32 vs float64, sphere tessellation vs pixel error, time-segment length, "model only
what a scene needs", adaptive tessellation on the parade scene), prints one summary table
and writes docs/performance.md with docs/images/perf_scaling.png and perf_error.png.

    python3 examples/benchmarks/bench_performance.py --quick          # smoke run, < 30 s
    python3 examples/benchmarks/bench_performance.py                  # full run, minutes
    python3 examples/benchmarks/bench_performance.py --suites scaling,tessellation --runs 7 \
        --json perf.json

Same options as ``warp-st bench --help``; here ``--out`` defaults to this checkout's
docs/performance.md whatever the working directory. Run it on an idle machine: the report
records the load average at start and end.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
os.environ.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))


def main(argv=None) -> int:
    from warp_st import bench

    argv = list(sys.argv[1:] if argv is None else argv)
    if not any(a == "--out" or a.startswith("--out=") for a in argv):
        argv += ["--out", str(ROOT / "docs" / "performance.md")]
    return bench.main(argv)


if __name__ == "__main__":
    sys.exit(main())
