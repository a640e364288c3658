"""The per-pixel megakernel: camera ray on the past lightcone, closest hit, shading, AOVs.

Pure Warp device code; the host (``warp_st.renderer``) fills the structs. All events are
relative to the render origin (the camera event), so large absolute times cost nothing.
"""

import functools

import warp as wp

from .probe import make_probe
from .trace import make_trace

__all__ = ["get_kernels", "Kernels"]


class Kernels:
    """The compiled device types and kernels for one scalar type."""

    def __init__(self, scalar):
        self.scalar = scalar
        self.vec3 = wp.types.vector(3, scalar)
        self.vec4 = wp.types.vector(4, scalar)
        self.mat33 = wp.types.matrix((3, 3), scalar)
        Geometry, trace, hit_tet, basis = make_trace(scalar)
        self.Geometry = Geometry
        self.Shading, self.Camera, self.Film, self.render_pixels = _make_render(scalar, self, trace, Geometry)
        self._probe_parts = (scalar, self.vec3, self.vec4, Geometry, trace, hit_tet, basis)
        self._probe = None

    @property
    def cast_rays(self):
        """Kernel: closest hit of arbitrary null rays through the BVH (tests, benchmarks)."""
        return self._probes()[0]

    @property
    def brute_rays(self):
        """Kernel: closest hit of arbitrary null rays over every tetrahedron (the oracle)."""
        return self._probes()[1]

    def _probes(self):
        if self._probe is None:  # built on first use: renders never compile them
            self._probe = make_probe(*self._probe_parts)
        return self._probe


