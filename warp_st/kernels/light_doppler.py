"""The Doppler factor of light from a light to the surface point it lights (docs/spec.md §3.5).

Pure Warp device code. The light emits its authored colour in its own rest frame; a surface
point receives it at D_ls = (k·u_surface)/(k·u_light), k the photon's null vector from the
emission event to the hit (spatial direction -l, l the unit vector from the hit towards the
emission point), the signs as the camera side's D = (k·u_cam)/(k·u_point) (§1). With
-k·u = u_t + l·u_x: D_ls = (s_t + l·s_x) / (gamma_l (1 + l·v_l)), s = gamma_u (1, u) for a
coupled surface point and (1, u) for a decoupled one; a light moves with gamma_l (1, v_l),
v_l its velocity at the emission event. With infinite light speed only time dilation
remains: D_ls = s_t / gamma_l. A light and a surface point both at rest give exactly 1.
"""
import functools

import warp as wp

__all__ = ["make_light_doppler"]


@functools.lru_cache(maxsize=None)
def make_light_doppler(scalar):
    vec3 = wp.types.vector(3, scalar)
    # A light animated at >= c (a warning, spec §3.4): 1 - |v|^2 is kept >= this.
    MIN_INV_GAMMA2 = 1.0e-12

    @wp.func
    def incident_doppler(l: vec3, u: vec3, gamma_u: scalar, decoupled: int, v_light: vec3, finite: int) -> scalar:
        """D_ls of the light arriving along -l at a surface point moving with u (its gamma
        ``gamma_u``) from a light point moving with ``v_light`` at its emission event."""
        s_t = gamma_u
        s_x = gamma_u * u
        if decoupled != 0:
            s_t = scalar(1.0)
            s_x = u
        gamma_l = scalar(1.0) / wp.sqrt(wp.max(scalar(1.0) - wp.dot(v_light, v_light), scalar(MIN_INV_GAMMA2)))
        if finite == 0:
            return s_t / gamma_l
        return (s_t + wp.dot(l, s_x)) / (gamma_l * (scalar(1.0) + wp.dot(l, v_light)))

    return incident_doppler
