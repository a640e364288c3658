"""Tessellation of the analytic USD gprims (UsdGeom.Sphere, UsdGeom.Cube).

Both produce closed meshes with shared vertices (so extrusion gives a watertight
world-tube), in the prim's local space.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["sphere", "cube", "sphere_segments_for_sagitta", "DEFAULT_SPHERE_SEGMENTS"]

#: Longitude segments of a sphere when nothing asks for finer: the chord sagitta
#: is r (1 - cos(pi / 64)) = 1.2e-3 r.
DEFAULT_SPHERE_SEGMENTS = 64


def sphere_segments_for_sagitta(radius: float, sagitta: float, *, lo: int = 8, hi: int = 512) -> int:
    """Longitude segments n so that a great-circle chord's sagitta r(1 - cos(pi/n)) <= sagitta."""
    if sagitta <= 0.0 or radius <= 0.0:
        return hi
    ratio = min(sagitta / radius, 1.0)
    n = math.ceil(math.pi / math.acos(1.0 - ratio)) if ratio < 1.0 else lo
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
