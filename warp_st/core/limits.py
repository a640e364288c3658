"""Resource limits: refuse, before allocating, what would not fit (issue: bad input and faults).

Budget checks (the database size and :func:`warp_st.rendering.budget.check_resources`) live
in :mod:`warp_st.rendering.budget`; this module holds only the fixed ranges and sizes.

The 4D database grows with the tetrahedron count N = sum over bodies of 3 x T x K
(T triangles, K time segments of the body's visible window). N is known cheaply
before anything big is allocated: the visibility windows give each body's window,
:func:`warp_st.spacetime.extrude.body_slices` its K. :func:`estimate_bytes` turns N (and the
vertex and pixel counts) into the peak memory of the build and one frame, and
:func:`check_resources` raises :class:`SceneError` with the count and the estimate
when that exceeds the limit (``--max-memory`` / ``Renderer(max_memory=...)``;
default: 75 % of the physical memory, or of the cgroup limit when lower).

Magnitudes: every length, time, speed and colour the reader accepts is within
``MAX_MAGNITUDE`` (1e15): products of two such values (a speed times a time, a
scale times a point) stay far inside float64 and float32, so no NaN or infinity
can appear between the reader and the kernels.
"""
from __future__ import annotations

import functools
import math
import os
import re

from warp_st.core.scene import SceneError

__all__ = [
    "MAX_MAGNITUDE",
    "MAX_WINDOW",
    "MAX_SAMPLES",
    "MAX_BOUNCES",
    "MAX_PIXELS",
    "default_max_memory",
    "parse_size",
    "format_size",
    "resolve_max_memory",
    "physical_memory",
]

#: Largest magnitude of any coordinate, time, size, speed or colour read from a stage.
MAX_MAGNITUDE = 1e15
#: Largest |t| x max(1, |v|) of a body's visible window: every extruded coordinate
#: (t, o + v (t - t_ref) + r) then stays below ~1e30, inside float32.
MAX_WINDOW = 1e30
#: Largest ``spacetime:samples`` / ``--samples`` (rays per pixel).
MAX_SAMPLES = 1 << 16
#: Largest ``spacetime:maxDepth`` / ``--max-depth`` (mirror bounces).
MAX_BOUNCES = 1 << 10
#: Largest width x height (the kernels index pixels with int32).
MAX_PIXELS = (1 << 31) - 1

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40, "P": 1 << 50}


@functools.lru_cache(maxsize=1)
def _cgroup_limit() -> int | None:
    """The cgroup's memory limit (read once per process: the files are slow to open)."""
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as fh:
                text = fh.read().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < (1 << 60):
            return int(text)
    return None


def physical_memory() -> int | None:
    """Physical memory in bytes (os.sysconf, else /proc/meminfo), or None if unknown."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        if total > 0:
            return int(total)
    except (AttributeError, ValueError, OSError):
        pass
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def default_max_memory() -> int | None:
    """75 % of the physical memory (or of the cgroup limit, when lower); None if unknown."""
    sizes = [s for s in (physical_memory(), _cgroup_limit()) if s]
    return int(0.75 * min(sizes)) if sizes else None


def parse_size(text) -> int:
    """Bytes from ``"8G"``, ``"512M"``, ``"1.5GiB"``, ``"1000000"`` (K/M/G/T/P are powers of 1024).

    Raises ValueError on anything else, or on a size that is not positive.
    """
    m = re.fullmatch(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*([kKmMgGtTpP]?)(?:i?[bB])?\s*", str(text))
    if not m:
        raise ValueError(f"expected a size like 8G, 512M or 1000000 (bytes), got {text!r}")
    value = float(m.group(1)) * _UNITS[m.group(2).upper()]
    if not (math.isfinite(value) and value >= 1):
        raise ValueError(f"expected a positive size, got {text!r}")
    return int(value)


def format_size(n: float) -> str:
    """``1.5 GiB``-style text."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} PiB"  # pragma: no cover


def resolve_max_memory(max_memory, source: str | None) -> int | None:
    """Validated ``max_memory`` (bytes, or a size text); None selects the default."""
    if max_memory is None:
        return default_max_memory()
    try:
        value = parse_size(max_memory) if isinstance(max_memory, str) else int(max_memory)
    except (TypeError, ValueError, OverflowError):
        raise SceneError.at(source, None, "max_memory", f"must be a size in bytes, got {max_memory!r}") from None
    if value < 1:
        raise SceneError.at(source, None, "max_memory", f"must be a positive size in bytes, got {max_memory!r}")
    return value
