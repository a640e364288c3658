"""examples/benchmarks/bench_animation.py runs end to end, small (a smoke test; no timing is asserted).

Law: it prints the CPU model and one row per (scene, tolerance), writes the markdown table and
the PNG curve where it is told, restores the renderer's own cutting rule afterwards, and a
finer tolerance cuts more motion segments of the accelerating rocket."""
from __future__ import annotations

import math

from example_scripts import load_example


def test_bench_animation_quick_prints_rows_and_writes_the_curve(tmp_path, capsys):
    bench = load_example("benchmarks/bench_animation.py")
    from warp_st.rendering import renderer as renderer_module
    from warp_st.spacetime.animation import animation_cuts

    out, png = tmp_path / "bench.md", tmp_path / "curve.png"
    assert bench.main(["--quick", "--scenes", "hyperbolic_rocket", "--out", str(out), "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("CPU: ") and out.read_text().strip() == text.strip()
    rows = [line.split("|")[1:-1] for line in text.splitlines() if line.startswith("| hyperbolic_rocket")]
    assert [float(r[1]) for r in rows] == [2.0, 0.5]
    segments = [int(r[2]) for r in rows]
    assert 0 < segments[0] < segments[1]  # the rocket's chord error grows with a piece's length
    assert all(math.isfinite(float(r[3])) and float(r[3]) > 0 for r in rows)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert renderer_module.animation_cuts is animation_cuts
