"""Diffuse irradiance of a sky map by spherical harmonics (Ramamoorthi & Hanrahan 2001).

The radiance L(w) of a latlong map is projected on the nine real spherical harmonics of
order <= 2 (each texel subdivided SUB x SUB times, weighed by its exact solid angle); the
irradiance E(n) = integral of L(w) max(0, n.w) dw is then sum_k A_l(k) L_k Y_k(n), with
A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4 (the clamped cosine's own expansion, whose
higher terms are small: the approximation's error). A constant sky is exact
(E = pi L). The coefficients are returned already multiplied by A_l, in the lab's axes:
the kernel evaluates E(n) = sum_k C_k Y_k(n).
"""
from __future__ import annotations

import numpy as np

__all__ = ["sh_basis", "irradiance_coefficients", "SUB"]

#: Sub-samples per texel axis in the projection.
SUB = 4
_A = np.array([np.pi] + [2.0 * np.pi / 3.0] * 3 + [np.pi / 4.0] * 5)


def sh_basis(d: np.ndarray) -> np.ndarray:
    """The nine real SH of order <= 2 at unit directions d (..., 3) -> (..., 9), in the
    order Y00, Y1-1 (y), Y10 (z), Y11 (x), Y2-2 (xy), Y2-1 (yz), Y20, Y21 (xz), Y22."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([np.full_like(x, 0.282094791773878), 0.488602511902920 * y, 0.488602511902920 * z,
                     0.488602511902920 * x, 1.092548430592079 * x * y, 1.092548430592079 * y * z,
                     0.315391565252520 * (3.0 * z * z - 1.0), 1.092548430592079 * x * z,
                     0.546274215296040 * (x * x - y * y)], axis=-1)


def irradiance_coefficients(radiance, texels: np.ndarray | None, local_from_lab: np.ndarray) -> np.ndarray:
    """(9, 3): A_l x the SH coefficients of the sky's radiance, lab axes.

    radiance: the map's multiplier (3,); texels: the latlong map (H, W, >=3) in OpenEXR's
    layout (kernels/sky.py), or None for a constant sky; local_from_lab: (3, 3)."""
    radiance = np.asarray(radiance, dtype=np.float64)
    coef = np.zeros((9, 3))
    if texels is None:
        coef[0] = radiance * 4.0 * np.pi * 0.282094791773878
        return coef * _A[:, None]
    h, w = texels.shape[:2]
    # Sub-texel centres: column u -> longitude pi - 2 pi u, row v -> latitude pi/2 - pi v.
    u = (np.arange(w * SUB) + 0.5) / (w * SUB)
    v_edges = np.arange(h * SUB + 1) / (h * SUB)
    lat_edges = np.pi / 2.0 - np.pi * v_edges
    lat = 0.5 * (lat_edges[:-1] + lat_edges[1:])
    lon = np.pi - 2.0 * np.pi * u
    # Exact solid angle of each sub-texel: d(lon) x (sin(lat_top) - sin(lat_bottom)).
    omega = (2.0 * np.pi / (w * SUB)) * (np.sin(lat_edges[:-1]) - np.sin(lat_edges[1:]))
    la, lo = lat[:, None], lon[None, :]
    local = np.stack([np.cos(la) * np.sin(lo), np.sin(la) * np.ones_like(lo), np.cos(la) * np.cos(lo)], axis=-1)
    lab = local @ np.asarray(local_from_lab, dtype=np.float64)  # d_lab = local_from_lab^T d_local
    rgb = np.repeat(np.repeat(np.asarray(texels, dtype=np.float64)[..., :3], SUB, axis=0), SUB, axis=1) * radiance
    weights = sh_basis(lab) * omega[:, None, None]  # (H S, W S, 9)
    coef = np.einsum("ijk,ijc->kc", weights, rgb)
    return coef * _A[:, None]
