"""Tessellation of the analytic USD gprims (UsdGeom Sphere, Cube, Cylinder, Cone, Capsule, Plane).

All but the plane (one quad) are closed, in the prim's local space. Sphere and cube share
their vertices (so extrusion gives a watertight world-tube); cylinders and cones repeat
theirs at the rims, where the normal changes, at the very same coordinates.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["sphere", "cube", "cylinder", "capsule", "plane", "sphere_segments_for_sagitta", "DEFAULT_SPHERE_SEGMENTS"]

#: Longitude segments of a sphere when nothing asks for finer: the chord sagitta
#: is r (1 - cos(pi / 64)) = 1.2e-3 r.
DEFAULT_SPHERE_SEGMENTS = 64


def sphere_segments_for_sagitta(radius: float, sagitta: float, *, lo: int = 8, hi: int = 512) -> int:
    """Longitude segments n so that a great-circle chord's sagitta r(1 - cos(pi/n)) <= sagitta."""
    if sagitta <= 0.0 or radius <= 0.0:
        return hi
    ratio = min(sagitta / radius, 1.0)
    angle = math.acos(1.0 - ratio)  # 0 when the ratio is below float64's resolution at 1
    if angle == 0.0:
        return hi
    n = math.ceil(math.pi / angle) if ratio < 1.0 else lo
    return int(min(max(n, lo), hi))


def sphere(radius: float, segments: int = DEFAULT_SPHERE_SEGMENTS):
    """UV sphere: ``segments`` longitudes, ``segments // 2`` latitude bands.

    Returns (points (P, 3), triangles (T, 3), normals (P, 3)); single pole vertices.
    """
    n_lon = max(int(segments), 3)
    n_lat = max(n_lon // 2, 2)
    theta = np.linspace(0.0, math.pi, n_lat + 1)[1:-1]  # interior latitudes
    phi = np.linspace(0.0, 2.0 * math.pi, n_lon, endpoint=False)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack(
        [st * np.cos(phi)[None, :], ct * np.ones_like(phi)[None, :], st * np.sin(phi)[None, :]], axis=-1
    ).reshape(-1, 3)
    normals = np.concatenate([[[0.0, 1.0, 0.0]], ring, [[0.0, -1.0, 0.0]]])
    top, bottom = 0, len(normals) - 1

    def vid(i, j):  # ring i (0 at top), longitude j
        return 1 + i * n_lon + (j % n_lon)

    tris = []
    j = np.arange(n_lon)
    tris.append(np.stack([np.full(n_lon, top), vid(0, j + 1), vid(0, j)], axis=1))
    for i in range(n_lat - 2):
        a, b, c, d = vid(i, j), vid(i, j + 1), vid(i + 1, j), vid(i + 1, j + 1)
        tris.append(np.stack([a, b, d], axis=1))
        tris.append(np.stack([a, d, c], axis=1))
    last = n_lat - 2
    tris.append(np.stack([vid(last, j), vid(last, j + 1), np.full(n_lon, bottom)], axis=1))
    triangles = np.concatenate(tris).astype(np.int64)
    return normals * float(radius), triangles, normals.copy()


_CUBE_QUADS = np.array(
    [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]], dtype=np.int64
)


def cube(size: float = 2.0):
    """Axis-aligned cube of edge ``size`` centred on the origin: (points (8, 3), triangles (12, 3))."""
    h = 0.5 * float(size)
    corners = np.array([[x, y, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)], dtype=np.float64)
    q = _CUBE_QUADS
    triangles = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return corners, triangles


# --- UsdGeom Cylinder (and Cylinder_1), Cone, Capsule (and Capsule_1), Plane ------------------
#
# Built about a local spine s with two cross axes (a, b), then turned onto the authored
# ``axis`` by a cyclic permutation (a rotation: winding and normals stay outward). Every
# shape is centred on the origin as UsdGeom defines it; longitudes are a multiple of 4, so
# the extreme points are vertices and the triangles' bounds are the shapes' extents.

