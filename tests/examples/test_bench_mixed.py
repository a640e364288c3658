"""``examples/benchmarks/bench_mixed.py`` runs end to end, small (a smoke test).

Law: it prints the CPU model and its table, and the mixed database holds fewer
tetrahedra (the flag's only) than the all-tet one (every sphere too). No timing is asserted.
"""
from example_scripts import load_example


def test_bench_mixed_prints_both_paths(capsys):
    load_example("benchmarks/bench_mixed.py").main(["--runs", "1", "--width", "32", "--height", "18", "--segments", "16"])
    out = capsys.readouterr().out
    assert out.startswith("CPU: ")
    rows = {line.split("|")[1].strip(): line.split("|")[2:4] for line in out.splitlines() if line.startswith("| ")}
    tet, mixed = (int(x.strip().replace(",", "")) for x in rows["tetrahedra"])
    assert 0 < mixed < tet
    assert {"warm frame, 1 thr, ms", "warm frame, 2 thr, ms"} <= set(rows)
