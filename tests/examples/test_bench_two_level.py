"""``examples/benchmarks/bench_two_level.py`` runs end to end (a smoke test: no timing is
asserted). Law: it prints the CPU model and one ratio row per table and thread count,
every ratio a positive finite number."""
import importlib.util
import math
from pathlib import Path


def test_bench_two_level_prints_its_table(capsys):
    path = Path(__file__).resolve().parents[2] / "examples" / "benchmarks" / "bench_two_level.py"
    spec = importlib.util.spec_from_file_location("bench_two_level_smoke", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--runs", "1", "--width", "32", "--height", "32", "--tables", "static,motion,sequence"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("CPU: ") and "unknown" not in out[0]
    rows = [line for line in out if line.startswith("| ") and "thr |" in line]
    assert len(rows) == 6
    for row in rows:
        ratio = float(row.split("|")[4].strip().rstrip("x"))
        assert math.isfinite(ratio) and ratio > 0
