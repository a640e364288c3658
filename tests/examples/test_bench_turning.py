"""bench_turning.py runs end to end, small (a smoke test). Laws it reports on (no timing
asserted): the pieces are traced on the rigid path without tetrahedra, the worldlines as
tetrahedra leaves of it (spacetime/mixed.py), and both report their segment counts."""
from __future__ import annotations

import math

from example_scripts import load_example


def test_the_rod_as_pieces_and_as_worldlines():
    bench = load_example("benchmarks/bench_turning.py")
    pieces, lines = (bench.measure(p, 30.0, 48, 27, 1) for p in ("rigid", None))
    assert pieces["primitive"] == "rigid" and pieces["tetrahedra"] == 0
    assert lines["primitive"] == "rigid" and lines["tetrahedra"] > 0
    for r in (pieces, lines):
        assert r["segments"] > 10
        assert all(math.isfinite(r[k]) and r[k] > 0 for k in ("database_mb", "build_s", "frame_s"))
