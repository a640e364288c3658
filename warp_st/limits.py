"""Resource limits: refuse, before allocating, what would not fit (issue: bad input and faults).

The 4D database grows with the tetrahedron count N = sum over bodies of 3 x T x K
(T triangles, K time segments of the body's visible window). N is known cheaply
before anything big is allocated: the visibility windows give each body's window,
:func:`warp_st.extrude.body_slices` its K. :func:`estimate_bytes` turns N (and the
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

import math
import os
import re

import numpy as np

from .scene import Scene, SceneError

__all__ = [
    "MAX_MAGNITUDE",
    "MAX_WINDOW",
    "MAX_SAMPLES",
    "MAX_BOUNCES",
    "MAX_PIXELS",
    "BYTES_PER_TET",
    "BYTES_PER_VERTEX",
    "BYTES_PER_PIXEL",
    "estimate_bytes",
    "count_database",
    "default_max_memory",
    "parse_size",
    "format_size",
    "check_resources",
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

# Per-item costs of the build and of one frame, in bytes, as the code allocates them.
#: BVH nodes per tetrahedron (leaves of <= 4 primitives, two children per inner node).
NODES_PER_TET = 0.7
_NODE_BYTES = 2 * 4 * 8 + 2 * 4 * 4 + 2 * 4  # lo/hi float64 host + lo/hi float32 device + first/count int32
BYTES_PER_TET = int(
    4 * 4 * 2  # tets: int32 x 4 on the host and on the device
    + 4 * 2  # tet_tri: int32, host and device
    + 4 * 4 * 8  # the (N, 4, 4) float64 events of the box computation
    + 2 * 4 * 8  # the primitive boxes lo/hi, float64
    # scratch of the BVH build, live at its peak: box centres (float64 x 4), their Morton
    # quantisation (int64 x 4), the node links (2N int64 x 2) and the sorted boxes (float64 x 8)
    + 4 * 8 + 4 * 8 + 2 * 2 * 8 + 8 * 8
    + NODES_PER_TET * _NODE_BYTES
)
#: Vertices: events float64 on the host, float32 on the device, normals float64 host + float32 device.
BYTES_PER_VERTEX = 4 * 8 + 4 * 4 + 3 * 8 + 3 * 4
#: The film (rgba + 5 scalars + 3 int32 on the device) and the Image (rgba f32, two f64 times, 5 x 4 bytes).
BYTES_PER_PIXEL = (4 * 4 + 5 * 4 + 3 * 4) + (4 * 4 + 2 * 8 + 5 * 4)

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40, "P": 1 << 50}


def estimate_bytes(tetrahedra: int, vertices: int, pixels: int = 0) -> int:
    """Peak bytes of a database of ``tetrahedra`` / ``vertices`` and a frame of ``pixels``.

    Per tetrahedron: its indices (int32 x 4) and triangle (int32) on the host and the
    device, the (N, 4, 4) float64 events and (N, 4) x 2 boxes of the BVH build, the
    build's scratch at its peak (centres, Morton quantisation, node links, sorted
    boxes) and ~0.7 BVH nodes (box corners float64 host + float32 device, two int32
    links): BYTES_PER_TET = 465. Measured with tracemalloc, the host peak of a build is
    about 0.85 of the estimate (``tests/test_faults.py``).
    Per vertex: the event (float64 host, float32 device) and the shading normal.
    """
    return int(tetrahedra * BYTES_PER_TET + vertices * BYTES_PER_VERTEX + pixels * BYTES_PER_PIXEL)


class MemoryRefusal(SceneError):
    """A render whose estimated memory exceeds the limit (bad input: exit 2)."""


def count_database(scene: Scene, windows, *, fine: bool = True) -> tuple[int, int, list[int]]:
    """(tetrahedra, vertices, tetrahedra per body) the extrusion of ``scene`` over ``windows`` makes.

    Exactly what :func:`warp_st.extrude.extrude_scene` allocates (3 tetrahedra per
    non-degenerate triangle per segment, one vertex per point per slice), without
    building it. A window that is not finite raises SceneError naming the body.
    """
    from .extrude import body_slices, surface_triangles
    from .visibility import intervals

    tets, verts, per_body = 0, 0, []
    for body, window in zip(scene.bodies, windows):
        n_body = 0
        parts = intervals(window)
        if parts and body.surfaces:
            if not all(math.isfinite(t) for part in parts for t in part):
                raise SceneError.at(
                    scene.source, body.prim_path, None,
                    f"its visible time window {_window_text(window)} is not finite (positions, speeds or times too large)",
                )
            segments = sum(len(body_slices(body, part, fine=fine)) - 1 for part in parts)
            for surf in body.surfaces:
                n_tri = len(surface_triangles(surf))
                if n_tri:
                    n_body += 3 * n_tri * segments
                    verts += (segments + len(parts)) * len(surf.points)
        per_body.append(n_body)
        tets += n_body
    return tets, verts, per_body


def _cgroup_limit() -> int | None:
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


def _window_text(window) -> str:
    from .visibility import intervals

    parts = intervals(window)
    return str(parts[0]) if len(parts) == 1 else " + ".join(str(p) for p in parts)


def _check_windows(scene: Scene, windows, max_depth: int) -> None:
    """SceneError for a visible window whose coordinates would pass MAX_WINDOW, naming its likely cause."""
    from .visibility import span

    for body, window in zip(scene.bodies, windows):
        window = span(window)
        reach = max(abs(float(t)) for t in window) * max(1.0, body.speed) if window is not None else 0.0
        if reach <= MAX_WINDOW:  # False for NaN
            continue
        mirrors = any(s.material.metallic > 0.0 for b in scene.bodies for s in b.surfaces)
        if mirrors and max_depth > 0:
            settings = scene.settings
            from_stage = settings.max_depth == max_depth and getattr(settings, "prim_path", None)
            prim, attr = (settings.prim_path, "spacetime:maxDepth") if from_stage else (None, "maxDepth")
            raise SceneError.at(
                scene.source, prim, attr,
                f"{max_depth} mirror bounces widen the visible time window of {body.prim_path} to "
                f"{tuple(window)}, beyond {MAX_WINDOW:g} (moving mirrors widen it at every bounce); use fewer bounces",
            )
        raise SceneError.at(scene.source, body.prim_path, None,
                            f"its visible time window {tuple(window)} at speed {body.speed:g} reaches coordinates "
                            f"beyond {MAX_WINDOW:g} (positions, speeds or times too large)")


def check_resources(scene: Scene, windows, *, width: int, height: int, samples: int = 1, max_depth: int = 0,
                    max_memory: int | None = None, fine: bool = True) -> int:
    """Refuse (SceneError; MemoryRefusal over ``max_memory``) a render that would exceed
    ``max_memory`` or the kernels' ranges. ``fine``: the time-segment rule
    (``extrude.body_slices``). Called after the visibility windows and before the
    extrusion. Returns the estimate.
    """
    src = scene.source
    if samples > MAX_SAMPLES:
        raise SceneError.at(src, None, "samples", f"must be <= {MAX_SAMPLES}, got {samples}")
    if max_depth > MAX_BOUNCES:
        raise SceneError.at(src, None, "maxDepth", f"must be <= {MAX_BOUNCES}, got {max_depth}")
    pixels = int(width) * int(height)
    if pixels > MAX_PIXELS:
        raise SceneError.at(src, None, "resolution", f"{width} x {height} is more than {MAX_PIXELS} pixels")
    _check_windows(scene, windows, max_depth)
    tets, verts, per_body = count_database(scene, windows, fine=fine)
    estimate = estimate_bytes(tets, verts, pixels)
    if max_memory is not None and estimate > max_memory:
        biggest = ""
        if per_body and max(per_body) > 0:
            i = int(np.argmax(per_body))
            biggest = f"; the largest body is {scene.bodies[i].prim_path} with {per_body[i]:,} tetrahedra"
        raise MemoryRefusal.at(
            src, None, None,
            f"the render needs about {format_size(estimate)} ({tets:,} tetrahedra, {verts:,} vertices, "
            f"{pixels:,} pixels), more than the memory limit of {format_size(max_memory)}{biggest}; "
            "raise --max-memory (max_memory=) or shorten the frame range, lifetimes or speeds",
        )
    return estimate
