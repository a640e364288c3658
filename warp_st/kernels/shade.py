"""Surface response at a hit event: normals, Lambert with null-ray shadows, 4D mirror reflection.

Pure Warp device code. Lights are at rest in the lab (docs/spec.md §3) unless animated: then
each hit is lit from the light's emission event on its worldline (``light_track``, §3.4).
With --doppler-color / --searchlight each light's radiance arrives shifted by the Doppler
factor between the light and the lit point (``light_doppler``, §3.5).
"""
import warp as wp

from warp_st.kernels.layout import ANALYTIC_TEST
from warp_st.kernels.light_doppler import make_light_doppler
from warp_st.kernels.light_track import make_light_track
from warp_st.kernels.prim_lookup import make_prim_lookup
from warp_st.kernels.sky import make_sky
from warp_st.kernels.spectrum import make_spectrum
from warp_st.kernels.texture import make_textures

__all__ = ["make_shade"]


def make_shade(scalar, vec3, vec4, Geometry, trace):
    # Secondary rays start this far (relative to the path length so far) from the hit
    # event: in float32 1e-4 is ~1000 ulps, far above the rounding of the hit.
    SELF_EPS = 1.0e-4 if wp.types.type_size_in_bytes(scalar) == 4 else 1.0e-9
    SEAM_SLOPE = 20.0  # the longest reach past an animated piece's seam: shadow rays at (l + u).n >= 0.05
    FAR = 1.0e30
    # A turning coupled body's points are below c (the reader refuses faster ones, checking
    # the vertices); a hit between them may exceed that by rounding: 1 - |u|^2 is kept >= this.
    MIN_INV_GAMMA2 = 1.0e-12
    mat33 = wp.types.matrix((3, 3), scalar)
    Textures, _inputs = make_textures(scalar)
    Sky, _radiance, _irradiance = make_sky(scalar)
    Track, light_linear_at, emission_event, emission_velocity = make_light_track(scalar)
    incident_doppler = make_light_doppler(scalar)
    doppler_transform = make_spectrum(scalar, vec3)
    prim_triangle, prim_vertices = make_prim_lookup(Geometry)

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
        mat_metallic: wp.array(dtype=scalar)
        tex: Textures  # the materials' textures (kernels/texture.py)
        body_origin: wp.array(dtype=vec4)  # (t_ref, o) relative to the render origin
        body_clock: wp.array(dtype=vec4)  # (t_ref, o) relative to the camera event (proper time)
        body_velocity: wp.array(dtype=vec3)
        body_gamma: wp.array(dtype=scalar)
        body_decoupled: wp.array(dtype=wp.int32)
        body_spins: wp.array(dtype=wp.int32)  # 1: the body turns (an animated piece), its points move with
        body_spin: wp.array(dtype=mat33)  # v + W (x - o(t)), W = Body.spin (docs/spec.md §2.1)
        body_seam: wp.array(dtype=scalar)  # Body.seam: an animated piece's distance from its neighbours
        body_points: wp.array(dtype=wp.int32)  # > 0: the body deforms, its points per slice (tet path, §2.2)
        vert_velocity: wp.array(dtype=vec3)  # a deforming body's vertex: its velocity over the slice above it
        vert_clock: wp.array(dtype=scalar)  # a deforming body's vertex: tau - (t - t_ref) (empty: none has one)
        light_kind: wp.array(dtype=wp.int32)  # 0 sphere (radius 0: point), 1 distant, 2 area (rect, disk)
        light_pos: wp.array(dtype=vec3)
        light_dir: wp.array(dtype=vec3)
        light_radiance: wp.array(dtype=vec3)
        light_radius: wp.array(dtype=scalar)
        light_first: wp.array(dtype=wp.int32)  # area lights: their samples' range in sample_*
        light_samples: wp.array(dtype=wp.int32)
        sample_pos: wp.array(dtype=vec3)
        sample_weight: wp.array(dtype=scalar)  # area weights (sum: the light's area)
        track: Track  # animated lights' worldlines (kernels/light_track.py)
        light_count: int
        background: vec3
        sky: Sky  # a DomeLight (kernels/sky.py); sky.present 0: the background is the sky
        max_depth: int
        doppler_table: wp.array(dtype=vec3)  # Doppler colour shift table (spectrum.py)
        color_shift: int
        searchlight: int

    @wp.func
    def self_eps(path: scalar) -> scalar:
        return scalar(SELF_EPS) * (scalar(1.0) + wp.abs(path))

    @wp.func
    def corner_velocity(shd: Shading, j: int, top: int, stride: int) -> vec3:
        """A deforming body's tetrahedron corner j: its point's velocity over the tetrahedron's
        slice interval (a corner at or past ``top`` is the point's event at the next slice)."""
        if j >= top:
            return shd.vert_velocity[j - stride]
        return shd.vert_velocity[j]

    @wp.func
    def point_velocity(geo: Geometry, shd: Shading, prim: int, lam: vec4, body: int, event: vec4):
        """(u, its gamma): the lab velocity of ``body``'s point at ``event`` (relative to
        the render origin), u = v + W (x - o(t)) with o(t) = o + v (t - t_ref) the pivot;
        a body that does not turn gives (v, its gamma) as is. Decoupled: gamma 1.

        A deforming body (§2.2): the barycentric blend (``lam``) of the corners' point
        velocities over the slice interval holding the hit; gamma 1 when decoupled, else
        of that velocity (a coupled turning body's worldlines, §2.1 0.8.0). Tetrahedron ``prim``'s
        vertex indices ascend and its lowest, a, is its triangle's lowest at the bottom
        slice; a top corner is a bottom point's index + the body's points per slice, so
        exactly the corners >= a + stride are tops."""
        stride = shd.body_points[body]
        if stride > 0:
            idx = prim_vertices(geo, prim)
            top = idx[0] + stride
            u = (lam[0] * corner_velocity(shd, idx[0], top, stride) + lam[1] * corner_velocity(shd, idx[1], top, stride)
                 + lam[2] * corner_velocity(shd, idx[2], top, stride) + lam[3] * corner_velocity(shd, idx[3], top, stride))
            g = scalar(1.0)
            if shd.body_decoupled[body] == 0:  # spacetime/turning.py
                g = scalar(1.0) / wp.sqrt(wp.max(scalar(1.0) - wp.dot(u, u), scalar(MIN_INV_GAMMA2)))
            return u, g
        v = shd.body_velocity[body]
        g = shd.body_gamma[body]
        if shd.body_spins[body] != 0:
            bo = shd.body_origin[body]
            y = vec3(event[1] - bo[1], event[2] - bo[2], event[3] - bo[3]) - v * (event[0] - bo[0])
            v = v + shd.body_spin[body] * y
            if shd.body_decoupled[body] == 0:
                g = scalar(1.0) / wp.sqrt(wp.max(scalar(1.0) - wp.dot(v, v), scalar(MIN_INV_GAMMA2)))
        return v, g

    @wp.func
    def shading_normal(geo: Geometry, shd: Shading, prim: int, lam: vec4, n: vec3, v: vec3) -> vec3:
        """Unit normal at the hit, on the side the light to the camera leaves from.

        Smooth triangles interpolate vertex normals with the hit's barycentrics; an
        analytic hit (4th barycentric ANALYTIC, ``trace_rigid``) carries its own.
        Relative to a surface point moving with v (``point_velocity``) the photon (spatial
        direction -n) moves as -(n + v), which picks the side of a two-sided surface.
        """
        tri = prim_triangle(geo, prim)
        normal = shd.tri_normal[tri]
        if lam[3] > scalar(ANALYTIC_TEST):
            normal = vec3(lam[0], lam[1], lam[2])
        elif shd.tri_smooth[tri] != 0:
            idx = prim_vertices(geo, prim)
            sm = (
                lam[0] * shd.vert_normal[idx[0]]
                + lam[1] * shd.vert_normal[idx[1]]
                + lam[2] * shd.vert_normal[idx[2]]
                + lam[3] * shd.vert_normal[idx[3]]
            )
            if wp.length(sm) > scalar(0.0):
                normal = wp.normalize(sm)
        if wp.dot(normal, n + v) > scalar(0.0):
            normal = -normal
        return normal

    @wp.func
    def unblocked(geo: Geometry, finite: int, event: vec4, x: vec3, p: vec3, s_min: scalar, tri: int, body: int,
                  skip_dist: scalar) -> scalar:
        """1 when the null ray from the hit event back towards the point p at rest reaches it, else 0."""
        to_p = p - x
        d = wp.length(to_p)
        blocker, _bs, _bl, _bv, _bo = trace(geo.ref, event, to_p / d, finite, s_min, d * (scalar(1.0) - scalar(SELF_EPS)),
                                            tri, body, skip_dist, 1)
        if blocker < 0:
            return scalar(1.0)
        return scalar(0.0)

    @wp.func(inline=True)
    def sphere_visibility(geo: Geometry, finite: int, event: vec4, x: vec3, c: vec3, r: scalar, l: vec3, d: scalar,
                          s_min: scalar, tri: int, body: int, skip_dist: scalar) -> scalar:
        """Unblocked fraction of five shadow rays to the sphere's silhouette disk (its centre and
        four points at 0.7 of its radius, docs/design/usdlux.md)."""
        centre = c - l * (r * r / d)
        rs = scalar(0.7) * r * wp.sqrt(wp.max(scalar(1.0) - r * r / (d * d), scalar(0.0)))
        a = vec3(scalar(1.0), scalar(0.0), scalar(0.0))
        if wp.abs(l[0]) > scalar(0.6):
            a = vec3(scalar(0.0), scalar(1.0), scalar(0.0))
        e1 = wp.normalize(wp.cross(l, a))
        e2 = wp.cross(l, e1)
        vis = unblocked(geo, finite, event, x, centre, s_min, tri, body, skip_dist)
        vis += unblocked(geo, finite, event, x, centre + rs * e1, s_min, tri, body, skip_dist)
        vis += unblocked(geo, finite, event, x, centre - rs * e1, s_min, tri, body, skip_dist)
        vis += unblocked(geo, finite, event, x, centre + rs * e2, s_min, tri, body, skip_dist)
        vis += unblocked(geo, finite, event, x, centre - rs * e2, s_min, tri, body, skip_dist)
        return vis / scalar(5.0)

    @wp.func
    def shadow_skip(shd: Shading, body: int, normal: vec3, l: vec3, u: vec3, finite: int, cos_l: scalar,
                    skip_dist: scalar):
        """(leave, skip) of a shadow ray towards l from a point moving with u. An animated
        body's neighbouring pieces model the same surface within ``body_seam``: relative to
        the point the ray leaves along l + u (with infinite c the ray and the surface meet at
        one instant: along l), so it enters the body's own world-tube at once when
        leave = (l + u).n <= 0 (the body shadows itself), else it meets the neighbours' copy
        within seam / leave, which the ray skips on the body (at most SEAM_SLOPE seams)."""
        seam = shd.body_seam[body]
        if seam <= scalar(0.0):
            return cos_l, skip_dist
        leave = cos_l
        if finite != 0:
            leave = wp.dot(normal, l + u)
        reach = seam * scalar(SEAM_SLOPE)
        if leave * scalar(SEAM_SLOPE) > scalar(1.0):
            reach = seam / leave
        return leave, wp.max(skip_dist, reach)

    @wp.func
    def area_light(geo: Geometry, shd: Shading, finite: int, event: vec4, x: vec3, normal: vec3, li: int,
                   s_min: scalar, tri: int, body: int, skip_dist: scalar, u: vec3, gamma_u: scalar):
        """sum_i w_i cos cos' / d^2 over the light's unblocked samples (warp_st.core.light_samples)
        whose light arrives unshifted, and the sum of the others' shifted radiance times theirs
        (D_ls != 1 at the point moving with u, with --doppler-color / --searchlight)."""
        moving = shd.track.count[li] > 0
        shifting = shd.color_shift != 0 or shd.searchlight != 0
        total = scalar(0.0)
        shifted = vec3(scalar(0.0))
        first = shd.light_first[li]
        for j in range(first, first + shd.light_samples[li]):
            back = shd.light_dir[li]
            p = shd.sample_pos[j]
            v_light = vec3(scalar(0.0))
            if moving:  # the sample's retarded position, the light's normal turned with it
                e = emission_event(shd.track, li, p, shd.light_pos[li], event, finite)
                v_light = emission_velocity(shd.track, li, p, shd.light_pos[li], e[0])
                p = vec3(e[1], e[2], e[3])
                back = wp.normalize(light_linear_at(shd.track, li, e[0]) * back)
            to_p = p - x
            d = wp.length(to_p)
            l = to_p / d
            cos_s = wp.dot(normal, l)
            cos_e = wp.dot(back, l)  # the light emits along -back: towards x when back.l > 0
            leave, skip = shadow_skip(shd, body, normal, l, u, finite, cos_s, skip_dist)
            if cos_s > scalar(0.0) and cos_e > scalar(0.0) and leave > scalar(0.0):
                vis = unblocked(geo, finite, event, x, p, s_min, tri, body, skip)
                a = vis * shd.sample_weight[j] * cos_s * cos_e / (d * d)
                dop = scalar(1.0)
                if shifting:
                    dop = incident_doppler(l, u, gamma_u, shd.body_decoupled[body], v_light, finite)
                if dop == scalar(1.0):
                    total += a
                else:
                    rad = doppler_transform(shd.light_radiance[li], dop, shd.doppler_table, shd.color_shift,
                                            shd.searchlight)
                    shifted += rad * a
        return total, shifted

    @wp.func(inline=True)
    def shade(geo: Geometry, shd: Shading, finite: int, prim: int, path: scalar, event: vec4, normal: vec3,
              diffuse: vec3, emissive: vec3, u: vec3, gamma_u: scalar):
        """Emission plus Lambert from lights at rest, each behind a null-ray shadow test.

        ``diffuse`` / ``emissive``: the material's at the hit (textured or constant); u, gamma_u:
        the lit point's velocity (``point_velocity``), for the light's Doppler factor.
        Without lights the surface shows its unlit albedo (docs/spec.md §3).
        """
        tri = prim_triangle(geo, prim)
        body = shd.tri_body[tri]
        color = emissive
        if shd.light_count == 0:
            return color + diffuse
        x = vec3(event[1], event[2], event[3])
        s_min = self_eps(path)
        # A smooth-shaded facet near the terminator would shadow itself on its
        # neighbours (the facet normal is not the shading normal): ignore its own
        # body within two facet sizes. Real self-shadowing of a moving body needs
        # it to move by its size, far beyond that.
        skip_dist = scalar(0.0)
        if shd.tri_smooth[tri] != 0:
            skip_dist = scalar(2.0) * shd.tri_size[tri]
        for li in range(shd.light_count):
            kind = shd.light_kind[li]
            if kind == 2:
                area, shifted = area_light(geo, shd, finite, event, x, normal, li, s_min, tri, body, skip_dist,
                                           u, gamma_u)
                color = color + wp.cw_mul(diffuse, shd.light_radiance[li]) * area
                if shd.color_shift != 0 or shd.searchlight != 0:
                    color = color + wp.cw_mul(diffuse, shifted)
            else:
                l = shd.light_dir[li]
                pos = shd.light_pos[li]
                v_light = vec3(scalar(0.0))  # a distant light has none: it only turns
                if shd.track.count[li] > 0:
                    if kind == 1:  # a distant light's direction at the hit time (no retardation)
                        l = wp.normalize(light_linear_at(shd.track, li, event[0]) * l)
                    else:  # the sphere's centre at its retarded time
                        e = emission_event(shd.track, li, pos, pos, event, finite)
                        v_light = emission_velocity(shd.track, li, pos, pos, e[0])
                        pos = vec3(e[1], e[2], e[3])
                dist = scalar(FAR)
                atten = scalar(1.0)
                radius = scalar(0.0)
                centre_dist = scalar(0.0)
                if kind == 0:
                    to_light = pos - x
                    dist = wp.length(to_light)
                    centre_dist = dist
                    l = to_light / dist
                    atten = scalar(1.0) / (dist * dist)
                    dist = dist * (scalar(1.0) - scalar(SELF_EPS))
                    radius = shd.light_radius[li]
                cos_l = wp.dot(normal, l)
                if cos_l > scalar(0.0) and centre_dist >= radius:
                    vis = scalar(0.0)
                    leave, skip = shadow_skip(shd, body, normal, l, u, finite, cos_l, skip_dist)
                    # leave <= 0: the body's own shadow (vis stays 0)
                    if leave > scalar(0.0) and radius > scalar(0.0):  # a sphere: shadows from its silhouette
                        vis = sphere_visibility(geo, finite, event, x, pos, radius, l, centre_dist,
                                                s_min, tri, body, skip)
                    elif leave > scalar(0.0):
                        blocker, _bs, _bl, _bv, _bo = trace(geo.ref, event, l, finite, s_min, dist, tri, body, skip, 1)
                        if blocker < 0:
                            vis = scalar(1.0)
                    if vis > scalar(0.0):
                        rad = shd.light_radiance[li]
                        if shd.color_shift != 0 or shd.searchlight != 0:
                            dop = incident_doppler(l, u, gamma_u, shd.body_decoupled[body], v_light, finite)
                            rad = doppler_transform(rad, dop, shd.doppler_table, shd.color_shift, shd.searchlight)
                        color = color + wp.cw_mul(diffuse, rad) * (cos_l * atten) * vis
        return color

    @wp.func
    def reflect_null(n: vec3, normal: vec3, v: vec3, finite: int):
        """Reflect the past null ray (-1, n) about a mirror's world-sheet (ok, new n).

        The world-sheet of a surface with lab normal N moving with v is
        {N.(x - v t) = const}; its Minkowski normal is nu = (N.v, N). Reflecting
        k = (-1, n) as k' = k - 2 (k.nu)/(nu.nu) nu keeps k' null and is Einstein's
        law of reflection at a moving mirror (equivalently: boost to the mirror frame,
        reflect, boost back). With infinite light speed the ray stays at constant t
        and reflects as in 3D. Returns ok = 0 when nu is not spacelike (|N.v| >= 1).
        """
        if finite == 0:
            return 1, wp.normalize(n - scalar(2.0) * wp.dot(n, normal) * normal)
        nv = wp.dot(normal, v)
        denom = scalar(1.0) - nv * nv
        if denom <= scalar(0.0):
            return 0, n
        f = scalar(2.0) * (wp.dot(n, normal) + nv) / denom
        k_t = scalar(-1.0) - f * nv
        k_x = n - f * normal
        if k_t >= scalar(0.0):
            return 0, n
        return 1, wp.normalize(k_x / (-k_t))

    return Shading, self_eps, shading_normal, shade, reflect_null, point_velocity
