"""The benchmark scripts of examples/benchmarks/ run end to end, small (smoke tests).

Law: each script prints the CPU model with its table; ``bench_performance.py --quick`` runs
every suite at tiny sizes, prints one summary row per measured case, and writes the
markdown report, the two plots and the raw numbers where it is told; the tracer
comparisons agree with wp.Mesh on which rays hit. No timing is asserted (the numbers
depend on a machine that may be shared): only that they exist, are finite and positive,
and that the laws the suites measure hold (a longer time segment makes fewer
tetrahedra, a window cut short cannot add any, a scene without mirrors traces the same
rays at any bounce limit, the adaptive tessellation stays under half a pixel). The
package has no ``warp-st bench`` any more: the command line refuses it.
"""
from __future__ import annotations

import json
import math

import pytest
from example_scripts import load_example



def _load(name):
    return load_example(f"benchmarks/{name}.py")


def _cpu_model():
    _load("bench_performance")  # puts benchlib on the path
    from benchlib.machine import cpu_model

    return cpu_model()


def _finite_positive(x):
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


#: The summary table's first column: one row per measured case of the quick run.
SUMMARY_ROWS = [
    "scaling (sphere grid)", "scaling (tessellated 3x3 grid)", "scaling (moving cubes)", "sequence reuse",
    "precision float32", "precision float64", "tessellation (rest)",
    "time segments: 4x4 sphere grid (16 seg.)", "time segments: one sphere at 0.9c (32 seg.)",
    "needs: lights", "needs: mirrors", "needs: clipping (lit)", "needs: clipping (unlit)",
    "needs: slack of the lit bound", "adaptive parade 96x54",
]


