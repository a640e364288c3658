"""Capture what native libraries (USD, OpenEXR, Warp) print on the process's file descriptors.

The one helper for every place that must keep native text off the terminal: a stage's
composition errors (summarised by one SceneError line), OpenEXR's messages on a corrupt
file, Warp's "no CUDA driver" line, USD's diagnostics held back by the command line.
"""
from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile

__all__ = ["captured_output", "held_diagnostics"]


@contextlib.contextmanager
def captured_output(fds: tuple[int, ...] = (2,), *, python_streams: bool = False):
    """Redirect the file descriptors ``fds`` into a temporary file for the block.

    Yields a list; when the block ends (normally or by an exception, which propagates)
    the captured text is appended to it. ``python_streams`` also captures Python-level
    ``sys.stdout`` / ``sys.stderr`` writes (pybind11's ``py::print`` goes there), whose
    text is appended first. Without real descriptors (an embedded interpreter) only the
    Python streams are captured.
    """
    captured: list[str] = []
    py_sink = io.StringIO()
    for stream in (sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__):
        with contextlib.suppress(Exception):
            if stream is not None:
                stream.flush()
    redirects = contextlib.ExitStack()
    if python_streams:
        redirects.enter_context(contextlib.redirect_stdout(py_sink))
        redirects.enter_context(contextlib.redirect_stderr(py_sink))
    with redirects:
        try:
            saved = [os.dup(fd) for fd in fds]
        except (OSError, ValueError, AttributeError):  # no real descriptors
            saved = None
        if saved is None:
            try:
                yield captured
            finally:
                captured.append(py_sink.getvalue())
            return
        with tempfile.TemporaryFile() as sink:
            try:
                for fd in fds:
                    os.dup2(sink.fileno(), fd)
                yield captured
            finally:
                for fd, copy in zip(fds, saved):
                    with contextlib.suppress(Exception):
                        (sys.stdout if fd == 1 else sys.stderr).flush()
                    os.dup2(copy, fd)
                    os.close(copy)
                sink.seek(0)
                if python_streams:
                    captured.append(py_sink.getvalue())
                captured.append(sink.read().decode("utf-8", "replace"))


@contextlib.contextmanager
def held_diagnostics():
    """Hold back the reader's Python warnings and what USD prints on fd 2 during the block.

    On bad input only the one error line is printed (docs/spec.md §6), so what was held is
    dropped when the block raises; on success it is printed (each warning as one line).
    """
    import warnings

    with captured_output() as printed, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    native = "".join(printed).rstrip()
    if native:
        print(native, file=sys.stderr)
    for w in caught:
        print(f"warp-st: warning: {' '.join(str(w.message).split())}", file=sys.stderr)
