"""The per-pixel megakernel: camera ray on the past lightcone, closest hit, shading, AOVs.

Pure Warp device code; the host (``warp_st.rendering.renderer``) fills the structs. All events are
relative to the render origin (the geometry's anchor, a grid point near the camera event:
``rendering/anchor.py``; the camera event is ``Camera.origin`` from it), so large absolute
times cost nothing; the film's times are relative to the camera event.
"""

import functools

import warp as wp

from warp_st.kernels.layout import ANALYTIC_TEST, PRIMITIVES
from warp_st.kernels.prim_lookup import make_prim_lookup
from warp_st.kernels.probe import make_probe
from warp_st.kernels.shade import make_shade
from warp_st.kernels.sky import make_sky
from warp_st.kernels.spectrum import make_spectrum
from warp_st.kernels.texture import make_textures
from warp_st.kernels.trace import make_trace
from warp_st.kernels.trace_rigid import make_trace_rigid
from warp_st.kernels.traverse import STACK_SIZE, make_traverse

__all__ = ["get_kernels", "Kernels", "PIXELS_PER_THREAD"]

#: Pixels one kernel thread renders in turn (``render_pixels``).
PIXELS_PER_THREAD = 64




class Kernels:
    """The compiled device types and kernels for one scalar type and primitive kind
    (``tets``: the rigid path with deforming bodies' tetrahedra, ``trace_rigid``; ``stack``:
    the rigid top level's traversal stack, ``traverse.stack_for``)."""

    def __init__(self, scalar, primitive: str = "prism", tets: bool = False, stack: int = STACK_SIZE):
        self.scalar = scalar
        self.primitive = primitive
        self.stack = stack
        self.vec3 = wp.types.vector(3, scalar)
        self.vec4 = wp.types.vector(4, scalar)
        self.vec16 = wp.types.vector(16, scalar)  # box corners of a wide node's four children
        if primitive == "rigid":
            Geometry, trace, prepare, leaf = make_trace_rigid(scalar, tets, stack)
        else:
            Geometry, trace, prepare, leaf = make_trace(scalar, primitive)
        self.Geometry = Geometry
        self.Shading, self.Camera, self.Film, self.render_pixels, self._make_unlit, self._make_camera_rays = (
            _make_render(scalar, self, trace, Geometry))
        self._unlit = None
        self._camera_rays = None
        self._probe_parts = (scalar, self.vec3, self.vec4, Geometry, prepare, leaf)
        self._probe = None

    def pixels(self, lit: bool):
        """The pixel kernel: ``render_pixels`` for a scene with lights, else its twin without
        shadow rays (built on first use; the same pixels where no light is)."""
        if lit:
            return self.render_pixels
        if self._unlit is None:
            self._unlit = self._make_unlit()
        return self._unlit

    @property
    def camera_rays(self):
        """Kernel: the lab direction of every pixel centre's ray (the Camera's ``dirs``)."""
        if self._camera_rays is None:
            self._camera_rays = self._make_camera_rays()
        return self._camera_rays

    @property
    def cast_rays(self):
        """Kernel: closest hit of arbitrary null rays through the BVH (tests, benchmarks)."""
        return self._probes()[0]

    @property
    def brute_rays(self):
        """Kernel: closest hit of arbitrary null rays over every primitive (prism,
        tetrahedron or motion segment), no BVH (the oracle of the traversal)."""
        return self._probes()[1]

    def _probes(self):
        if self._probe is None:  # built on first use: renders never compile them
            scalar, vec3, vec4, Geometry, prepare, leaf = self._probe_parts
            # The probe's traversal inlined into its kernel, as wp.mesh_query_ray is into a
            # caller's: its constant arguments (no skips, closest hit) fold those branches.
            trace = make_traverse(scalar, Geometry, prepare, leaf, inline=True, stack_size=self.stack)
            self._probe = make_probe(scalar, vec3, vec4, Geometry, trace, prepare, leaf)
        return self._probe


