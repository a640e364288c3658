"""Command-line manners: a closed pipe ends quietly (issue 15, Deliver 6).

Law: when the reader of stdout goes away (``warp-st inspect x.exr | head``), every
subcommand stops with the status of a process killed by SIGPIPE, 128 + 13 = 141, and
writes nothing on stderr (no "Broken pipe" error, no "Exception ignored" from the
interpreter's last flush). Checked with real child processes and real pipes.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cli_helpers import ROOT, child_env
from warp_st.output.film import Image

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGPIPE"), reason="POSIX pipes and SIGPIPE")

SIGPIPE_STATUS = 128 + 13
STAGE = ROOT / "usd_scenes" / "thesis" / "sphere_and_cubes.usda"


def env(buffered: bool) -> dict:
    """The child's environment; ``buffered``: Python's default block-buffered stdout on a
    pipe (the user's case: the closed pipe may show only in the last flush), else
    PYTHONUNBUFFERED (every print meets it)."""
    extra = {} if buffered else {"PYTHONUNBUFFERED": "1"}
    environment = child_env(**extra)
    if buffered:
        environment.pop("PYTHONUNBUFFERED", None)
    return environment


@pytest.fixture(params=[True, False], ids=["buffered", "unbuffered"])
def buffered(request) -> bool:
    return request.param


def closed_from_the_start(args: list[str], cwd: Path, buffered: bool) -> subprocess.CompletedProcess:
    """Run ``python -m warp_st ARGS`` with stdout a pipe whose read end is already closed:
    its first write meets EPIPE, whatever the timing."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        return subprocess.run([sys.executable, "-m", "warp_st", *args], stdout=write_end, stderr=subprocess.PIPE,
                              env=env(buffered), cwd=str(cwd), text=True, timeout=300)
    finally:
        os.close(write_end)


def head_one_line(args: list[str], cwd: Path, buffered: bool) -> tuple[str, subprocess.Popen, str]:
    """``python -m warp_st ARGS | head -1``: read one line, close the pipe, wait."""
    proc = subprocess.Popen([sys.executable, "-m", "warp_st", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=env(buffered), cwd=str(cwd), text=True)
    try:
        first = proc.stdout.readline()
        proc.stdout.close()
        err = proc.stderr.read()
        proc.wait(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return first, proc, err


@pytest.fixture
def big_exr(tmp_path) -> Path:
    """An EXR whose ``inspect`` listing (~300 KB of header lines) cannot fit a pipe's
    buffer (64 KB on Linux), so a reader that stops after one line breaks the pipe."""
    path = tmp_path / "big.exr"
    metadata = {f"note{i:04d}": "x" * 100 for i in range(3000)}
    Image(rgba=np.zeros((4, 6, 4), np.float32), metadata=metadata).write_exr(path)
    return path


def test_inspect_into_head(big_exr, tmp_path, buffered):
    """The issue's case, ``warp-st inspect x.exr | head -1``."""
    first, proc, err = head_one_line(["inspect", str(big_exr)], tmp_path, buffered)
    assert first == f"file: {big_exr}\n"
    assert (proc.returncode, err) == (SIGPIPE_STATUS, "")


@pytest.mark.parametrize("args", [
    ["validate", str(STAGE)],
    ["render", str(STAGE), "--width", "16", "--height", "12", "-o", "out.exr"],
    ["render", str(STAGE), "--width", "16", "--height", "12", "-o", "out.exr", "--log", "-"],
], ids=["validate", "render", "render-log-stdout"])
def test_every_command_into_a_closed_pipe(args, tmp_path):
    result = closed_from_the_start(args, tmp_path, buffered=True)
    assert (result.returncode, result.stderr) == (SIGPIPE_STATUS, "")


@pytest.mark.parametrize("size", ["big", "small"])
def test_inspect_into_a_closed_pipe(big_exr, tmp_path, size):
    """A listing bigger than the buffer meets the closed pipe while printing; a small one
    (buffered) only in the last flush."""
    path = big_exr
    if size == "small":
        path = tmp_path / "small.exr"
        Image(rgba=np.zeros((4, 6, 4), np.float32)).write_exr(path)
    result = closed_from_the_start(["inspect", str(path)], tmp_path, buffered=True)
    assert (result.returncode, result.stderr) == (SIGPIPE_STATUS, "")


def test_errors_still_speak(tmp_path):
    """Bad input with stdout closed is still the one-line error and exit 2 (the closed pipe
    changes nothing that goes to stderr)."""
    result = closed_from_the_start(["inspect", str(tmp_path / "absent.exr")], tmp_path, buffered=True)
    assert result.returncode == 2 and result.stderr.startswith("warp-st: error: "), result.stderr