def test_performance_quick_subset_prints_its_rows(tmp_path, capsys):
    """The default suite's share of the quick run: two suites, no plots (the full quick run
    below takes about a minute, so it is marked slow: ``-m slow`` runs it)."""
    bench = _load("bench_performance")
    out, raw = tmp_path / "performance.md", tmp_path / "perf.json"
    assert bench.main(["--quick", "--suites", "sequence,precision", "--no-plots", "--out", str(out),
                       "--json", str(raw)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"CPU: {_cpu_model()} (")
    assert [line.split(" | ")[0].lstrip("| ") for line in lines[3:]] == [
        "sequence reuse", "precision float32", "precision float64"]
    assert f"Machine: {_cpu_model()}," in out.read_text()
    results = json.loads(raw.read_text())["results"]
    assert list(results) == ["sequence", "precision"]
    seq = results["sequence"]
    assert _finite_positive(seq["reuse_per_frame_s"]) and _finite_positive(seq["rebuild_per_frame_s"])
    for row in results["precision"]["rows"]:  # float32 Z within 1e-5 relative of the exact mesh hit at Z ~ 5
        assert row["z_poly"] < (5e-5 if row["precision"] == "float32" else 5e-6), row


@pytest.mark.slow
def test_performance_quick_prints_the_table_and_writes_the_report(tmp_path, capsys):
    bench = _load("bench_performance")
    out = tmp_path / "docs" / "performance.md"
    raw = tmp_path / "perf.json"
    assert bench.main(["--quick", "--out", str(out), "--json", str(raw)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"CPU: {_cpu_model()} (")
    assert lines[1] == "| suite | case | result |"
    assert [line.split(" | ")[0].lstrip("| ") for line in lines[3:]] == SUMMARY_ROWS

    text = out.read_text()
    assert f"Machine: {_cpu_model()}," in text
    for heading in ("## Summary", "## Scaling", "## Sequences", "## Precision", "## Sphere tessellation",
                    "## Time-segment length", "## Model only what a scene needs", "## Adaptive sphere"):
        assert heading in text, heading
    assert "\n".join(lines[1:]) in text  # the printed table is the report's summary
    for png in ("perf_scaling.png", "perf_error.png"):
        assert f"images/{png}" in text
        assert (out.parent / "images" / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    results = json.loads(raw.read_text())["results"]
    assert list(results) == list(bench.SUITES)
    for row in results["scaling"]["rows"]:
        assert row["tetrahedra"] > 0 and _finite_positive(row["bvh_s"]) and _finite_positive(row["kernel_s"]["median"])
    seq = results["sequence"]
    assert _finite_positive(seq["reuse_per_frame_s"]) and _finite_positive(seq["rebuild_per_frame_s"])
    for row in results["precision"]["rows"]:  # float32 Z within 1e-5 relative of the exact mesh hit at Z ~ 5
        assert row["z_poly"] < (5e-5 if row["precision"] == "float32" else 5e-6), row
    adaptive = [r for r in results["tessellation"]["rows"] if r["adaptive"]]
    assert adaptive and all(r["silhouette_px"] < 0.5 and r["depth_px"] < 0.5 for r in adaptive)
    # Renderer(sweep_fraction=f): a longer sweep per time segment, fewer tetrahedra
    for series in {r["series"] for r in results["slices"]["rows"]}:
        fixed = sorted((r["factor"], r["tetrahedra"]) for r in results["slices"]["rows"]
                       if r["series"] == series and r["factor"] is not None)
        tets = [t for _f, t in fixed]
        assert tets == sorted(tets, reverse=True) and tets[0] > tets[-1], fixed
    # Renderer(adjust_windows=...): cutting windows never adds tetrahedra
    slack = results["needs"]["slack"]
    assert all(0 < r["tetrahedra"] < slack["tetrahedra"] for r in slack["rows"]), slack
    # a scene without mirrors traces the same rays whatever the bounce limit
    no_mirror = [r for r in results["needs"]["mirrors"] if r["case"] == "no mirror"]
    assert len(no_mirror) == 2 and len({r["visits"] for r in no_mirror}) == 1


def test_performance_rejects_an_unknown_suite(capsys):
    with pytest.raises(SystemExit) as exc:
        _load("bench_performance").main(["--suites", "nope"])
    assert exc.value.code == 2
    assert "unknown suite" in capsys.readouterr().err.strip().splitlines()[-1]


def test_bench_trace_quick_compares_every_tracer(tmp_path, capsys):
    """``bench_trace.py --quick``: our prism and tetrahedron paths, wp.Mesh (and Embree when
    ``embreex`` is installed) trace the same static rays, and every tracer agrees with
    wp.Mesh on hit/miss (the report says OK)."""
    out = tmp_path / "trace.md"
    assert _load("bench_trace").main(["--quick", "--runs", "1", "--scenes", "parade,flanges", "--out", str(out)]) == 0
    text = out.read_text()
    assert capsys.readouterr().out == text
    assert f"Machine: {_cpu_model()}," in text
    table = {line.split(" | ")[0].lstrip("| "): line.split(" | ")[1:] for line in text.splitlines()
             if line.startswith("| ")}
    for row in ("static ours, prisms Mrays/s 1 thr", "static wp.Mesh Mrays/s 1 thr"):
        assert len(table[row]) == 2  # parade, flanges
        for cell in table[row]:
            assert _finite_positive(float(cell.split()[0].rstrip("|"))), (row, cell)
    ratios = table["static ratio ours (prisms) / wp.Mesh run by run, 1 thr: median (min–max)"]
    assert all(_finite_positive(float(cell.split()[0])) for cell in ratios), ratios
    sanity = [line for line in text.splitlines() if line.startswith("- ") and "hit/miss agree" in line]
    assert len(sanity) >= 4 and all(line.endswith("OK") for line in sanity), sanity


def test_bench_bands_splits_the_static_comparison_by_band(capsys):
    """``bench_bands.py`` times our tracer and wp.Mesh band by band on the same static rays;
    it refuses (raises) where the two disagree on which rays hit, so a table means
    hit/miss agreed on every ray. Times are only checked to be finite and positive."""
    assert _load("bench_bands").main(["--scene", "flanges", "--width", "64", "--height", "36", "--bands", "3",
                                      "--runs", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith(f"CPU: {_cpu_model()}")
    rows = [line for line in lines if line.startswith("| ") and line[2].isdigit()]
    assert [int(row.split("|")[1]) for row in rows] == [0, 1, 2]
    for row in rows:
        ours, mesh, ratio, hits = (float(x) for x in row.split("|")[2:6])
        assert all(_finite_positive(x) for x in (ours, mesh, ratio)) and 0.0 <= hits <= 1.0
    assert max(float(row.split("|")[5]) for row in rows) > 0.0, "the mirror scene's rays hit something"
