"""Doppler colour shift from tabulated colorimetry (host side, float64).

An RGB radiance is upsampled to a spectrum with Smits (1999): piecewise linear in the RGB
components, a non-negative mix of seven basis reflectances (white, cyan, magenta, yellow,
red, green, blue; ``colour.recovery.SDS_SMITS1999``) chosen by the ordering of R, G, B.
Being a radiance, the reflectance is multiplied by the white spectrum, a Planck
blackbody at D65's correlated colour temperature (6504 K), which is defined at every
wavelength a shift can reach. A Doppler factor D moves emitted wavelength mu to mu / D,
so the received spectrum is ``D * L(lambda * D)`` (power preserved; the searchlight's D^4
is separate). It is projected with the CIE 1931 2-degree colour matching functions
(``colour.MSDS_CMFS``, 1 nm table, 360-830 nm, summed as CIE 15 does) and the XYZ ->
linear sRGB matrix.

The shift is linear in the basis weights, so the host tabulates, for each basis spectrum
k and each D on a log2 grid, the received RGB ``T[D, k]``; the kernel (kernels/spectrum.py)
interpolates the table and mixes the ordering's three weights. Normalisation, fixed once
at D = 1 and applied to every D: a diagonal white balance makes white exactly (1, 1, 1),
then the red, green and blue basis spectra absorb each basis's residual RGB error (their
own 3x3 inverse), so every basis reproduces its ideal RGB at D = 1 and D = 1 is the
identity for every colour.
"""
from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import os
import threading
import warnings
from pathlib import Path

import numpy as np

__all__ = ["BASES", "IDEAL_RGB", "LOG2_D_MIN", "LOG2_D_MAX", "NODES_PER_OCTAVE", "INTERPOLATION_ERROR", "WHITE_K",
           "cmfs", "d_nodes", "smits_weights", "smits_spectrum", "received_xyz", "doppler_table",
           "cached_doppler_table", "doppler_transform_np"]

