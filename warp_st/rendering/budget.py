"""The memory budget of a render: refuse, before allocating, what would not fit.

The 4D database grows with the tetrahedron count N = sum over bodies of 3 x T x K (T
triangles, K time segments of the body's visible window). N is known cheaply before
anything big is allocated: the visibility windows give each body's window,
:func:`warp_st.spacetime.extrude.body_slices` its K. :func:`estimate_bytes` turns N (and the
vertex and pixel counts) into the peak memory of the build and one frame, and
:func:`check_resources` raises :class:`MemoryRefusal` with the count and the estimate when
that exceeds the limit.
"""
from __future__ import annotations

import math

import numpy as np

from warp_st.core.limits import MAX_BOUNCES, MAX_PIXELS, MAX_SAMPLES, MAX_WINDOW, format_size
from warp_st.core.scene import Scene, SceneError, surface_keep
from warp_st.spacetime.extrude import body_slices
from warp_st.spacetime.visibility import intervals, span

__all__ = [
    "BYTES_PER_TET",
    "BYTES_PER_VERTEX",
    "BYTES_PER_PIXEL",
    "MemoryRefusal",
    "BYTES_PER_RIGID_TRIANGLE",
    "BYTES_PER_RIGID_VERTEX",
    "estimate_bytes",
    "estimate_rigid_bytes",
    "count_database",
    "check_limits",
    "check_resources",
]

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
#: The film (rgba + 5 scalars + 3 int32 on the device), the Image (rgba f32, two f64 times,
#: 5 x 4 bytes) and the pixel direction tables (two float32 vec3, frame_inputs.MAX_DIRECTIONS).
BYTES_PER_PIXEL = (4 * 4 + 5 * 4 + 3 * 4) + (4 * 4 + 2 * 8 + 5 * 4) + 2 * 3 * 4
#: Per triangle of the rigid (two-level) database, which neither speed, lifetime nor
#: frame span changes, no body sharing its shape (rendering.database_bytes counts the
#: real one): the shading tables, one copy the host and the device share (normal
#: float32 x 3, size float32, smooth / body / material int32), the shape's vertex
#: indices (int32 x 3, which the bottom level reads too: accel/blas.py), 68 for the
#: bottom level's build (its float64 boxes of the triangles; the wide nodes it keeps are
#: ~11 bytes per triangle of a shape) and 16 for the build's other transients (each
#: body's triangles, held until taken). On bench_database_bytes.py --distinct: 132 + 12
#: per triangle against a peak RSS growth of 112.
BYTES_PER_RIGID_TRIANGLE = (12 + 4 + 12) + 12 + 68 + 16
#: Per vertex: shading normal (float32 x 3) and the shape's rest point (float32 x 3).
BYTES_PER_RIGID_VERTEX = 12 + 12


def estimate_bytes(tetrahedra: int, vertices: int, pixels: int = 0) -> int:
    """Peak bytes of a database of ``tetrahedra`` / ``vertices`` and a frame of ``pixels``.

    Per tetrahedron: its indices (int32 x 4) and triangle (int32) on the host and the
    device, the (N, 4, 4) float64 events and (N, 4) x 2 boxes of the BVH build, the
    build's scratch at its peak (centres, Morton quantisation, node links, sorted
    boxes) and ~0.7 BVH nodes (box corners float64 host + float32 device, two int32
    links): BYTES_PER_TET = 465. Measured with tracemalloc, the host peak of a build is
    about 0.85 of the estimate (``tests/rendering/test_faults.py``).
    Per vertex: the event (float64 host, float32 device) and the shading normal.
    """
    return int(tetrahedra * BYTES_PER_TET + vertices * BYTES_PER_VERTEX + pixels * BYTES_PER_PIXEL)


def estimate_rigid_bytes(triangles: int, vertices: int, pixels: int = 0) -> int:
    """Peak bytes of a rigid database of ``triangles`` / ``vertices`` and a frame of
    ``pixels`` (the motion segments, a few per body, are left out)."""
    return int(triangles * BYTES_PER_RIGID_TRIANGLE + vertices * BYTES_PER_RIGID_VERTEX + pixels * BYTES_PER_PIXEL)


class MemoryRefusal(SceneError):
    """A render whose estimated memory exceeds the limit (bad input: exit 2)."""


def texture_bytes(scene: Scene) -> int:
    """Bytes the textures and the sky map take: each distinct texel array on the host and
    once more as the kernel's atlas (``device_textures``)."""
    arrays = {id(t.texels): t.texels for b in scene.bodies for s in b.surfaces
              for m in (s.material, *s.subset_materials) for t in m.textures if t is not None}
    if scene.dome is not None and scene.dome.texels is not None:
        arrays[id(scene.dome.texels)] = scene.dome.texels
    return 2 * sum(int(a.nbytes) for a in arrays.values())


