"""Ray-query kernels for tests and benchmarks: arbitrary null rays, BVH or brute force."""
import warp as wp

from warp_st.kernels.traverse import make_null_inv

__all__ = ["make_probe"]


def make_probe(scalar, vec3, vec4, Geometry, trace, prepare, leaf):
    FAR = 1.0e30
    null_inv = make_null_inv(scalar)

    @wp.kernel(enable_backward=False, module="unique")
    def cast_rays(
        geo: Geometry,
        origins: wp.array(dtype=vec4),
        dirs: wp.array(dtype=vec3),
        finite: int,
        out_prim: wp.array(dtype=wp.int32),
        out_s: wp.array(dtype=scalar),
        out_visits: wp.array(dtype=wp.int32),
        first: int,
    ):
        """Rays ``first`` + tid (a tile's launch passes its first ray, as the renderer's
        do, not slices of the arrays: five slices cost ~20 us a launch under the GIL)."""
        i = wp.tid() + first
        prim, s, _lam, visits, _ovf = trace(geo.ref, origins[i], dirs[i], finite, scalar(0.0), scalar(FAR), -1, -1, scalar(0.0), 0)
        out_prim[i] = prim
        out_s[i] = s
        out_visits[i] = visits

    @wp.kernel(enable_backward=False, module="unique")
    def brute_rays(
        geo: Geometry,
        prim_count: int,
        origins: wp.array(dtype=vec4),
        dirs: wp.array(dtype=vec3),
        finite: int,
        out_prim: wp.array(dtype=wp.int32),
        out_s: wp.array(dtype=scalar),
    ):
        """The leaf test over every primitive at once: no BVH node is visited."""
        i = wp.tid()
        o = origins[i]
        n = dirs[i]
        ray = prepare(geo, o, n, finite, null_inv(n, finite))
        best, best_prim, _lam = leaf(geo, ray, 0, prim_count, o, n, finite, scalar(0.0), scalar(FAR), int(-1),
                                     vec4(scalar(0.0)), -1, -1, scalar(0.0), 0)
        out_prim[i] = best_prim
        out_s[i] = best

    return cast_rays, brute_rays
