"""bench_animation_db.py's wheel sequence runs end to end, small (a smoke test).

Laws it reports on (no timing asserted): one database per Renderer, none built while its
frames render, and the wheel's pieces on one bottom level (with the ground's: 2).
"""
from __future__ import annotations

import math

from example_scripts import load_example


def test_the_wheel_sequence_builds_once_on_one_bottom_level():
    bench = load_example("benchmarks/bench_animation_db.py")
    r = bench.sequence(6, 16, 9)
    assert r["builds_during_frames"] == 0
    for label in ("animated", "static"):
        x = r[label]
        assert x["builds"] == 1 and x["bottom_levels"] == 2
        assert all(math.isfinite(x[k]) and x[k] > 0 for k in ("construct_s", "frame_median_s", "total_s"))
    assert r["animated"]["pieces"] > 10 and r["static"]["pieces"] == 2