def count_database(scene: Scene, windows, *, fine: bool = True, fraction: float | None = None, view=None
                   ) -> tuple[int, int, list[int]]:
    """(tetrahedra, vertices, tetrahedra per body) the extrusion of ``scene`` over ``windows`` makes.

    Exactly what :func:`warp_st.spacetime.extrude.extrude_scene` allocates (3 tetrahedra per
    non-degenerate triangle per segment, one vertex per point per slice), without
    building it. A window that is not finite raises SceneError naming the body.
    """
    _check_finite(scene, windows)
    tets, verts, per_body = 0, 0, []
    for body, window in zip(scene.bodies, windows):
        n_body = 0
        parts = intervals(window)
        if parts and body.surfaces:
            segments = sum(len(body_slices(body, part, fine=fine, fraction=fraction, view=view)) - 1 for part in parts)
            for surf in body.surfaces:
                n_tri = triangle_count(surf)
                if n_tri:
                    n_body += 3 * n_tri * segments
                    verts += (segments + len(parts)) * len(surf.points)
        per_body.append(n_body)
        tets += n_body
    return tets, verts, per_body


def _check_finite(scene: Scene, windows) -> None:
    """SceneError naming the first body with triangles whose visible window is not finite."""
    for body, window in zip(scene.bodies, windows):
        parts = intervals(window)
        if parts and body.surfaces and not all(math.isfinite(t) for part in parts for t in part):
            raise SceneError.at(
                scene.source, body.prim_path, None,
                f"its visible time window {_window_text(window)} is not finite (positions, speeds or times too large)",
            )


def _window_text(window) -> str:
    parts = intervals(window)
    return str(parts[0]) if len(parts) == 1 else " + ".join(str(p) for p in parts)


def _check_windows(scene: Scene, windows, max_depth: int) -> None:
    """SceneError for a visible window whose coordinates would pass MAX_WINDOW, naming its likely cause."""
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


def triangle_count(surf) -> int:
    """``len(surface_triangles(surf))`` without building the triangles (the count only)."""
    return int(np.count_nonzero(surface_keep(surf)))


def check_limits(scene: Scene, windows, *, width: int, height: int, samples: int = 1, max_depth: int = 0) -> None:
    """Refuse (SceneError) a render beyond the kernels' ranges: samples, bounces, pixels,
    and visible windows whose coordinates pass MAX_WINDOW. Cheap: no counting."""
    src = scene.source
    if samples > MAX_SAMPLES:
        raise SceneError.at(src, None, "samples", f"must be <= {MAX_SAMPLES}, got {samples}")
    if max_depth > MAX_BOUNCES:
        raise SceneError.at(src, None, "maxDepth", f"must be <= {MAX_BOUNCES}, got {max_depth}")
    pixels = int(width) * int(height)
    if pixels > MAX_PIXELS:
        raise SceneError.at(src, None, "resolution", f"{width} x {height} is more than {MAX_PIXELS} pixels")
    _check_windows(scene, windows, max_depth)


def check_resources(scene: Scene, windows, *, width: int, height: int, samples: int = 1, max_depth: int = 0,
                    max_memory: int | None = None, fine: bool = True, fraction: float | None = None,
                    rigid: bool = False, view=None) -> int:
    """Refuse (SceneError; MemoryRefusal over ``max_memory``) a render that would exceed
    ``max_memory`` or the kernels' ranges. ``fine`` and ``fraction``: the
    time-segment rule (``extrude.body_slices``; ``view``: its cameras); ``rigid``: the two-level database instead of the
    extrusion (its size is the scene's triangles, whatever the windows). Called after
    the visibility windows and before the build. Returns the estimate.
    """
    check_limits(scene, windows, width=width, height=height, samples=samples, max_depth=max_depth)
    pixels = int(width) * int(height)
    if rigid:
        _check_finite(scene, windows)
        counts = [[triangle_count(s) for s in b.surfaces] for b in scene.bodies]
        tris = [sum(c) for c in counts]
        verts = sum(len(s.points) for b, c in zip(scene.bodies, counts) for s, n in zip(b.surfaces, c) if n)
        estimate, what, per_body = estimate_rigid_bytes(sum(tris), verts, pixels), f"{sum(tris):,} triangles", tris
        unit = "triangles"
    else:
        tets, verts, per_body = count_database(scene, windows, fine=fine, fraction=fraction, view=view)
        estimate, what, unit = estimate_bytes(tets, verts, pixels), f"{tets:,} tetrahedra", "tetrahedra"
    textures = texture_bytes(scene)
    if textures:
        estimate, what = estimate + textures, f"{what}, {format_size(textures)} of textures"
    if max_memory is not None and estimate > max_memory:
        biggest = ""
        if per_body and max(per_body) > 0:
            i = int(np.argmax(per_body))
            biggest = f"; the largest body is {scene.bodies[i].prim_path} with {per_body[i]:,} {unit}"
        raise MemoryRefusal.at(
            scene.source, None, None,
            f"the render needs about {format_size(estimate)} ({what}, {verts:,} vertices, "
            f"{pixels:,} pixels), more than the memory limit of {format_size(max_memory)}{biggest}; "
            "raise --max-memory (max_memory=) or shorten the frame range, lifetimes or speeds",
        )
    return estimate
