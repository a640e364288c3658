"""``warp-st bench``: run a benchmark script of the source checkout (docs/spec.md §6).

The benchmarks are scripts in ``examples/benchmarks/`` (not in the package): ``warp-st
bench`` lists them, ``warp-st bench NAME [ARGS...]`` runs ``bench_NAME.py ARGS`` with this
Python, from the checkout's root, and returns its exit status. An installed package
without its checkout has none: that is bad input (exit 2).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from warp_st.commands.common import UsageError


def benchmark_dir() -> Path:
    import warp_st

    return Path(warp_st.__file__).resolve().parents[1] / "examples" / "benchmarks"


def _scripts(folder: Path) -> dict[str, Path]:
    return {p.stem.removeprefix("bench_"): p for p in sorted(folder.glob("bench_*.py"))}


def add_arguments(parser) -> None:
    parser.add_argument("name", nargs="?", metavar="NAME", help="a benchmark (without bench_ and .py); none: list them")
    parser.add_argument("args", nargs=argparse.REMAINDER, metavar="ARGS", help="the script's own options (NAME --help)")


def _summary(path: Path) -> str:
    """The first line of the script's docstring."""
    for line in path.read_text(encoding="utf-8").splitlines():
        text = line.strip().strip('"').strip()
        if text and not text.startswith("#"):
            return text
    return ""


def run(args) -> int:
    folder = benchmark_dir()
    scripts = _scripts(folder) if folder.is_dir() else {}
    if not scripts:
        raise UsageError(f"no benchmarks at {folder}: they ship with the source checkout "
                         "(git clone, then pip install -e .)")
    if args.name is None:
        width = max(len(n) for n in scripts)
        for name, path in scripts.items():
            print(f"{name:<{width}}  {_summary(path)}")
        return 0
    if args.name not in scripts:
        raise UsageError(f"unknown benchmark {args.name!r}; one of: {', '.join(scripts)}")
    return subprocess.call([sys.executable, str(scripts[args.name]), *args.args], cwd=folder.parents[1])
