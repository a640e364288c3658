"""Deterministic quadrature points on UsdLux area lights (docs/spec.md §3, docs/design/usdlux.md).

A RectLight or DiskLight is shaded as a sum over a few fixed points p_i on its
surface with area weights w_i (the weights sum to the light's area): each point is
one shadow ray, and the irradiance on a surface at x with normal N is

    E = L * sum_i w_i * max(0, N.l_i) * max(0, Z.l_i) / |p_i - x|^2,   l_i = (p_i - x) / |p_i - x|,

with Z the light's back normal (it emits along -Z). The points are Gauss-Legendre nodes:
the tensor product over the rectangle, and over the disk in (rho^2, phi) (rho^2 makes the
area element uniform; phi equally spaced). Pure NumPy, float64.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.scene import Light

__all__ = ["RECT_NODES", "DISK_RINGS", "DISK_SPOKES", "area_samples"]

#: Gauss-Legendre nodes per side of a RectLight (RECT_NODES^2 shadow rays).
RECT_NODES = 4
#: Gauss-Legendre nodes in rho^2 and equally spaced angles of a DiskLight (their product: shadow rays).
DISK_RINGS = 3
DISK_SPOKES = 6


def _unit_rect() -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(RECT_NODES)
    a, b = np.meshgrid(x, x, indexing="ij")
    return np.stack([a.ravel(), b.ravel()], axis=1), np.outer(w, w).ravel() / 4.0  # weights sum to 1


def _unit_disk() -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(DISK_RINGS)
    rho = np.sqrt(0.5 * (x + 1.0))  # rho^2 uniform on [0, 1]
    phi = (np.arange(DISK_SPOKES) + 0.5) * (2.0 * np.pi / DISK_SPOKES)
    r, p = np.meshgrid(rho, phi, indexing="ij")
    ab = np.stack([(r * np.cos(p)).ravel(), (r * np.sin(p)).ravel()], axis=1)
    return ab, np.repeat(0.5 * w, DISK_SPOKES) / DISK_SPOKES  # weights sum to 1


def area_samples(light: Light) -> tuple[np.ndarray, np.ndarray]:
    """(points (K, 3), area weights (K,)) on a "rect" or "disk" light, lab frame; empty for other kinds."""
    if light.kind not in ("rect", "disk"):
        return np.zeros((0, 3)), np.zeros(0)
    ab, w = _unit_rect() if light.kind == "rect" else _unit_disk()
    u, v = (np.asarray(a, dtype=np.float64) for a in light.axes)
    area = float(np.linalg.norm(np.cross(u, v))) * (4.0 if light.kind == "rect" else np.pi)
    points = np.asarray(light.position, dtype=np.float64) + ab[:, :1] * u + ab[:, 1:] * v
    return points, w * area
