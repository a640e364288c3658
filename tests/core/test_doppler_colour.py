"""The host side of the Doppler colour shift against the tabulated CIE data and the
colour library's own Smits (1999) upsampling (warp_st/core/doppler_colour.py)."""
import warnings

import numpy as np
import pytest

from warp_st.core import doppler_colour as dc

# colour warns that optional SciPy features are off, and switches NumPy's printing to its
# 1.13 legacy mode: neither is for the rest of the suite.
with warnings.catch_warnings(), np.printoptions():
    warnings.simplefilter("ignore")
    import colour
    from colour.recovery import RGB_to_sd_Smits1999

CIE_1931 = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]


@pytest.mark.parametrize("d", [0.8, 1.0, 1.25])
def test_narrow_band_response_is_the_tabulated_cmf(d):
    """A narrow band of unit power emitted around mu0 = lambda0 * D (a box 1 nm wide in
    received wavelength, height 1/D in emitted wavelength) is received at lambda0 with unit
    power: its XYZ is the library's tabulated CMF at lambda0. Tolerance 1e-12: one product
    and a sum of zeros in float64."""
    for lam0 in range(380, 781, 25):
        def band(mu):
            return np.where(np.abs(mu / d - lam0) < 0.5, 1.0 / d, 0.0)

        np.testing.assert_allclose(dc.received_xyz(band, d), CIE_1931[lam0], rtol=1e-12, atol=1e-15)


def test_smits_spectrum_is_the_library_upsampling():
    """Our Smits weights and basis interpolation equal ``colour.recovery.RGB_to_sd_Smits1999``
    on seeded colours covering all six orderings of R, G, B and ties, on the CMF grid
    (inside and outside the bases' 380-720 nm table). Tolerance 1e-12: float64 mixes of
    O(1) values."""
    rng = np.random.default_rng(3)
    colours = np.vstack([rng.uniform(0, 1, (60, 3)), [[0.5, 0.5, 0.2], [0.3, 0.3, 0.3], [0.1, 0.4, 0.4], [0, 0, 1]]])
    lam, _ = dc.cmfs()
    for rgb in colours:
        np.testing.assert_allclose(dc.smits_spectrum(rgb, lam), RGB_to_sd_Smits1999(rgb)[lam], rtol=1e-12, atol=1e-12)


def test_unit_doppler_is_the_identity_of_the_integration():
    """The twin integrates the normalised spectrum directly; at D = 1 + 1e-12 (past its
    D == 1 shortcut) every colour, in and out of [0, 1], comes back: white stays white.
    Tolerance 1e-9: the shift over 1e-12 in D plus float64 sums of O(1) terms."""
    rgb = np.random.default_rng(4).uniform(-0.5, 3.0, (300, 3))
    out = dc.doppler_transform_np(rgb, np.full(300, 1.0 + 1e-12), color_shift=True, searchlight=False)
    np.testing.assert_allclose(out, rgb, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(dc.doppler_table()[-dc.LOG2_D_MIN * dc.NODES_PER_OCTAVE], dc.IDEAL_RGB)


def test_white_moves_along_the_planckian_locus():
    """A white surface seen with D in [0.7, 1.4] has the chromaticity of a blackbody: its
    xy stays within 0.006 of the Planckian locus (the locus from the library's Planck law
    and the tabulated CMFs, 1 K apart near 6500 K) while it travels ~0.09 along it, and the
    nearest locus temperature is within 5% of 6504 K * D, blue ahead and red behind.
    Why 0.006 and 5%: the spectrum of white is the 6504 K blackbody, exactly Planckian at
    6504 D after the shift, but D = 1 is normalised to sRGB white (D65, itself 0.0044 off
    the locus) by a fixed linear map; measured: 0.0038..0.0053 off, temperatures 1-4% low."""
    lam, cmf = dc.cmfs()
    temps = np.arange(3000.0, 12001.0, 1.0)
    locus = np.stack([colour.colorimetry.planck_law(lam * 1e-9, t) for t in temps]) @ cmf
    locus = locus[:, :2] / locus.sum(axis=1, keepdims=True)
    rgb_to_xyz = colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ
    points = []
    for d in np.linspace(0.7, 1.4, 15):
        xyz = rgb_to_xyz @ dc.doppler_transform_np([1.0, 1.0, 1.0], d, color_shift=True, searchlight=False)
        xy = xyz[:2] / xyz.sum()
        dist = np.linalg.norm(locus - xy, axis=1)
        nearest = dist.argmin()
        assert dist[nearest] < 0.006, (d, dist[nearest])
        assert abs(temps[nearest] / (dc.WHITE_K * d) - 1.0) < 0.05, (d, temps[nearest])
        points.append(xy)
    assert np.linalg.norm(points[0] - points[-1]) > 0.08


def test_cached_table_is_the_computed_one(tmp_path, monkeypatch):
    """The renderer's table file: written on first use, bit-identical to the computation,
    then read without computing (the computation is made to raise), and a damaged file
    (truncated bytes, or an array of another shape) is computed again and replaced."""
    want = dc.doppler_table()
    first = dc.cached_doppler_table(tmp_path)
    np.testing.assert_array_equal(first, want)
    (path,) = tmp_path.glob("doppler_colour_*.npy")

    def no_computing():
        raise AssertionError("the table was computed again")

    with monkeypatch.context() as m:
        m.setattr(dc, "doppler_table", no_computing)
        np.testing.assert_array_equal(dc.cached_doppler_table(tmp_path), want)
    for damage in (path.read_bytes()[:100], None):
        if damage is None:
            np.save(path, np.zeros((3, 7, 3)))
        else:
            path.write_bytes(damage)
        np.testing.assert_array_equal(dc.cached_doppler_table(tmp_path), want)
        np.testing.assert_array_equal(np.load(path), want)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary files left


def test_table_interpolation_is_within_its_stated_bound():
    """Linear interpolation of the table in log2 D, at a quarter, half and three quarters of
    every interval, against the direct integration for each basis: within
    INTERPOLATION_ERROR (the bound other tests' tolerances use), and not loose by more
    than 2x (so the bound means something)."""
    table, log2_d = dc.doppler_table(), np.log2(dc.d_nodes())
    worst = 0.0
    for frac in (0.25, 0.5, 0.75):
        d = 2.0 ** (log2_d[:-1] + frac / dc.NODES_PER_OCTAVE)
        interpolated = (1 - frac) * table[:-1] + frac * table[1:]
        for k in range(7):
            exact = dc.doppler_transform_np(np.broadcast_to(dc.IDEAL_RGB[k], d.shape + (3,)), d, color_shift=True,
                                            searchlight=False)
            worst = max(worst, np.abs(interpolated[:, k] - exact).max())
    assert dc.INTERPOLATION_ERROR / 2 < worst < dc.INTERPOLATION_ERROR


def test_loading_the_colour_library_leaves_numpy_printing_alone():
    """colour-science switches NumPy to its 1.13 printing when imported; ``inspect`` prints
    exact float64 times with ``str``, so the import must not leak (it once did: 12 digits).
    Run in a fresh interpreter: this process may have imported it already."""
    import subprocess
    import sys

    code = ("import numpy as np\nfrom warp_st.core import doppler_colour as dc\ndc.cmfs()\n"
            "print(str(np.float64(5.187856674200006)), np.get_printoptions()['legacy'])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["5.187856674200006", "False"], out
