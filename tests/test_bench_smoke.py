"""``warp-st bench --quick`` runs end to end and writes its report (a smoke test).

Law: the benchmark command is part of the command line (SPEC §6 style: exit 0, one
table on stdout), its quick mode exercises every suite at tiny sizes, and it writes the
markdown report and the two plots where it is told. No timing is asserted: the numbers
depend on the machine (and this one may be shared); only that they exist and are sane
(positive times, tetrahedra counted, measured tessellation error of the adaptive
choice under half a pixel, which is the bound the adaptive rule guarantees).
"""
from __future__ import annotations

import json

from warp_st import bench
from warp_st.cli import main as cli_main


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