#: Smits (1999) basis spectra in table order; the kernel indexes them 0..6.
BASES = ("white", "cyan", "magenta", "yellow", "red", "green", "blue")
#: The ideal linear RGB of each basis, in BASES order.
IDEAL_RGB = np.array([[1, 1, 1], [0, 1, 1], [1, 0, 1], [1, 1, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
#: Table range: D in [2^-4, 2^4] (clamped outside), 256 nodes per octave, D = 1 a node.
LOG2_D_MIN, LOG2_D_MAX, NODES_PER_OCTAVE = -4, 4, 256
#: Bound on the table's linear interpolation error, per unit basis weight (absolute, in
#: linear sRGB; measured 1.84e-4 at the midpoints, worst basis magenta, by
#: tests/core/test_doppler_colour.py). A colour's weights sum to its largest component.
INTERPOLATION_ERROR = 2e-4
#: The white spectrum's temperature: D65's correlated colour temperature, K.
WHITE_K = 6504.0


@functools.lru_cache(maxsize=None)
def _colour():
    """The colour-science package, imported without side effects on the process: it warns
    that optional SciPy features are off, and it switches NumPy's printing to its 1.13
    legacy mode (``str`` of a float64 to 12 digits), which is undone."""
    printing = np.get_printoptions()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
        import colour.recovery
    np.set_printoptions(**printing)
    return colour


@functools.lru_cache(maxsize=None)
def cmfs() -> tuple[np.ndarray, np.ndarray]:
    """CIE 1931 2-degree observer: wavelengths (nm, 1 nm steps) and xbar, ybar, zbar (n, 3)."""
    c = _colour().MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    return np.asarray(c.wavelengths, dtype=np.float64), np.asarray(c.values, dtype=np.float64)


@functools.lru_cache(maxsize=None)
def _xyz_to_rgb() -> np.ndarray:
    return np.asarray(_colour().RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB, dtype=np.float64)


def d_nodes() -> np.ndarray:
    """The table's Doppler factors, log2-spaced, D = 1 exactly at index -LOG2_D_MIN * NODES_PER_OCTAVE."""
    return 2.0 ** (np.arange(LOG2_D_MIN * NODES_PER_OCTAVE, LOG2_D_MAX * NODES_PER_OCTAVE + 1) / NODES_PER_OCTAVE)


def _basis(k: int, lam_nm: np.ndarray) -> np.ndarray:
    """Smits basis k at ``lam_nm``: the library's linear interpolation, constant outside 380-720 nm."""
    sd = _colour().recovery.SDS_SMITS1999[BASES[k]]
    return np.interp(lam_nm, np.asarray(sd.wavelengths, dtype=np.float64), np.asarray(sd.values, dtype=np.float64))


def _white(lam_nm: np.ndarray) -> np.ndarray:
    """Planck radiance at WHITE_K, scaled to 1 at 560 nm (the overall scale is normalised away)."""
    planck = _colour().colorimetry.planck_law
    lam = np.asarray(lam_nm, dtype=np.float64)
    return np.reshape(planck(lam.ravel() * 1e-9, WHITE_K), lam.shape) / planck(560e-9, WHITE_K)


def smits_weights(rgb) -> np.ndarray:
    """Smits (1999) basis weights (..., 7) of linear RGB (..., 3); exact: weights @ IDEAL_RGB == rgb."""
    rgb = np.asarray(rgb, dtype=np.float64)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    w = np.zeros(rgb.shape[:-1] + (7,))
    r_min = (r <= g) & (r <= b)
    g_min = ~r_min & (g <= r) & (g <= b)
    b_min = ~r_min & ~g_min
    lo = np.where(r_min, r, np.where(g_min, g, b))
    w[..., 0] = lo
    for mask, sec, x, y, (p1, p2) in ((r_min, 1, g, b, (6, 5)), (g_min, 2, r, b, (6, 4)), (b_min, 3, r, g, (5, 4))):
        # the two non-minimum components x, y: secondary*(min(x, y) - lo) + primary of the larger
        m = np.minimum(x, y)
        w[..., sec] = np.where(mask, m - lo, w[..., sec])
        w[..., p1] += np.where(mask & (x <= y), y - x, 0.0)
        w[..., p2] += np.where(mask & (x > y), x - y, 0.0)
    return w


def smits_spectrum(rgb, lam_nm) -> np.ndarray:
    """Smits reflectance of ``rgb`` (..., 3) at wavelengths ``lam_nm`` (..., n) (broadcast)."""
    w = smits_weights(rgb)
    lam = np.asarray(lam_nm, dtype=np.float64)
    return sum(w[..., k, None] * _basis(k, lam) for k in range(7))


def received_xyz(emitted, d) -> np.ndarray:
    """XYZ of the received spectrum ``D * emitted(lambda * D)``: ``emitted`` maps wavelengths
    (..., n) in nm to radiance; d (...) broadcast; a 1 nm rectangle sum over the CIE table."""
    lam, cmf = cmfs()
    d = np.asarray(d, dtype=np.float64)[..., None]
    return np.einsum("...n,nc->...c", d * emitted(lam * d), cmf)


def _raw_rgb(k: int, d) -> np.ndarray:
    return received_xyz(lambda lam: _basis(k, lam) * _white(lam), d) @ _xyz_to_rgb().T


@functools.lru_cache(maxsize=None)
def _normalisation() -> tuple[np.ndarray, np.ndarray]:
    """(balance (3,), K (7, 7)): normalised responses are ``balance * raw(D) @ K``, exact at D = 1."""
    raw1 = np.stack([_raw_rgb(k, 1.0) for k in range(7)], axis=1)  # (3, 7)
    balance = 1.0 / raw1[:, 0]
    bal1 = balance[:, None] * raw1
    q = bal1[:, 4:7]  # red, green, blue
    k = np.eye(7)
    k[4:7, :] += np.linalg.solve(q, IDEAL_RGB.T - bal1)
    return balance, k


@functools.lru_cache(maxsize=None)
def doppler_table() -> np.ndarray:
    """T (n_D, 7, 3): normalised received linear-sRGB of each basis at each ``d_nodes()`` D."""
    balance, k = _normalisation()
    d = d_nodes()
    raw = np.stack([_raw_rgb(j, d) for j in range(7)], axis=-1)  # (n_D, 3, 7)
    table = np.einsum("c,dcj,jk->dkc", balance, raw, k)
    one = -LOG2_D_MIN * NODES_PER_OCTAVE
    assert np.abs(table[one] - IDEAL_RGB).max() < 1e-9
    table[one] = IDEAL_RGB  # exact in float32 too
    return table


def cached_doppler_table(folder) -> np.ndarray:
    """``doppler_table()`` through a file in ``folder`` (the renderer passes Warp's kernel
    cache): later processes need neither the colour library's import (~0.8 s) nor the
    integration (~0.2 s). The file name carries a hash of this module's source and the
    library's version, so a change of either makes a new file; a missing, unreadable or
    malformed file is computed again and written atomically; an unwritable folder only
    costs the computation."""
    key = hashlib.sha256(Path(__file__).read_bytes() + importlib.metadata.version("colour-science").encode())
    path = Path(folder) / f"doppler_colour_{key.hexdigest()[:16]}.npy"
    n_d = (LOG2_D_MAX - LOG2_D_MIN) * NODES_PER_OCTAVE + 1
    try:
        table = np.load(path)
        if table.shape == (n_d, 7, 3) and table.dtype == np.float64:
            return table
    except (OSError, ValueError, EOFError):
        pass
    table = doppler_table()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
        with open(tmp, "wb") as f:
            np.save(f, table)
        os.replace(tmp, path)
    except OSError:
        pass
    return table


def doppler_transform_np(rgb, d, *, color_shift: bool, searchlight: bool) -> np.ndarray:
    """Float64 twin of the kernel's ``doppler_transform``, integrating directly (no table):
    rgb (..., 3), d (...). D is clamped to the table's range like the kernel; D <= 0 is black."""
    rgb = np.asarray(rgb, dtype=np.float64)
    d = np.asarray(d, dtype=np.float64)
    out = rgb.copy()
    if color_shift:
        balance, k = _normalisation()
        dc = np.clip(d, 2.0**LOG2_D_MIN, 2.0**LOG2_D_MAX)
        w = np.einsum("...j,kj->...k", smits_weights(rgb), k)  # normalised weights: (K w)
        spectrum = lambda lam: _white(lam) * sum(w[..., j, None] * _basis(j, lam) for j in range(7))
        shifted = balance * (received_xyz(spectrum, dc) @ _xyz_to_rgb().T)
        out = np.where((d > 0)[..., None], shifted, 0.0)
    if searchlight:
        out = out * (d**4)[..., None]
    return np.where((d == 1.0)[..., None], rgb, out)
