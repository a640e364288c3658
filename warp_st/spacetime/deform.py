"""Deforming bodies in the 4D database: per-vertex worldlines sliced into prisms (docs/spec.md §2.2).

A deforming body's points move independently: linearly between USD's sample times
(``core.deform.PointSamples``), held outside them, plus the body's uniform
``spacetime:fourVelocity`` motion. Its slices are the sample times inside the window,
each interval split evenly into k parts; a prism between two slices is cut into its three
tetrahedra (``extrude._prism_tets``), so the traced world-tube is the union of flat
tetrahedra through the sampled events, exact there. Between two slices a vertex moves
linearly, as USD interpolates; the tetrahedra's surface at a lab time t departs from the
triangle through the interpolated vertices by at most f (1 - f) max |d_i - d_j| over the
triangle's corners i, j (d the corners' displacements over the slice interval, f its
fraction at t), so k is the smallest with max |d_i - d_j| / (4 k) <= the tolerance. With the
render's cameras (a ``SliceView``) the tolerance is the rigid animated path's half-pixel rule
(``spacetime.animation``): half a pixel at the nearest distance any camera can see the body
in that sample interval, over the cameras' and the points' angular magnification; without
(extrusions built for tests) DEFORM_TOLERANCE x the body's size. k also keeps each slice's
largest displacement within the extrusion's sweep per segment (``extrude.segment_sweep``,
the 4D boxes' rule).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from warp_st.core.deform import deforming, surface_hull_points
from warp_st.core.scene import Body, SceneError, surface_keep, surface_triangles
from warp_st.spacetime.adaptive import _camera_stretch, min_pixel_angle
from warp_st.spacetime.animation import FLOOR_FRACTION
from warp_st.spacetime.turning import worldline_body

__all__ = ["DEFORM_TOLERANCE", "deforming", "deform_primitive", "deform_slices", "deformed_events", "deformed_triangles",
           "slice_velocities", "SliceView", "slice_view"]

#: Largest distance between the traced surface and USD's interpolated one, as a fraction
#: of the body's size (its largest extent over all its samples).
DEFORM_TOLERANCE = 2.5e-4


@dataclasses.dataclass(frozen=True)
class SliceView:
    """The render's cameras as the slices' half-pixel rule sees them (hashable: a database
    cache key). positions: each camera event's position, ((x, y, z), ...); stretch: the
    angular magnification bound of each (``adaptive._camera_stretch``); angle: the smallest
    pixel angle of any (radians); pixels: the tolerance in pixels."""

    positions: tuple
    stretch: tuple
    angle: float
    pixels: float = 0.5


def slice_view(cameras, *, width: int, height: int, pixels: float = 0.5) -> SliceView:
    """The ``SliceView`` of camera states ``cameras`` rendering ``width`` x ``height``."""
    cameras = list(cameras)
    return SliceView(positions=tuple(tuple(float(x) for x in np.asarray(c.position, dtype=np.float64))
                                     for c in cameras),
                     stretch=tuple(float(_camera_stretch(c)) for c in cameras),
                     angle=float(min((min_pixel_angle(c, width, height) for c in cameras), default=np.inf)),
                     pixels=float(pixels))


def _view_tolerance(view: SliceView, pa: np.ndarray, pb: np.ndarray, dt: float) -> float:
    """The half-pixel tolerance of a sample interval whose points go from ``pa`` to ``pb``
    (linearly, in ``dt``): every surface point in it lies in the box of both ends' points,
    so no camera sees it nearer than the box; a decoupled body's retarded image is
    magnified by up to gamma of its fastest point (inf at >= c). Never below FLOOR_FRACTION
    of the body's extent at the ends (a camera inside the box, a point at >= c)."""
    both = np.concatenate([pa, pb])
    lo, hi = both.min(axis=0), both.max(axis=0)
    speed = float(np.linalg.norm(pb - pa, axis=1).max()) / dt if dt > 0.0 and len(pa) else 0.0
    body_stretch = 1.0 / math.sqrt(1.0 - speed * speed) if speed < 1.0 else np.inf
    tol = np.inf
    for position, stretch in zip(view.positions, view.stretch):
        d = float(np.linalg.norm(np.maximum(np.maximum(lo - position, position - hi), 0.0)))
        s = stretch * body_stretch
        tol = min(tol, view.pixels * view.angle * d / s if d > 0.0 and np.isfinite(s) else 0.0)
    extent = max(float(np.max(pa.max(axis=0) - pa.min(axis=0))), float(np.max(pb.max(axis=0) - pb.min(axis=0))))
    return max(tol, FLOOR_FRACTION * max(extent, 1e-6))


def _surfaces(body: Body) -> list:
    """The surfaces ``extrude.body_triangles`` keeps (those with a triangle), in its order."""
    return [s for s in body.surfaces if surface_keep(s).any()]


def _triangles(body: Body) -> np.ndarray:
    """The kept surfaces' triangles as indices into their concatenated points, (T, 3)."""
    parts, base = [], 0
    for s in _surfaces(body):
        parts.append(surface_triangles(s) + base)
        base += len(s.points)
    return np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)


def points_at(body: Body, t: float) -> np.ndarray:
    """Every kept point of ``body`` at lab time ``t``, (P, 3), the uniform motion added."""
    pts = [s.samples.at(t) if s.samples is not None else np.asarray(s.points, dtype=np.float64)
           for s in _surfaces(body)]
    return np.concatenate(pts) + np.asarray(body.velocity, dtype=np.float64) * (t - body.reference_time)


