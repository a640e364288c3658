"""Shared test set-up: import the package from the checkout, keep Warp quiet; the fuzz seed.

The fuzz tests (tests/fuzz_helpers.py) draw a fresh seed each run unless
``WARP_ST_FUZZ_SEED`` is set; this file prints it in the terminal summary and beside
each failing test of a module that uses it, and writes ``WARP_ST_FUZZ_REPORT``.

The suite runs on pytest-xdist's workers (pyproject's ``-n auto``): the controller draws
the run's one seed into the environment before the workers start (they inherit it), and
each worker hands its cases tried back to the controller, which writes the report.
"""
import json
import os
import secrets
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
os.environ.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))


SEED_VARIABLE = "WARP_ST_FUZZ_SEED"  # fuzz_helpers.SEED_VARIABLE (read when it is imported)


def pytest_configure(config):
    """The run's fuzz seed, drawn once (in xdist's controller, before its workers start)."""
    if not hasattr(config, "workerinput") and not os.environ.get(SEED_VARIABLE, "").strip():
        os.environ[SEED_VARIABLE] = str(secrets.randbits(32))
    config.fuzz_stats = {}


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
    seed = os.environ[SEED_VARIABLE]
    terminalreporter.write_line(f"fuzz seed: {seed} (replay: {SEED_VARIABLE}={seed})")


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """xdist's controller: a worker's cases tried, added to the run's."""
    for kind, n in json.loads(getattr(node, "workeroutput", {}).get("fuzz_stats", "{}")).items():
        node.config.fuzz_stats[kind] = node.config.fuzz_stats.get(kind, 0) + n


def pytest_sessionfinish(session):
    fuzz = _fuzz()
    stats = session.config.fuzz_stats
    for kind, n in (fuzz.STATS if fuzz is not None else {}).items():
        stats[kind] = stats.get(kind, 0) + n
    if hasattr(session.config, "workeroutput"):  # an xdist worker: the controller writes the report
        session.config.workeroutput["fuzz_stats"] = json.dumps(stats)
        return
    target = os.environ.get("WARP_ST_FUZZ_REPORT")
    if target and stats:
        Path(target).write_text(json.dumps(stats, indent=1, sort_keys=True) + "\n")
