"""Doppler colour shift and searchlight (Weiskopf–Kraus–Ruder radiance transform).

Pure Warp device code. The colour shift reads a table made on the host from the CIE 1931
colour matching functions and Smits (1999) spectral upsampling (core/doppler_colour.py):
row ``i * 7 + k`` is the received linear sRGB of basis spectrum k (white, cyan, magenta,
yellow, red, green, blue) at D = 2^(LOG2_D_MIN + i / NODES_PER_OCTAVE). A colour is the
Smits mix of three bases chosen by the ordering of its components; the kernel interpolates
their rows linearly in log2 D (D clamped to the table's range) and mixes them. The table
is exactly the ideal RGB at D = 1, so D = 1 is the identity.

The searchlight scales radiance by D^4: specific intensity I_nu / nu^3 is invariant,
so the frequency-integrated radiance transforms as D^4 (Weiskopf, Kraus & Ruder 1999).
"""
import functools

import warp as wp

from warp_st.core.doppler_colour import LOG2_D_MAX, LOG2_D_MIN, NODES_PER_OCTAVE

__all__ = ["make_spectrum"]


@functools.lru_cache(maxsize=None)
def make_spectrum(scalar, vec3):
    LO, PER = float(LOG2_D_MIN), float(NODES_PER_OCTAVE)
    # the last node's index, as a float (the clamp) and the last interval's (an int): one
    # closure constant used as both types trips Warp 1.19's float64 codegen
    U_MAX = float((LOG2_D_MAX - LOG2_D_MIN) * NODES_PER_OCTAVE)
    I_MAX = (LOG2_D_MAX - LOG2_D_MIN) * NODES_PER_OCTAVE - 1

    @wp.func
    def basis_rgb(table: wp.array(dtype=vec3), i: int, f: scalar, k: int) -> vec3:
        a = table[i * 7 + k]
        return a + f * (table[i * 7 + 7 + k] - a)

    @wp.func
    def doppler_transform(
        rgb: vec3, d: scalar, table: wp.array(dtype=vec3), color_shift: int, searchlight: int
    ) -> vec3:
        """Radiance seen through Doppler factor d (received / emitted frequency)."""
        if d == scalar(1.0) or (color_shift == 0 and searchlight == 0):
            return rgb
        out = rgb
        if color_shift != 0:
            if d > scalar(0.0):
                u = wp.clamp((wp.log2(d) - scalar(LO)) * scalar(PER), scalar(0.0), scalar(U_MAX))
                i = wp.min(int(wp.floor(u)), I_MAX)
                f = u - scalar(i)
                r, g, b = rgb[0], rgb[1], rgb[2]
                # Smits (1999): white * min + secondary * (mid - min) + primary * (max - mid),
                # the secondary the complement of the smallest component (cyan, magenta,
                # yellow), the primary the largest one's (red, green, blue). At a tie the
                # choice does not matter: its weight is 0.
                lo = wp.min(r, wp.min(g, b))
                hi = wp.max(r, wp.max(g, b))
                mid = wp.max(wp.min(r, g), wp.min(wp.max(r, g), b))
                sec = int(3)
                if r == lo:
                    sec = 1
                elif g == lo:
                    sec = 2
                prim = int(6)
                if r == hi:
                    prim = 4
                elif g == hi:
                    prim = 5
                out = (
                    lo * basis_rgb(table, i, f, 0)
                    + (mid - lo) * basis_rgb(table, i, f, sec)
                    + (hi - mid) * basis_rgb(table, i, f, prim)
                )
            else:
                out = vec3(scalar(0.0))
        if searchlight != 0:
            d2 = d * d
            out = out * (d2 * d2)
        return out

    return doppler_transform
