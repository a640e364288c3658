"""Frame lists and per-frame output names: ``1-240x2``, ``OUT.####.exr``, ``OUT.%04d.exr``."""
from __future__ import annotations

import argparse
import math
import re

import numpy as np

__all__ = ["parse_frames", "finite_frame", "has_frame_pattern", "format_frame", "expand_output",
           "frame_label", "frames_label"]

_RANGE = re.compile(r"^\s*(-?\d+)\s*-\s*(-?\d+)\s*(?:x\s*(\d+))?\s*$")
_NUMBER = re.compile(r"^\s*-?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?\s*$")


def parse_frames(text: str) -> list[float]:
    """Frames from ``A-B[xStep]`` ranges (inclusive, integers) and numbers, comma separated.

    ``"1-240x2"`` -> 1, 3, ..., 239; ``"1,5,10-20x5"`` -> 1, 5, 10, 15, 20. Single
    items may be fractional time codes. Duplicates are dropped, order is kept.
    Raises argparse.ArgumentTypeError (exit 2) on a malformed or empty range.
    """
    frames: list[float] = []
    for item in text.split(","):
        if not item.strip():
            raise argparse.ArgumentTypeError(f"bad frame list {text!r}: empty item")
        m = _RANGE.match(item)
        if m:
            first, last = int(m.group(1)), int(m.group(2))
            step = int(m.group(3)) if m.group(3) is not None else 1
            if step < 1:
                raise argparse.ArgumentTypeError(f"bad frame range {item.strip()!r}: step must be >= 1")
            if last < first:
                raise argparse.ArgumentTypeError(
                    f"bad frame range {item.strip()!r}: end {last} is before start {first}"
                )
            frames.extend(float(f) for f in range(first, last + 1, step))
        elif _NUMBER.match(item):
            frames.append(finite_frame(item))
        else:
            raise argparse.ArgumentTypeError(
                f"bad frame list {text!r}: expected N, A-B or A-BxStep items separated by commas"
            )
    return list(dict.fromkeys(frames))


def finite_frame(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad frame {text!r}: not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"bad frame {text!r}: must be finite")
    return value


_PATTERN = re.compile(r"#+|%0?(\d*)d")


def has_frame_pattern(name: str) -> bool:
    """True if ``name`` has a ``####`` run or a ``%04d`` printf pattern."""
    return _PATTERN.search(name) is not None


def format_frame(frame: float, width: int) -> str:
    """Zero-padded frame number; fractional time codes keep their fraction (``0001.5``)."""
    frame = float(frame)
    if frame.is_integer():
        return f"{int(frame):0{width}d}"
    text = np.format_float_positional(abs(frame), trim="-")
    whole, frac = text.split(".")
    sign = "-" if frame < 0 else ""
    return sign + whole.zfill(max(width - len(sign), 0)) + "." + frac


def expand_output(pattern: str, frame: float) -> str:
    """Replace every ``#`` run (width = its length) and ``%0Nd`` by the frame number."""

    def repl(m: re.Match) -> str:
        if m.group(0).startswith("#"):
            width = len(m.group(0))
        else:
            width = int(m.group(1)) if m.group(1) else 0
        return format_frame(frame, width)

    return _PATTERN.sub(repl, pattern)


def frame_label(frame: float) -> str:
    return str(int(frame)) if float(frame).is_integer() else repr(float(frame))


def frames_label(frames: list[float]) -> str:
    """Compact list: consecutive integers grouped as ranges ("0-2, 5, 7.5")."""
    if not frames:
        return "none"
    parts: list[str] = []
    run: list[int] = []

    def flush():
        if run:
            parts.append(str(run[0]) if len(run) == 1 else f"{run[0]}-{run[-1]}")
            run.clear()

    for f in sorted(frames):
        if float(f).is_integer() and (not run or int(f) == run[-1] + 1):
            run.append(int(f))
            continue
        flush()
        if float(f).is_integer():
            run.append(int(f))
        else:
            parts.append(frame_label(f))
    flush()
    return ", ".join(parts)