def _size(body: Body) -> float:
    pts = np.concatenate([surface_hull_points(s) for s in body.surfaces])
    return max(float(np.max(pts.max(axis=0) - pts.min(axis=0))), 1e-6)


def deform_slices(body: Body, window, sweep: float, *, max_segments: int = 4096,
                  view: SliceView | None = None) -> np.ndarray:
    """Slice times covering ``window`` for a deforming body, ascending, at least two: its
    sample times inside it, each interval split evenly until the tetrahedra follow USD's
    linear interpolation within half a pixel of ``view``'s cameras (without a view:
    DEFORM_TOLERANCE x its size) and no point moves more than ``sweep`` per slice. At most
    ``max_segments`` parts per interval."""
    lo, hi = float(window[0]), float(window[1])
    times = np.unique(np.concatenate([s.samples.times for s in body.surfaces if s.samples is not None]))
    knots = [lo, *[float(t) for t in times if lo < t < hi], hi]
    tris = _triangles(body)
    fixed = DEFORM_TOLERANCE * _size(body)
    out = [lo]
    pa = points_at(body, lo)
    for a, b in zip(knots[:-1], knots[1:]):
        pb = points_at(body, b)
        d = pb - pa
        spread = 0.0
        if len(tris):
            spread = max(float(np.linalg.norm(d[tris[:, i]] - d[tris[:, j]], axis=1).max())
                         for i, j in ((0, 1), (1, 2), (0, 2)))
        moved = float(np.linalg.norm(d, axis=1).max()) if len(d) else 0.0
        tol = fixed if view is None else _view_tolerance(view, pa, pb, b - a)
        k = max(1, math.ceil(0.25 * spread / tol), math.ceil(moved / sweep) if sweep > 0.0 else 1)
        out.extend(np.linspace(a, b, min(k, max_segments) + 1)[1:].tolist())
        pa = pb
    if len(out) < 2:
        out.append(hi)
    return np.array(out, dtype=np.float64)


def deformed_events(body: Body, slices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Events (K+1, P, 4) of every kept point at every slice, and the shading normals there
    (K+1, P, 3): area-weighted vertex normals of the deformed triangles at each slice."""
    tris = _triangles(body)
    pts = np.stack([points_at(body, float(t)) for t in slices])  # (K+1, P, 3)
    ev = np.empty(pts.shape[:2] + (4,))
    ev[:, :, 0] = slices[:, None]
    ev[:, :, 1:] = pts
    face = np.cross(pts[:, tris[:, 1]] - pts[:, tris[:, 0]], pts[:, tris[:, 2]] - pts[:, tris[:, 0]])  # (K+1, T, 3)
    normals = np.zeros_like(pts)
    for corner in range(3):
        np.add.at(normals, (slice(None), tris[:, corner]), face)
    normals /= np.maximum(np.linalg.norm(normals, axis=2, keepdims=True), 1e-300)
    return ev, normals


def slice_velocities(events: np.ndarray) -> np.ndarray:
    """Each point's lab velocity over the slice interval above each slice, (K+1, P, 3), from
    its events (K+1, P, 4) (``deformed_events``): between two slices a point moves linearly
    (every sample time is a slice), so this is its exact velocity there, the uniform motion
    included. The last slice, the top of the last interval only, repeats the interval below."""
    dt = np.diff(events[:, 0, 0])[:, None, None]
    up = np.diff(events[:, :, 1:], axis=0) / np.where(dt > 0.0, dt, 1.0)
    return np.concatenate([up, up[-1:]])


def deformed_triangles(body: Body, bt, longest_edges):
    """``bt`` (``extrude.BodyTriangles``) for a deforming body: shaded with its per-slice
    vertex normals (``deformed_events``), each triangle's size its largest over the samples.
    A triangle whose corners no other triangle shares is shaded with its own face's normal:
    size 0, so that its shadow rays do not skip its body (``kernels/shade.py``: the skip is
    for smooth facets near the terminator; a turning box, ``spacetime.turning``, shadows itself)."""
    times = np.unique(np.concatenate([s.samples.times for s in body.surfaces if s.samples is not None]))
    size = np.max([longest_edges(points_at(body, float(t)), bt.triangles) for t in times], axis=0)
    uses = np.bincount(bt.triangles.reshape(-1), minlength=len(bt.local))
    size = np.where((uses[bt.triangles] == 1).all(axis=1), 0.0, size)
    return dataclasses.replace(bt, tri_smooth=np.ones(len(bt.triangles), np.int32), tri_size=size)


def deform_primitive(scene, primitive: str | None, rigid: bool = True, worldlines: bool = True) -> str | None:
    """The renderer's primitive for ``scene`` when a body deforms, or turns and is traced as
    per-vertex worldlines (``turning.worldline_body``, with ``worldlines``): its prisms are
    not rigid (only their tetrahedra are exact), so "prism" is an error; "rigid" traces the
    deforming bodies' tetrahedra as leaves of the two-level path (``spacetime.mixed``), the
    default where the rigid path is (``rigid``: float32), else "tet". Without one: ``primitive``."""
    body = next((b for b in scene.bodies if deforming(b) or (worldlines and worldline_body(b))), None)
    if body is None or primitive in ("tet", "rigid"):
        return primitive
    if primitive is None:
        return None if rigid else "tet"
    raise SceneError.at(scene.source, body.prim_path, "primitive",
                        f"a deforming body is traced on the tet or rigid path only (got {primitive!r}); "
                        "use primitive='rigid' or 'tet'")
