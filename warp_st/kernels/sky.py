"""The sky (a UsdLux DomeLight, docs/spec.md §3): radiance arriving from a lab direction.

Pure Warp device code. The dome is at rest in the lab at infinity, so a ray that escapes
shows the dome where it points in the lab; a moving camera's aberration comes from its
boosted pixel directions alone. The latlong map follows OpenEXR: a local direction d has
latitude asin(d_y) and longitude atan2(d_x, d_z); column u = (pi - lon) / 2 pi and row
v = (pi/2 - lat) / pi of the image (row 0 at the top), nearest texel. Surfaces get the
dome's diffuse irradiance from nine spherical-harmonic coefficients (``sky_irradiance``).
"""
import functools
import math

import warp as wp

__all__ = ["make_sky"]


@functools.lru_cache(maxsize=None)
def make_sky(scalar):
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    mat33 = wp.types.matrix((3, 3), scalar)
    # Constants folded here: an expression inside a scalar cast is evaluated in float32.
    PI, TWO_PI, HALF_PI = math.pi, 2.0 * math.pi, 0.5 * math.pi

    @wp.struct
    class Sky:
        present: int  # 0: no dome (the background colour is the sky)
        radiance: vec3  # intensity x color x 2^exposure
        local_from_lab: mat33
        width: int  # 0: a constant sky
        height: int
        texel: wp.array(dtype=vec4)  # the latlong map, rows from the top
        irradiance: wp.array(dtype=vec3)  # 9 SH coefficients x A_l (core/sky_irradiance.py), lab axes

    @wp.func
    def sky_radiance(sky: Sky, n: vec3) -> vec3:
        """Radiance of the dome seen looking along the lab direction n."""
        if sky.width == 0:
            return sky.radiance
        d = sky.local_from_lab * n
        lat = wp.asin(wp.clamp(d[1], scalar(-1.0), scalar(1.0)))
        lon = wp.atan2(d[0], d[2])
        u = (scalar(PI) - lon) / scalar(TWO_PI)
        v = (scalar(HALF_PI) - lat) / scalar(PI)
        x = wp.clamp(int(wp.floor(u * scalar(sky.width))), 0, sky.width - 1)
        y = wp.clamp(int(wp.floor(v * scalar(sky.height))), 0, sky.height - 1)
        t = sky.texel[y * sky.width + x]
        return wp.cw_mul(sky.radiance, vec3(t[0], t[1], t[2]))

    @wp.func
    def sky_irradiance(sky: Sky, n: vec3) -> vec3:
        """Diffuse irradiance E(n) of the dome on a surface of unit normal n (no shadowing):
        sum_k C_k Y_k(n) over the nine real spherical harmonics of order <= 2."""
        c = sky.irradiance
        x = n[0]
        y = n[1]
        z = n[2]
        e = c[0] * scalar(0.282094791773878)
        e = e + (c[1] * y + c[2] * z + c[3] * x) * scalar(0.488602511902920)
        e = e + (c[4] * (x * y) + c[5] * (y * z) + c[7] * (x * z)) * scalar(1.092548430592079)
        e = e + c[6] * (scalar(0.315391565252520) * (scalar(3.0) * z * z - scalar(1.0)))
        e = e + c[8] * (scalar(0.546274215296040) * (x * x - y * y))
        return e

    return Sky, sky_radiance, sky_irradiance
