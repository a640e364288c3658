"""What every ``warp-st`` command shares: the program name, the one-line errors and signals."""
from __future__ import annotations

import argparse
import contextlib
import math
import sys

PROG = "warp-st"


class UsageError(Exception):
    """Bad input detected by the command line itself: exit 2 with one line."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGHUP) delivered to the command line: stop like ^C, exit 128 + signal."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def interruption(exc: BaseException) -> str:
    if isinstance(exc, Terminated):
        import signal

        return f"terminated by {signal.Signals(exc.signum).name}"
    return "interrupted"


def interrupted_status(exc: BaseException) -> int:
    return 128 + exc.signum if isinstance(exc, Terminated) else 130


@contextlib.contextmanager
def terminate_as_interrupt():
    """While the command runs, SIGTERM / SIGHUP raise :class:`Terminated` in the main thread
    (so outputs are finished or rolled back exactly as on ^C); the old handlers come back after."""
    import signal

    def handler(signum, frame):
        raise Terminated(signum)

    saved = {}
    for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is None:
            continue
        try:
            saved[sig] = signal.signal(sig, handler)
        except (ValueError, OSError):  # not the main thread, or not supported here
            pass
    try:
        yield
    finally:
        for sig, old in saved.items():
            with contextlib.suppress(ValueError, OSError):
                signal.signal(sig, old)


def closed_pipe_status() -> int:
    """The end of a command whose reader closed stdout (``warp-st inspect x.exr | head``):
    no message, stdout pointed at the null device (so the interpreter's final flush of the
    unwritten rest does not complain: Python's documented recipe for SIGPIPE) and the
    status of a process killed by SIGPIPE, 128 + 13 = 141 (1 where there is no SIGPIPE)."""
    import os
    import signal

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no real stdout file (captured or closed)
        pass
    sigpipe = getattr(signal, "SIGPIPE", None)
    return 128 + sigpipe if sigpipe is not None else 1


def error(message: str) -> None:
    message = " ".join(str(message).split())  # one line, always
    print(f"{PROG}: error: {message}", file=sys.stderr)


# --- argument types (argparse reports their errors as one line, exit 2) ---------


def _int_at_least(minimum: int, what: str):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    return parse


positive_int = _int_at_least(1, "a positive integer")
non_negative_int = _int_at_least(0, "an integer >= 0")


def non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not math.isfinite(value) or value < 0.0:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def size_arg(text: str) -> int:
    from warp_st.core.limits import parse_size

    try:
        return parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def int_arg(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def stage_light_speed_arg(text: str):
    """argparse type of ``--light-speed C``: a :class:`LightSpeedSetting` (docs/spec.md §1.1)."""
    from warp_st.core.light_speed import parse_light_speed

    try:
        return parse_light_speed(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
