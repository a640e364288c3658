"""Doppler colour shift and searchlight (Weiskopf–Kraus–Ruder radiance transform).

Pure Warp device code. An RGB colour is read as three spectral lines at the sRGB
primaries' dominant wavelengths; a Doppler factor D moves each line to lambda / D and
the result is re-expressed in RGB through the CIE 1931 colour matching functions
(Wyman, Sloan & Shirley 2013 multi-lobe fit) and the XYZ -> linear sRGB matrix. The
basis is normalised so that D = 1 is exactly the identity; lines shifted out of the
visible band fade to black, as they should.

The searchlight scales radiance by D^4: specific intensity I_nu / nu^3 is invariant,
so the frequency-integrated radiance transforms as D^4 (Weiskopf, Kraus & Ruder 1999).
"""
import numpy as np
import warp as wp

__all__ = ["PRIMARY_NM", "cmf_rgb_np", "spectral_basis_inverse", "make_spectrum", "doppler_transform_np"]

#: Dominant wavelengths of the sRGB primaries, nm.
PRIMARY_NM = (611.3, 549.1, 464.3)

_XYZ_TO_SRGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)


def _lobe(lam, mu, s1, s2):
    s = np.where(lam < mu, s1, s2)
    return np.exp(-0.5 * ((lam - mu) / s) ** 2)


def cmf_rgb_np(lam_nm) -> np.ndarray:
    """Linear sRGB response of a unit spectral line at ``lam_nm`` (float64 twin), (..., 3)."""
    lam = np.asarray(lam_nm, dtype=np.float64)
    x = 1.056 * _lobe(lam, 599.8, 37.9, 31.0) + 0.362 * _lobe(lam, 442.0, 16.0, 26.7) - 0.065 * _lobe(lam, 501.1, 20.4, 26.2)
    y = 0.821 * _lobe(lam, 568.8, 46.9, 40.5) + 0.286 * _lobe(lam, 530.9, 16.3, 31.1)
    z = 1.217 * _lobe(lam, 437.0, 11.8, 36.0) + 0.681 * _lobe(lam, 459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1) @ _XYZ_TO_SRGB.T


def spectral_basis_inverse() -> np.ndarray:
    """A = inverse of the matrix whose columns are the lines' RGB responses: A M(lambda_c) = e_c."""
    return np.linalg.inv(np.stack([cmf_rgb_np(l) for l in PRIMARY_NM], axis=1))


def make_spectrum(scalar, vec3, mat33):
    LAM_R, LAM_G, LAM_B = (float(x) for x in PRIMARY_NM)
    @wp.func
    def lobe(lam: scalar, mu: scalar, s1: scalar, s2: scalar) -> scalar:
        s = s2
        if lam < mu:
            s = s1
        t = (lam - mu) / s
        return wp.exp(scalar(-0.5) * t * t)

    @wp.func
    def line_rgb(lam: scalar) -> vec3:
        x = (
            scalar(1.056) * lobe(lam, scalar(599.8), scalar(37.9), scalar(31.0))
            + scalar(0.362) * lobe(lam, scalar(442.0), scalar(16.0), scalar(26.7))
            - scalar(0.065) * lobe(lam, scalar(501.1), scalar(20.4), scalar(26.2))
        )
        y = scalar(0.821) * lobe(lam, scalar(568.8), scalar(46.9), scalar(40.5)) + scalar(0.286) * lobe(
            lam, scalar(530.9), scalar(16.3), scalar(31.1)
        )
        z = scalar(1.217) * lobe(lam, scalar(437.0), scalar(11.8), scalar(36.0)) + scalar(0.681) * lobe(
            lam, scalar(459.0), scalar(26.0), scalar(13.8)
        )
        return vec3(
            scalar(3.2406) * x - scalar(1.5372) * y - scalar(0.4986) * z,
            scalar(-0.9689) * x + scalar(1.8758) * y + scalar(0.0415) * z,
            scalar(0.0557) * x - scalar(0.2040) * y + scalar(1.0570) * z,
        )

    @wp.func
    def doppler_transform(rgb: vec3, d: scalar, basis_inv: mat33, color_shift: int, searchlight: int) -> vec3:
        """Radiance seen through Doppler factor d (received / emitted frequency)."""
        if d == scalar(1.0) or (color_shift == 0 and searchlight == 0):
            return rgb
        out = rgb
        if color_shift != 0:
            if d > scalar(0.0):
                mixed = (
                    rgb[0] * line_rgb(scalar(LAM_R) / d)
                    + rgb[1] * line_rgb(scalar(LAM_G) / d)
                    + rgb[2] * line_rgb(scalar(LAM_B) / d)
                )
                out = basis_inv * mixed
            else:
                out = vec3(scalar(0.0))
        if searchlight != 0:
            d2 = d * d
            out = out * (d2 * d2)
        return out

    return doppler_transform


def doppler_transform_np(rgb, d, *, color_shift: bool, searchlight: bool) -> np.ndarray:
    """Float64 twin of the kernel's ``doppler_transform``: rgb (..., 3), d (...)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    d = np.asarray(d, dtype=np.float64)
    out = rgb.copy()
    if color_shift:
        lines = np.stack([cmf_rgb_np(np.float64(l) / np.maximum(d, 1e-300)) for l in PRIMARY_NM], axis=-2)  # (..., 3, 3)
        mixed = np.einsum("...c,...cj->...j", rgb, lines)
        out = np.where((d > 0)[..., None], mixed @ spectral_basis_inverse().T, 0.0)
    if searchlight:
        out = out * (d**4)[..., None]
    return np.where((d == 1.0)[..., None], rgb, out)