def _make_render(scalar, k, trace, Geometry):
    vec3, vec4 = k.vec3, k.vec4
    FAR = 1.0e30
    INV_PI = 0.3183098861837907  # 1/pi (a cast of an expression would be evaluated in float32)
    Shading, self_eps, shading_normal, shade, reflect_null, point_velocity = make_shade(scalar, vec3, vec4, Geometry, trace)
    doppler_transform = make_spectrum(scalar, vec3)
    _textures, surface_inputs = make_textures(scalar)
    _sky, sky_radiance, sky_irradiance = make_sky(scalar)
    prim_triangle, prim_vertices = make_prim_lookup(Geometry)

    @wp.struct
    class Camera:
        # The pinhole in float64 (``camera_direction``): a float32 lens would turn every
        # ray by ~1e-7, which near a silhouette moves the hit's lookback by 1e-5.
        lab_from_camera: wp.mat33d
        focal: wp.float64
        h_ap: wp.float64
        v_ap: wp.float64
        h_off: wp.float64
        v_off: wp.float64
        width: int
        height: int
        velocity: vec3
        gamma: scalar
        # The camera event relative to the geometry's anchor (rendering/anchor.py): the rays'
        # origin; the film's times stay relative to the camera event.
        origin: vec4
        moving: int
        decoupled: int
        finite: int
        samples: int
        strata: int
        shutter: scalar
        seed: int
        # Film coordinates of the pixel centres' rays, (x_ndc h_ap / 2 + h_off) / focal per
        # column and (y_ndc v_ap / 2 + v_off) / focal per row (``pixel_direction``).
        col: wp.array(dtype=wp.float64)
        row: wp.array(dtype=wp.float64)
        # The lab direction of every pixel centre's ray (``pixel_direction``, row by row):
        # the AOV rays' table, made once per lens by ``camera_rays`` (rendering/camera.py);
        # empty: the kernel computes them (``centre_direction``).
        dirs: wp.array(dtype=vec3)

    @wp.struct
    class Film:
        rgba: wp.array(dtype=vec4)
        depth: wp.array(dtype=scalar)
        event_time: wp.array(dtype=scalar)
        proper_time: wp.array(dtype=scalar)
        doppler: wp.array(dtype=scalar)
        object_id: wp.array(dtype=wp.int32)
        source_time: wp.array(dtype=scalar)
        bounces: wp.array(dtype=wp.int32)
        sample_id: wp.array(dtype=wp.int32)  # Cryptomatte: 1 + the triangle each sample hits first, 0: none; empty: off
        visits: wp.array(dtype=wp.int32)  # node visits per kernel thread (its PIXELS_PER_THREAD pixels), not per pixel
        covered: wp.array(dtype=wp.int32)  # per kernel thread: its pixels whose AOV ray hit (object id > 0)
        overflow: wp.array(dtype=wp.int32)
        # The Image's own time planes (float64 time codes, absolute), written instead of
        # event_time / source_time when not empty: ``time_code`` of the relative lab times.
        event_code: wp.array(dtype=wp.float64)
        source_code: wp.array(dtype=wp.float64)
        code_origin: wp.float64  # the camera's time code
        per_code: wp.float64  # lab time per time code (the light speed, docs/spec.md §3.1)

    @wp.func
    def time_code(rel: scalar, origin: wp.float64, per_code: wp.float64) -> wp.float64:
        """A relative lab time as the Image stores it: in time codes, absolute, quantised as
        the EXR stores it (output/film.quantize_relative's float64 operations, in its order)."""
        r = wp.float64(rel)
        if per_code != wp.float64(1.0):
            r = r / per_code
        return wp.float64(wp.float32((r + origin) - origin)) + origin

    @wp.func
    def aberrate(n_rest: vec3, v: vec3, gamma: scalar, decoupled: int) -> vec3:
        """Camera rest-frame look direction -> lab look direction (docs/spec.md §3).

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
    def lens_direction(cam: Camera, d_cam: wp.vec3d) -> vec3:
        """The lab look direction of camera-frame direction ``d_cam`` (float64, rounded
        once to ``scalar`` before the aberration)."""
        d = wp.normalize(cam.lab_from_camera * d_cam)
        n_rest = vec3(scalar(d[0]), scalar(d[1]), scalar(d[2]))
        if cam.moving != 0:
            return aberrate(n_rest, cam.velocity, cam.gamma, cam.decoupled)
        return n_rest

    @wp.func
    def camera_direction(cam: Camera, px: scalar, py: scalar) -> vec3:
        """Pinhole look direction in the lab for film position (px, py) in pixels: in
        float64, rounded once to ``scalar`` before the aberration."""
        one = wp.float64(1.0)
        half = wp.float64(0.5)
        x_ndc = (wp.float64(px) / wp.float64(cam.width)) * wp.float64(2.0) - one
        y_ndc = one - (wp.float64(py) / wp.float64(cam.height)) * wp.float64(2.0)
        d_cam = wp.vec3d((x_ndc * cam.h_ap * half + cam.h_off) / cam.focal,
                         (y_ndc * cam.v_ap * half + cam.v_off) / cam.focal, -one)
        return lens_direction(cam, d_cam)

    @wp.func
    def pixel_direction(cam: Camera, px: int, py: int) -> vec3:
        """``camera_direction`` at pixel (px, py)'s centre, its film coordinates from the
        host's tables (the same float64 operations, so the same bits: no divisions here)."""
        return lens_direction(cam, wp.vec3d(cam.col[px], cam.row[py], wp.float64(-1.0)))

    @wp.func
    def centre_direction(cam: Camera, pixel: int) -> vec3:
        """``pixel_direction`` of ``pixel`` (row by row): the lens's table when it has one
        (``camera_rays``, made before the launch), else the float64 pinhole here."""
        if cam.dirs.shape[0] > 0:
            return cam.dirs[pixel]
        return pixel_direction(cam, pixel % cam.width, pixel / cam.width)

    @wp.func
    def four_velocity(v: vec3, gamma: scalar, decoupled: int) -> vec4:
        # (1, v) decoupled, gamma (1, v) coupled; one select, not a vector built in two
        # branches (the compiler stores such a vector through memory and the 8-byte
        # load after its 4-byte stores stalls).
        g = wp.where(decoupled != 0, scalar(1.0), gamma)
        return vec4(g, g * v[0], g * v[1], g * v[2])

    @wp.func
    def null_dir(n: vec3, finite: int) -> vec4:
        return vec4(wp.where(finite != 0, scalar(-1.0), scalar(0.0)), n[0], n[1], n[2])

    @wp.func
    def sample_ray(cam: Camera, px: int, py: int, k: int, pixel: int):
        """Sample k of a pixel: stratified jitter in the pixel and in camera time.

        Returns the ray origin, the camera event moved by (tau, v_cam tau), relative to the anchor, and
        the lab direction. Seeded per (pixel, sample): reproducible bit for bit.
        """
        state = wp.rand_init(cam.seed, pixel * cam.samples + k)
        sx = (scalar(k % cam.strata) + scalar(wp.randf(state))) / scalar(cam.strata)
        sy = (scalar((k / cam.strata) % cam.strata) + scalar(wp.randf(state))) / scalar(cam.strata)
        # Time strata in a scrambled order so time and position decorrelate.
        kt = (k * 7919 + 3) % cam.samples
        tau = (scalar(kt) + scalar(wp.randf(state))) / scalar(cam.samples) * cam.shutter
        n = camera_direction(cam, scalar(px) + sx, scalar(py) + sy)
        o = vec4(tau, tau * cam.velocity[0], tau * cam.velocity[1], tau * cam.velocity[2])
        return cam.origin + o, n

    @wp.func
    def no_lights(geo: Geometry, shd: Shading, finite: int, prim: int, path: scalar, event: vec4, normal: vec3,
                  diffuse: vec3, emissive: vec3, u: vec3, gamma_u: scalar) -> vec3:
        """What ``shade`` returns without lights: the unlit kernel's stand-in, which casts no shadow rays."""
        return emissive + diffuse

    def make_pixels(shade_hit, name=None):
        """The pixel kernel shading lit hits with ``shade_hit``: ``shade``, or for scenes
        without lights ``no_lights`` (the kernel never calls it there). Without ``shade`` the
        kernel calls ``trace`` from one site, so the compiler inlines it and no ray copies the
        Geometry struct (Warp passes structs by value): the same pixels, ~15 % faster.
        ``trace_path``, ``shade`` and ``sphere_visibility`` are inlined by force (each has one
        call site): left to the compiler, the first two became out-of-line calls taking the
        Geometry and Shading structs by value, ~5 KB copied per ray (docs/design/two-level.md,
        "The lit kernel's struct copies")."""

        @wp.func(inline=True)
        def trace_path(geo: Geometry, shd: Shading, cam: Camera, origin: vec4, n0: vec3):
            """Radiance along one camera ray with mirror bounces (a loop: kernels cannot recurse).

            A surface shows (1 - metallic) x its own shading + metallic x diffuseColor x the
            radiance arriving along the reflected null ray (docs/spec.md §2; issue: light transport),
            for at most ``max_depth`` reflections. Returns (colour, alpha, first prim, its
            lookback s, barycentrics, source event time, bounces before it, visits,
            overflow). The source is the last hit that is not a perfect mirror, or the
            hit where the path ends; NaN when only mirrors led to the background.

            With Doppler colour / searchlight on, each contribution is transformed by its
            own D = (k.u_cam)/(k.u_source): k is followed through every reflection, whose
            moving mirror changes the photon's lab energy by (1 + f N.v) (see reflect_null).
            """
            finite = cam.finite
            uc = four_velocity(cam.velocity, cam.gamma, cam.decoupled)
            cam_term = uc[0]
            if finite != 0:
                cam_term = uc[0] + n0[0] * uc[1] + n0[1] * uc[2] + n0[2] * uc[3]
            energy = scalar(1.0)  # photon lab energy at the current segment / at the camera
            color = vec3(scalar(0.0))
            weight = vec3(scalar(1.0))
            o = origin
            n = n0
            skip = int(-1)
            path = scalar(0.0)
            first_prim = int(-1)
            first_s = scalar(0.0)
            first_lam = vec4(scalar(0.0))
            first_u = vec3(scalar(0.0))
            first_gamma = scalar(1.0)
            source_t = scalar(wp.nan)
            source_bounces = int(0)
            bounces = int(0)
            visits = int(0)
            overflow = int(0)
            depth = int(0)
            while depth <= shd.max_depth:
                prim, s, lam, vis, ovf = trace(geo.ref, o, n, finite, self_eps(path), scalar(FAR), skip, -1, scalar(0.0), 0)
                visits += vis
                overflow = wp.max(overflow, ovf)
                if prim < 0:
                    # The dome (at rest in the lab, D = cam_term / energy) is seen by every
                    # escaping ray; without one the background only after a mirror (the film
                    # composites it behind primary misses).
                    if depth > 0 or shd.sky.present != 0:
                        bg = shd.background
                        if shd.sky.present != 0:
                            bg = sky_radiance(shd.sky, n)
                        bg = doppler_transform(bg, cam_term / energy, shd.doppler_table, shd.color_shift, shd.searchlight)
                        color = color + wp.cw_mul(weight, bg)
                    break
                event = o + s * null_dir(n, finite)
                path = path + s
                if depth == 0:
                    first_prim = prim
                    first_s = s
                    first_lam = lam
                tri = prim_triangle(geo, prim)
                mat = shd.tri_material[tri]
                diffuse, emissive, metal = surface_inputs(shd.tex, prim, tri, lam, mat, shd.mat_diffuse[mat],
                                                          shd.mat_emissive[mat], shd.mat_metallic[mat])
                body = shd.tri_body[tri]
                u, gamma_u = point_velocity(geo, shd, prim, lam, body, event)  # the emitting point's own velocity
                normal = vec3(scalar(0.0))  # needed by lights, the dome and mirrors only (unlit: its loads skipped)
                if shd.light_count > 0 or shd.sky.present != 0 or metal > scalar(0.0):
                    normal = shading_normal(geo, shd, prim, lam, n, u)
                if depth == 0:
                    first_u = u
                    first_gamma = gamma_u
                if metal < scalar(1.0):
                    local = emissive + diffuse  # unlit: what shade() returns without lights, without its call
                    if shd.light_count > 0:
                        local = shade_hit(geo, shd, finite, prim, path, event, normal, diffuse, emissive, u, gamma_u)
                    if shd.sky.present != 0:  # the dome's diffuse light (no shadowing), instead of the unlit albedo
                        lit = wp.cw_mul(diffuse, sky_irradiance(shd.sky, normal)) * scalar(INV_PI)
                        if shd.light_count == 0:
                            local = emissive + lit
                        else:
                            local = local + lit
                    ub = four_velocity(u, gamma_u, shd.body_decoupled[body])
                    body_term = ub[0]
                    if finite != 0:
                        body_term = ub[0] + n[0] * ub[1] + n[1] * ub[2] + n[2] * ub[3]
                    local = doppler_transform(local, cam_term / (energy * body_term), shd.doppler_table, shd.color_shift, shd.searchlight)
                    color = color + wp.cw_mul(weight, local) * (scalar(1.0) - metal)
                    source_t = event[0]
                    source_bounces = bounces
                if metal <= scalar(0.0) or depth == shd.max_depth:
                    if metal >= scalar(1.0):
                        source_t = event[0]
                        source_bounces = bounces
                    break
                v_mirror = u
                ok, n_out = reflect_null(n, normal, v_mirror, finite)
                # An interpolated normal can send a grazing reflection into the facet's own
                # plane (it would re-enter a convex mirror): reflect about the facet then.
                facet = shd.tri_normal[tri]
                if lam[3] > scalar(ANALYTIC_TEST):  # an analytic hit: its normal is the surface's
                    facet = normal
                if wp.dot(facet, n + v_mirror) > scalar(0.0):
                    facet = -facet
                if wp.dot(facet, n_out + v_mirror) <= scalar(0.0):
                    normal = facet
                    ok, n_out = reflect_null(n, normal, v_mirror, finite)
                if ok == 0:
                    break
                if finite != 0:
                    nv = wp.dot(normal, v_mirror)
                    energy = energy * (scalar(1.0) + scalar(2.0) * (wp.dot(n, normal) + nv) * nv / (scalar(1.0) - nv * nv))
                weight = wp.cw_mul(weight, diffuse) * metal
                o = event
                n = n_out
                skip = tri
                bounces += 1
                depth += 1
            alpha = scalar(0.0)
            if first_prim >= 0:
                alpha = scalar(1.0)
            return color, alpha, first_prim, first_s, first_lam, source_t, source_bounces, visits, overflow, first_u, first_gamma

        @wp.kernel(enable_backward=False, module="unique", name=name)
        def render_pixels(geo: Geometry, shd: Shading, cam: Camera, film: Film, offset: int, end: int):
            # Pixels offset + tid * PIXELS_PER_THREAD onwards, up to ``end`` (exclusive), in
            # turn: a CPU launch copies the kernel's struct arguments (kilobytes) per
            # thread, and so does every call that takes them, inlined or not (Warp passes
            # structs by value): the loop is the kernel's own, around the pixel's code.
            first = offset + wp.tid() * PIXELS_PER_THREAD
            last = wp.min(first + PIXELS_PER_THREAD, end)
            thread_visits = int(0)
            thread_covered = int(0)
            n_next = centre_direction(cam, first)
            for pixel in range(first, last):
                px = pixel % cam.width
                py = pixel / cam.width
                n = n_next
                if pixel + 1 < last:  # the next pixel's direction read or computed before this pixel's
                    # trace, which does not wait for it: out-of-order execution overlaps the two
                    n_next = centre_direction(cam, pixel + 1)
                # Ray 0 is the AOV ray: the pixel centre at the frame's camera time (also the
                # beauty when there is one sample); rays 1..samples are the jittered samples.
                # One call site of trace_path, inlined by force (out of line, a call copies the
                # Geometry and Shading structs per ray).
                rays = int(1)
                if cam.samples > 1:
                    rays = 1 + cam.samples
                color = vec3(scalar(0.0))
                alpha = scalar(0.0)
                prim = int(-1)
                s = scalar(0.0)
                src_t = scalar(0.0)
                src_b = int(0)
                visits = int(0)
                overflow = int(0)
                sum_color = vec3(scalar(0.0))
                sum_alpha = scalar(0.0)
                u0 = vec3(scalar(0.0))
                gamma0 = scalar(1.0)
                lam0 = vec4(scalar(0.0))
                for k in range(rays):
                    ray_o = cam.origin
                    ray_n = n
                    if k > 0:
                        ray_o, ray_n = sample_ray(cam, px, py, k - 1, pixel)
                    c, a, p_k, s_k, lam_k, st_k, sb_k, ray_visits, ray_ovf, u_k, g_k = trace_path(geo, shd, cam, ray_o, ray_n)
                    visits += ray_visits
                    overflow = wp.max(overflow, ray_ovf)
                    if film.sample_id.shape[0] > 0 and (k > 0 or rays == 1):  # the beauty's samples
                        hit_id = int(0)
                        if p_k >= 0:
                            hit_id = prim_triangle(geo, p_k) + 1
                        film.sample_id[pixel * cam.samples + wp.max(k - 1, 0)] = hit_id
                    if k == 0:
                        color = c
                        alpha = a
                        prim = p_k
                        s = s_k
                        lam0 = lam_k
                        src_t = st_k
                        src_b = sb_k
                        u0 = u_k
                        gamma0 = g_k
                    else:
                        sum_color = sum_color + c
                        sum_alpha = sum_alpha + a
                if cam.samples > 1:
                    inv = scalar(1.0) / scalar(cam.samples)
                    color = sum_color * inv
                    alpha = sum_alpha * inv
                thread_visits += visits
                if overflow != 0:
                    film.overflow[0] = 1
                bg = shd.background
                if shd.sky.present != 0:
                    bg = vec3(scalar(0.0))  # the sky is in the colour already
                film.rgba[pixel] = vec4(color[0] + bg[0] * (scalar(1.0) - alpha), color[1] + bg[1] * (scalar(1.0) - alpha), color[2] + bg[2] * (scalar(1.0) - alpha), alpha)
                if prim < 0:
                    film.depth[pixel] = scalar(wp.inf)
                    if film.event_code.shape[0] > 0:
                        film.event_code[pixel] = wp.float64(wp.nan)
                        film.source_code[pixel] = wp.float64(wp.nan)
                    else:
                        film.event_time[pixel] = scalar(wp.nan)
                        film.source_time[pixel] = scalar(wp.nan)
                    film.proper_time[pixel] = scalar(wp.nan)
                    film.doppler[pixel] = scalar(wp.nan)
                    if shd.sky.present != 0:  # the dome's D = (k.u_cam)/(k.u_lab), k = (1, -n)
                        uc0 = four_velocity(cam.velocity, cam.gamma, cam.decoupled)
                        film.doppler[pixel] = uc0[0]
                        if cam.finite != 0:
                            film.doppler[pixel] = uc0[0] + n[0] * uc0[1] + n[1] * uc0[2] + n[2] * uc0[3]
                    film.object_id[pixel] = 0
                    film.bounces[pixel] = 0
                    continue
                dt = scalar(0.0)
                if cam.finite != 0:
                    dt = -s
                event = vec4(dt, s * n[0], s * n[1], s * n[2])
                film.depth[pixel] = rest_distance(cam, dt, vec3(event[1], event[2], event[3]))
                if film.event_code.shape[0] > 0:
                    film.event_code[pixel] = time_code(event[0], film.code_origin, film.per_code)
                    film.source_code[pixel] = time_code(src_t - cam.origin[0], film.code_origin, film.per_code)
                else:
                    film.event_time[pixel] = event[0]
                    film.source_time[pixel] = src_t - cam.origin[0]  # trace_path's events are the anchor's
                film.bounces[pixel] = src_b

                body = shd.tri_body[prim_triangle(geo, prim)]
                bo = shd.body_clock[body]  # relative to the camera event, as ``event`` is
                v = shd.body_velocity[body]
                dec = shd.body_decoupled[body]
                rel_t = event[0] - bo[0]
                tau = rel_t
                if dec == 0:
                    rel_x = vec3(event[1] - bo[1], event[2] - bo[2], event[3] - bo[3])
                    tau = shd.body_gamma[body] * (rel_t - wp.dot(v, rel_x))
                if shd.vert_clock.shape[0] > 0 and shd.body_points[body] > 0:
                    # a deforming body's slices' clocks, blended as the event's time is: the
                    # pivot's proper time linear between slices (0 for bodies without one)
                    idx = prim_vertices(geo, prim)
                    tau = tau + (lam0[0] * shd.vert_clock[idx[0]] + lam0[1] * shd.vert_clock[idx[1]]
                                 + lam0[2] * shd.vert_clock[idx[2]] + lam0[3] * shd.vert_clock[idx[3]])
                film.proper_time[pixel] = tau

                # D = (k.u_cam)/(k.u_body), k = (1, -n): -k.u = u_t + n.u_x. With infinite
                # light speed only time dilation is left: the limit is u_cam_t / u_body_t.
                # The emitting point's velocity (docs/spec.md §2.1, §2.2): trace_path's at this very event.
                ub = four_velocity(u0, gamma0, dec)
                uc = four_velocity(cam.velocity, cam.gamma, cam.decoupled)
                dop = uc[0] / ub[0]
                if cam.finite != 0:
                    dop = (uc[0] + n[0] * uc[1] + n[1] * uc[2] + n[2] * uc[3]) / (
                        ub[0] + n[0] * ub[1] + n[1] * ub[2] + n[2] * ub[3]
                    )
                film.doppler[pixel] = dop
                film.object_id[pixel] = body + 1
                thread_covered += 1
            film.visits[first / PIXELS_PER_THREAD] = thread_visits  # tiles start at multiples of PIXELS_PER_THREAD
            film.covered[first / PIXELS_PER_THREAD] = thread_covered

        return render_pixels

    def make_camera_rays():
        @wp.kernel(enable_backward=False, module="unique")
        def camera_rays(cam: Camera, out: wp.array(dtype=vec3), first: int):
            """``out[pixel]``: ``pixel_direction`` of the pixel centres from ``first`` on, row by row."""
            pixel = first + wp.tid()
            out[pixel] = pixel_direction(cam, pixel % cam.width, pixel / cam.width)

        return camera_rays

    return (Shading, Camera, Film, make_pixels(shade), lambda: make_pixels(no_lights, "render_pixels_unlit"),
            make_camera_rays)


@functools.lru_cache(maxsize=None)
def get_kernels(precision: str, primitive: str = "prism", tets: bool = False, stack: int = STACK_SIZE) -> Kernels:
    """Kernels for ``"float32"``/``"float64"`` and a primitive of PRIMITIVES, built
    once per process (``"rigid"`` in float64 serves scenes of exact quadrics only;
    ``tets``: rigid with deforming bodies' tetrahedra as a second leaf kind; ``stack``: the
    rigid top level's traversal stack, ``traverse.stack_for`` its tree; the other paths
    take the full stack whatever it says)."""
    scalar = {"float32": wp.float32, "float64": wp.float64}[precision]
    if primitive not in PRIMITIVES:
        raise ValueError(f"primitive must be one of {', '.join(PRIMITIVES)}, got {primitive!r}")
    rigid = primitive == "rigid"
    return Kernels(scalar, primitive, tets and rigid, stack if rigid else STACK_SIZE)
