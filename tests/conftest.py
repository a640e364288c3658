"""Shared test set-up: import the package from the checkout, keep Warp quiet; the fuzz seed.

The fuzz tests (tests/fuzz_helpers.py) draw a fresh seed each run unless
``WARP_ST_FUZZ_SEED`` is set; this file prints it in the terminal summary and beside
each failing test of a module that uses it, and writes ``WARP_ST_FUZZ_REPORT``.
"""
import json
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
os.environ.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))


def _fuzz():
    """tests/fuzz_helpers.py if a collected test module imported it, else None."""
    return sys.modules.get("fuzz_helpers")


def _replay_line(fuzz) -> str:
    return f"fuzz seed: {fuzz.FUZZ_SEED} (replay: {fuzz.SEED_VARIABLE}={fuzz.FUZZ_SEED})"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    fuzz = _fuzz()
    module = getattr(item, "module", None)
    if fuzz is not None and report.failed and module is not None and any(
            getattr(value, "__module__", None) == fuzz.__name__ for value in vars(module).values()):
        report.sections.append(("fuzz seed", _replay_line(fuzz)))


def pytest_terminal_summary(terminalreporter):
    fuzz = _fuzz()
    if fuzz is not None:
        terminalreporter.write_line(_replay_line(fuzz))


def pytest_sessionfinish(session):
    fuzz = _fuzz()
    target = os.environ.get("WARP_ST_FUZZ_REPORT")
    if fuzz is not None and target and fuzz.STATS:
        Path(target).write_text(json.dumps(fuzz.STATS, indent=1, sort_keys=True) + "\n")
