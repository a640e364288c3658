"""``warp-st bench --quick`` runs end to end and writes its report (a smoke test).

Law: the benchmark command is part of the command line (docs/spec.md §6 style: exit 0, one
table on stdout), its quick mode exercises every suite at tiny sizes, and it writes the
markdown report and the two plots where it is told. No timing is asserted: the numbers
depend on the machine (and this one may be shared); only that they exist and are sane
(positive times, tetrahedra counted, measured tessellation error of the adaptive
choice under half a pixel, which is the bound the adaptive rule guarantees).
"""
from __future__ import annotations

import json

from warp_st import bench
from warp_st.commands.cli import main as cli_main


def test_bench_quick_writes_report(tmp_path, capsys):
    out = tmp_path / "docs" / "performance.md"
    raw = tmp_path / "perf.json"
    rc = cli_main(["bench", "--quick", "--out", str(out), "--json", str(raw)])
    assert rc == 0
    printed = capsys.readouterr().out
    assert printed.startswith("| suite | case | result |")
    text = out.read_text()
    for heading in ("## Summary", "## Scaling", "## Sequences", "## Precision", "## Sphere tessellation",
                    "## Time-segment length", "## Model only what a scene needs", "## Adaptive sphere"):
        assert heading in text, heading
    assert "images/perf_scaling.png" in text and "images/perf_error.png" in text
    for png in ("perf_scaling.png", "perf_error.png"):
        data = (out.parent / "images" / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 1000

    results = json.loads(raw.read_text())["results"]
    assert set(results) == set(bench.SUITES)
    for row in results["scaling"]["rows"]:
        assert row["tetrahedra"] > 0 and row["bvh_s"] > 0 and row["kernel_s"]["median"] > 0
    adaptive = [r for r in results["tessellation"]["rows"] if r["adaptive"]]
    assert adaptive and all(r["silhouette_px"] < 0.5 and r["depth_px"] < 0.5 for r in adaptive)
    # a scene without mirrors traces the same rays whatever the bounce limit
    no_mirror = [r for r in results["needs"]["mirrors"] if r["case"] == "no mirror"]
    assert len({r["visits"] for r in no_mirror}) == 1


def test_bench_rejects_unknown_suite(capsys):
    assert cli_main(["bench", "--suites", "nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown suite" in err[0]


def test_bench_trace_quick_compares_every_tracer(tmp_path, capsys):
    """``examples/benchmarks/bench_trace.py --quick`` runs end to end: our prism and
    tetrahedron paths, wp.Mesh (and Embree when ``embreex`` is installed) trace the same
    static rays, and every tracer agrees with wp.Mesh on hit/miss (the report says OK)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "benchmarks" / "bench_trace.py"
    spec = importlib.util.spec_from_file_location("bench_trace_smoke", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / "trace.md"
    assert module.main(["--quick", "--runs", "1", "--scenes", "parade,flanges", "--out", str(out)]) == 0
    text = out.read_text()
    assert "static ours, prisms Mrays/s 1 thr" in text and "static wp.Mesh Mrays/s 1 thr" in text
    assert "static ratio ours (prisms) / wp.Mesh run by run, 1 thr" in text
    sanity = [line for line in text.splitlines() if line.startswith("- ") and "hit/miss agree" in line]
    assert len(sanity) >= 4 and all(line.endswith("OK") for line in sanity), sanity


def test_bench_bands_splits_the_static_comparison_by_band(capsys):
    """``examples/benchmarks/bench_bands.py`` times our tracer and wp.Mesh band by band on
    the same static rays; it refuses (raises) where the two disagree on which rays hit,
    so a table means hit/miss agreed on every ray. Times are only checked to exist."""
    import importlib.util
    import math
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "benchmarks" / "bench_bands.py"
    spec = importlib.util.spec_from_file_location("bench_bands_smoke", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--scene", "flanges", "--width", "64", "--height", "36", "--bands", "3", "--runs", "1"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert len(rows) == 3
    for row in rows:
        ours, mesh = (float(x) for x in row.split("|")[2:4])
        assert math.isfinite(ours) and math.isfinite(mesh) and ours > 0 and mesh > 0
    hits = [float(row.split("|")[5]) for row in rows]
    assert max(hits) > 0.0, "the mirror scene's rays hit something"