def _make_render(scalar, k, trace, Geometry):
    vec3, vec4, mat33 = k.vec3, k.vec4, k.mat33
    # Secondary rays start this far (relative to the hit's lookback) from the hit
    # event: in float32 1e-4 is ~1000 ulps, far above the rounding of the hit.
    SELF_EPS = 1.0e-4 if wp.types.type_size_in_bytes(scalar) == 4 else 1.0e-9
    FAR = 1.0e30

    @wp.struct
    class Shading:
        vert_normal: wp.array(dtype=vec3)
        tri_normal: wp.array(dtype=vec3)
        tri_smooth: wp.array(dtype=wp.int32)
        tri_size: wp.array(dtype=scalar)
        tri_body: wp.array(dtype=wp.int32)
        tri_material: wp.array(dtype=wp.int32)
        mat_diffuse: wp.array(dtype=vec3)
        mat_emissive: wp.array(dtype=vec3)
        body_origin: wp.array(dtype=vec4)  # (t_ref, o) relative to the render origin
        body_velocity: wp.array(dtype=vec3)
        body_gamma: wp.array(dtype=scalar)
        body_decoupled: wp.array(dtype=wp.int32)
        light_kind: wp.array(dtype=wp.int32)  # 0 sphere (point), 1 distant
        light_pos: wp.array(dtype=vec3)
        light_dir: wp.array(dtype=vec3)
        light_radiance: wp.array(dtype=vec3)
        light_count: int
        background: vec3

    @wp.struct
    class Camera:
        lab_from_camera: mat33
        focal: scalar
        h_ap: scalar
        v_ap: scalar
        h_off: scalar
        v_off: scalar
        width: int
        height: int
        velocity: vec3
        gamma: scalar
        moving: int
        decoupled: int
        finite: int

    @wp.struct
    class Film:
        rgba: wp.array(dtype=vec4)
        depth: wp.array(dtype=scalar)
        event_time: wp.array(dtype=scalar)
        proper_time: wp.array(dtype=scalar)
        doppler: wp.array(dtype=scalar)
        object_id: wp.array(dtype=wp.int32)
        visits: wp.array(dtype=wp.int32)
        overflow: wp.array(dtype=wp.int32)

    @wp.func
    def aberrate(n_rest: vec3, v: vec3, gamma: scalar, decoupled: int) -> vec3:
        """Camera rest-frame look direction -> lab look direction (SPEC §3).

        Relativistic: boost the arriving photon k' = (1, -n') to the lab, n = -k_x/k_t.
        Classical (Galilean): n + v is parallel to n' with |n| = 1.
        """
        vv = wp.dot(v, v)
        if vv == scalar(0.0):
            return n_rest
        if decoupled != 0:
            nv = wp.dot(n_rest, v)
            lam = nv + wp.sqrt(nv * nv - vv + scalar(1.0))
            return wp.normalize(lam * n_rest - v)
        nv = wp.dot(n_rest, v)
        kx = n_rest + ((gamma - scalar(1.0)) / vv) * nv * v - gamma * v
        return wp.normalize(kx / (gamma * (scalar(1.0) - nv)))

    @wp.func
    def rest_distance(cam: Camera, dt: scalar, dx: vec3) -> scalar:
        """|spatial part| of the camera-to-event separation in the camera's rest frame."""
        if cam.moving == 0:
            return wp.length(dx)
        v = cam.velocity
        if cam.decoupled != 0:
            return wp.length(dx - v * dt)
        vv = wp.dot(v, v)
        return wp.length(dx + ((cam.gamma - scalar(1.0)) / vv) * wp.dot(v, dx) * v - cam.gamma * dt * v)

    @wp.func
    def camera_direction(cam: Camera, px: scalar, py: scalar) -> vec3:
        """Pinhole look direction in the lab for film position (px, py) in pixels."""
        x_ndc = (px / scalar(cam.width)) * scalar(2.0) - scalar(1.0)
        y_ndc = scalar(1.0) - (py / scalar(cam.height)) * scalar(2.0)
        d_cam = vec3(
            (x_ndc * cam.h_ap * scalar(0.5) + cam.h_off) / cam.focal,
            (y_ndc * cam.v_ap * scalar(0.5) + cam.v_off) / cam.focal,
            scalar(-1.0),
        )
        n_rest = wp.normalize(cam.lab_from_camera * d_cam)
        if cam.moving != 0:
            return aberrate(n_rest, cam.velocity, cam.gamma, cam.decoupled)
        return n_rest

    @wp.func
    def four_velocity(v: vec3, gamma: scalar, decoupled: int) -> vec4:
        if decoupled != 0:
            return vec4(scalar(1.0), v[0], v[1], v[2])
        return vec4(gamma, gamma * v[0], gamma * v[1], gamma * v[2])

    @wp.func
    def shade(geo: Geometry, shd: Shading, cam: Camera, tet: int, s: scalar, lam: vec4, event: vec4, n: vec3):
        """Lambert from lights at rest with null-ray shadow tests; unlit albedo without lights."""
        tri = geo.tet_tri[tet]
        mat = shd.tri_material[tri]
        body = shd.tri_body[tri]
        diffuse = shd.mat_diffuse[mat]
        color = shd.mat_emissive[mat]
        if shd.light_count == 0:
            return color + diffuse
        normal = shd.tri_normal[tri]
        if shd.tri_smooth[tri] != 0:
            idx = geo.tet[tet]
            sm = (
                lam[0] * shd.vert_normal[idx[0]]
                + lam[1] * shd.vert_normal[idx[1]]
                + lam[2] * shd.vert_normal[idx[2]]
                + lam[3] * shd.vert_normal[idx[3]]
            )
            if wp.length(sm) > scalar(0.0):
                normal = wp.normalize(sm)
        # Two-sided: use the side the light to the camera leaves from. Relative to a
        # surface moving with v the photon (spatial direction -n) moves as -(n + v).
        v = shd.body_velocity[body]
        if wp.dot(normal, n + v) > scalar(0.0):
            normal = -normal
        x = vec3(event[1], event[2], event[3])
        s_min = scalar(SELF_EPS) * (scalar(1.0) + wp.abs(s))
        # A smooth-shaded facet near the terminator would shadow itself on its
        # neighbours (the facet normal is not the shading normal): ignore its own
        # body within two facet sizes. Real self-shadowing of a moving body needs
        # it to move by its size, far beyond that.
        skip_dist = scalar(0.0)
        if shd.tri_smooth[tri] != 0:
            skip_dist = scalar(2.0) * shd.tri_size[tri]
        for li in range(shd.light_count):
            l = shd.light_dir[li]
            dist = scalar(FAR)
            atten = scalar(1.0)
            if shd.light_kind[li] == 0:
                to_light = shd.light_pos[li] - x
                dist = wp.length(to_light)
                l = to_light / dist
                atten = scalar(1.0) / (dist * dist)
                dist = dist * (scalar(1.0) - scalar(SELF_EPS))
            cos_l = wp.dot(normal, l)
            if cos_l > scalar(0.0):
                blocker, _bs, _bl, _bv, _bo = trace(geo, event, l, cam.finite, s_min, dist, tri, body, skip_dist, 1)
                if blocker < 0:
                    color = color + wp.cw_mul(diffuse, shd.light_radiance[li]) * (cos_l * atten)
        return color

    @wp.kernel(enable_backward=False, module="unique")
    def render_pixels(geo: Geometry, shd: Shading, cam: Camera, film: Film, offset: int):
        pixel = wp.tid() + offset
        px = pixel % cam.width
        py = pixel / cam.width
        n = camera_direction(cam, scalar(px) + scalar(0.5), scalar(py) + scalar(0.5))
        origin = vec4(scalar(0.0))
        tet, s, lam, visits, overflow = trace(geo, origin, n, cam.finite, scalar(0.0), scalar(FAR), -1, -1, scalar(0.0), 0)
        film.visits[pixel] = visits
        if overflow != 0:
            film.overflow[0] = 1
        if tet < 0:
            bg = shd.background
            film.rgba[pixel] = vec4(bg[0], bg[1], bg[2], scalar(0.0))
            film.depth[pixel] = scalar(wp.inf)
            film.event_time[pixel] = scalar(wp.nan)
            film.proper_time[pixel] = scalar(wp.nan)
            film.doppler[pixel] = scalar(wp.nan)
            film.object_id[pixel] = 0
            return
        dt = scalar(0.0)
        if cam.finite != 0:
            dt = -s
        event = vec4(dt, s * n[0], s * n[1], s * n[2])
        color = shade(geo, shd, cam, tet, s, lam, event, n)
        film.rgba[pixel] = vec4(color[0], color[1], color[2], scalar(1.0))
        film.depth[pixel] = rest_distance(cam, dt, vec3(event[1], event[2], event[3]))
        film.event_time[pixel] = event[0]

        body = shd.tri_body[geo.tet_tri[tet]]
        bo = shd.body_origin[body]
        v = shd.body_velocity[body]
        dec = shd.body_decoupled[body]
        rel_t = event[0] - bo[0]
        tau = rel_t
        if dec == 0:
            rel_x = vec3(event[1] - bo[1], event[2] - bo[2], event[3] - bo[3])
            tau = shd.body_gamma[body] * (rel_t - wp.dot(v, rel_x))
        film.proper_time[pixel] = tau

        # D = (k.u_cam)/(k.u_body), k = (1, -n): -k.u = u_t + n.u_x. With infinite
        # light speed only time dilation is left: the limit is u_cam_t / u_body_t.
        ub = four_velocity(v, shd.body_gamma[body], dec)
        uc = four_velocity(cam.velocity, cam.gamma, cam.decoupled)
        dop = uc[0] / ub[0]
        if cam.finite != 0:
            dop = (uc[0] + n[0] * uc[1] + n[1] * uc[2] + n[2] * uc[3]) / (
                ub[0] + n[0] * ub[1] + n[1] * ub[2] + n[2] * ub[3]
            )
        film.doppler[pixel] = dop
        film.object_id[pixel] = body + 1

    return Shading, Camera, Film, render_pixels


@functools.lru_cache(maxsize=None)
def get_kernels(precision: str) -> Kernels:
    """Kernels for ``"float32"`` or ``"float64"``, built once per process."""
    scalar = {"float32": wp.float32, "float64": wp.float64}[precision]
    return Kernels(scalar)