#: rows: the images of local a, b, s for each UsdGeom ``axis`` (USD row-vector convention).
_AXIS_FRAME = {
    "X": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
    "Y": np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    "Z": np.eye(3),
}


def _longitudes(segments: int) -> int:
    return max(4, 4 * math.ceil(int(segments) / 4))


def _ring(radius: float, height: float, phi: np.ndarray) -> np.ndarray:
    return np.stack([radius * np.cos(phi), radius * np.sin(phi), np.full_like(phi, height)], axis=1)


def _band(profile, normals, phi):
    """Revolve the polyline ``profile`` [(r, s), ...] (per-point (n_r, n_s) ``normals``) about s.

    A ring of radius 0 is repeated per longitude (each copy with its triangle's normal), so
    no triangle is degenerate and an apex shades smoothly."""
    n = len(phi)
    mid = phi + math.pi / n  # the longitude of each triangle at a pole
    points, shading, tris = [], [], []
    for i, ((r, s), (nr, ns)) in enumerate(zip(profile, normals)):
        angles = mid if r == 0.0 else phi
        points.append(_ring(r, s, angles))
        shading.append(np.stack([nr * np.cos(angles), nr * np.sin(angles), np.full(n, ns)], axis=1))
        if i == 0:
            continue
        j = np.arange(n)
        a, b = (i - 1) * n + j, (i - 1) * n + (j + 1) % n
        c, d = i * n + j, i * n + (j + 1) % n
        if profile[i - 1][0] == 0.0:  # from a pole: one triangle per longitude
            tris.append(np.stack([a, d, c], axis=1))
        elif r == 0.0:  # to a pole
            tris.append(np.stack([a, b, c], axis=1))
        else:
            tris += [np.stack([a, b, d], axis=1), np.stack([a, d, c], axis=1)]
    return np.concatenate(points), np.concatenate(tris), np.concatenate(shading)


def _assemble(parts, axis: str):
    """Concatenate (points, triangles, normals) parts, wind every triangle outward (along
    its shading normals) and turn the spine onto ``axis``."""
    points, tris, normals, base = [], [], [], 0
    for p, t, nrm in parts:
        points.append(p)
        tris.append(t + base)
        normals.append(nrm)
        base += len(p)
    points, tris, normals = np.concatenate(points), np.concatenate(tris), np.concatenate(normals)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = normals / np.where(length > 0.0, length, 1.0)
    face = np.cross(points[tris[:, 1]] - points[tris[:, 0]], points[tris[:, 2]] - points[tris[:, 0]])
    inward = np.einsum("ij,ij->i", face, normals[tris].sum(axis=1)) < 0.0
    tris[inward] = tris[inward][:, [0, 2, 1]]
    frame = _AXIS_FRAME[axis]
    return points @ frame, tris.astype(np.int64), normals @ frame


def _disk(radius: float, height: float, facing: float, phi):
    centre = np.array([[0.0, 0.0, height]])
    n = len(phi)
    points = np.concatenate([centre, _ring(radius, height, phi)])
    j = np.arange(n)
    tris = np.stack([np.zeros(n, np.int64), 1 + j, 1 + (j + 1) % n], axis=1)
    return points, tris, np.tile([0.0, 0.0, facing], (n + 1, 1))


def cylinder(radius_bottom: float, radius_top: float, height: float, axis: str = "Z",
             segments: int = DEFAULT_SPHERE_SEGMENTS):
    """UsdGeom Cylinder (radius_top == radius_bottom), Cylinder_1, or Cone (radius_top = 0):
    a capped frustum along ``axis`` from -height/2 (radius_bottom) to +height/2.

    Returns (points, triangles, normals): smooth side normals, flat caps (their own vertices)."""
    phi = np.linspace(0.0, 2.0 * math.pi, _longitudes(segments), endpoint=False)
    h = 0.5 * float(height)
    rb, rt = float(radius_bottom), float(radius_top)
    slope = np.array([2.0 * h, rb - rt])  # outward normal (n_r, n_s) of the side
    slope = slope / np.linalg.norm(slope)
    parts = [_band([(rb, -h), (rt, h)], [slope, slope], phi)]
    if rb > 0.0:
        parts.append(_disk(rb, -h, -1.0, phi))
    if rt > 0.0:
        parts.append(_disk(rt, h, 1.0, phi))
    return _assemble(parts, axis)


