"""Shared test helper: import a script of examples/ as a module, to call its main() or run()."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load_example(relative: str):
    """The module of ``examples/<relative>`` (e.g. ``"thesis/aberration.py"``), with its folder
    first on sys.path so that the modules beside it (thesis_common, benchlib, bench_trace) import."""
    path = EXAMPLES / relative
    if str(path.parent) not in sys.path:
        sys.path.insert(0, str(path.parent))
    spec = importlib.util.spec_from_file_location(f"example_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
