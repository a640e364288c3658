"""``warp-st bench``: lists and runs the checkout's benchmark scripts (docs/spec.md §6)."""
from __future__ import annotations

from pathlib import Path

from cli_helpers import run

from warp_st.commands import bench

ROOT = Path(__file__).resolve().parents[2]


def test_lists_every_benchmark_script(capsys):
    code, out, _ = run(capsys, "bench")
    names = sorted(p.stem.removeprefix("bench_") for p in (ROOT / "examples" / "benchmarks").glob("bench_*.py"))
    assert code == 0 and len(names) >= 5
    assert sorted(line.split()[0] for line in out.splitlines()) == names
    assert "two_level" in out and "wp.Mesh" in out  # each with its docstring's first line


def test_runs_the_script_with_its_arguments(capfd):
    """The script's own --help: it ran (its usage names the script) and its status is ours."""
    code = bench.run(type("Args", (), {"name": "two_level", "args": ["--help"]})())
    out = capfd.readouterr().out
    assert code == 0 and "bench_two_level.py" in out and "--runs" in out


def test_unknown_benchmark_is_one_error_line(capsys):
    code, _, err = run(capsys, "bench", "no_such_thing")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "two_level" in err


def test_without_the_checkout_is_bad_input(capsys, monkeypatch, tmp_path):
    monkeypatch.setattr(bench, "benchmark_dir", lambda: tmp_path / "missing")
    code, _, err = run(capsys, "bench")
    assert code == 2 and "source checkout" in err and len(err.strip().splitlines()) == 1