def _cap_angles(start: float, stop: float, step: float) -> np.ndarray:
    """Polar angles from ``start`` to ``stop`` in about ``step``, with the equator when inside."""
    if start == stop:
        return np.array([start])
    count = max(1, math.ceil(abs(stop - start) / step - 1e-9))
    angles = np.linspace(start, stop, count + 1)
    lo, hi = min(start, stop), max(start, stop)
    if lo < 0.5 * math.pi < hi and not np.isclose(angles, 0.5 * math.pi).any():
        angles = np.sort(np.append(angles, 0.5 * math.pi))[:: 1 if start < stop else -1]
    return angles


def capsule(radius_bottom: float, radius_top: float, height: float, axis: str = "Z",
            segments: int = DEFAULT_SPHERE_SEGMENTS):
    """UsdGeom Capsule (equal radii) or Capsule_1: a frustum of ``height`` along ``axis``
    closed by two spherical caps tangent to it (hemispheres when the radii are equal).

    With d = radius_bottom - radius_top, a cap of join radius r at s0 = -+height/2 is a
    sphere of radius r sqrt(height^2 + d^2) / height centred at s0 - r d / height (the side's
    normal at the join passes through the centre). Returns (points, triangles, normals)."""
    n = _longitudes(segments)
    phi = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    hh, rb, rt = float(height), float(radius_bottom), float(radius_top)
    step = 2.0 * math.pi / n
    if hh <= 0.0:  # no side: one sphere (the larger cap)
        caps = [(max(rb, rt), 0.0, math.pi, 0.0)]
    else:
        d = rb - rt
        scale = math.hypot(hh, d) / hh
        bottom = (rb * scale, -0.5 * hh - rb * d / hh)
        top = (rt * scale, 0.5 * hh - rt * d / hh)
        # polar angle (from +s) of each join circle on its own sphere
        join_b = math.atan2(rb, -0.5 * hh - bottom[1]) if rb > 0.0 else math.pi
        join_t = math.atan2(rt, 0.5 * hh - top[1]) if rt > 0.0 else 0.0
        caps = [(bottom[0], bottom[1], math.pi, join_b), (top[0], top[1], join_t, 0.0)]
    profile, normals = [], []
    for radius, centre, start, stop in caps:
        for theta in _cap_angles(start, stop, step):  # the join rings bound the side (normals agree)
            sin, cos = (0.0 if theta in (0.0, math.pi) else math.sin(theta)), math.cos(theta)
            profile.append((radius * sin, centre + radius * cos))
            normals.append((sin, cos))
    return _assemble([_band(profile, normals, phi)], axis)


def plane(width: float, length: float, axis: str = "Z"):
    """UsdGeom Plane: a width x length rectangle through the origin, normal to ``axis``
    (width along X for axis Y or Z, along Z for axis X; length along Y for X or Z, along Z
    for Y, as UsdGeom's extents). Returns (points, triangles, normals)."""
    w, ln = 0.5 * float(width), 0.5 * float(length)
    x, y, z = np.eye(3)
    u, v = {"X": (w * z, ln * y), "Y": (w * x, ln * z), "Z": (w * x, ln * y)}[axis]
    normal = _AXIS_FRAME[axis][2]
    points = np.array([-u - v, u - v, u + v, -u + v])
    tris = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    if np.dot(np.cross(u, v), normal) < 0.0:
        tris = tris[:, [0, 2, 1]]
    return points, tris, np.tile(normal, (4, 1))
