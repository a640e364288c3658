"""The bottom level's query in Warp's own language: the twin of ``kernels/blas.py``'s C++.

Until 0.10 this was the renderer's query; the C++ one (``warp_st/kernels/blas_query.inc``)
computes the same operations in the same order on four lanes at a time. The tests hold
the two equal bit for bit (t, barycentrics, face), so this file is the oracle that the
native code's vector steps, lane masks and tie order are right. Its arguments, results
and algorithm are the ones ``warp_st/kernels/blas.py`` describes.
"""

import warp as wp

from warp_st.kernels.layout import LINK_MASK, LINK_SHIFT
from warp_st.kernels.traverse import STACK_SIZE, make_box_ops, make_sort4

__all__ = ["make_blas_twin"]


def make_blas_twin(Geometry):
    vec12 = wp.types.vector(12, wp.float32)
    stack_i = wp.types.vector(STACK_SIZE, wp.int32)
    stack_s = wp.types.vector(STACK_SIZE, wp.float32)
    fmin, fmax, safe_inv, SLAB_GROW = make_box_ops(wp.float32)
    sort4 = make_sort4(wp.float32)
    INF = float("inf")

    @wp.func(inline=True)
    def blas_query(g: Geometry, root: int, vert: int, tri0: int, p: wp.vec3, d: wp.vec3, t_max: wp.float32, any_hit: int,
                   tri_base: int, skip_body: int, skip_t: wp.float32, skip_tri: int):
        # The shear of Woop's test, once per ray: z along the largest |d| (the first
        # of equals), x and y swapped when d_z < 0 to keep the winding.
        kz = int(0)
        if wp.abs(d[1]) > wp.abs(d[0]):
            kz = 1
        if wp.abs(d[2]) > wp.abs(d[kz]):
            kz = 2
        kx = (kz + 1) % 3
        ky = (kx + 1) % 3
        if d[kz] < 0.0:
            kt = kx
            kx = ky
            ky = kt
        sx = d[kx] / d[kz]
        sy = d[ky] / d[kz]
        sz = 1.0 / d[kz]
        inv = wp.vec3(safe_inv(d[0]), safe_inv(d[1]), safe_inv(d[2]))
        o12 = vec12()
        inv12 = vec12()
        for k in range(12):
            o12[k] = p[k // 4]
            inv12[k] = inv[k // 4]
        best = t_max
        hit = int(0)
        best_u = float(0.0)
        best_v = float(0.0)
        best_face = int(-1)
        st_node = stack_i()
        st_s = stack_s()
        sp = int(0)
        cur = root << LINK_SHIFT  # the root wide node's link
        while cur >= 0:
            first = cur >> LINK_SHIFT
            count = cur & LINK_MASK
            next_link = int(-1)
            if count > 0:
                for i in range(first, first + count):
                    tri = g.shape_vidx[i]
                    a = g.blas_points[vert + tri[0]] - p
                    b = g.blas_points[vert + tri[1]] - p
                    c = g.blas_points[vert + tri[2]] - p
                    ax = a[kx] - sx * a[kz]
                    ay = a[ky] - sy * a[kz]
                    bx = b[kx] - sx * b[kz]
                    by = b[ky] - sy * b[kz]
                    cx = c[kx] - sx * c[kz]
                    cy = c[ky] - sy * c[kz]
                    # Edge functions: products of float32 are exact in float64, so each
                    # is their difference rounded once (an edge shared by two triangles
                    # gets the same value with opposite signs in both).
                    eu = wp.float32(wp.float64(cx) * wp.float64(by) - wp.float64(cy) * wp.float64(bx))
                    ev = wp.float32(wp.float64(ax) * wp.float64(cy) - wp.float64(ay) * wp.float64(cx))
                    ew = wp.float32(wp.float64(bx) * wp.float64(ay) - wp.float64(by) * wp.float64(ax))
                    outside = (eu < 0.0 or ev < 0.0 or ew < 0.0) and (eu > 0.0 or ev > 0.0 or ew > 0.0)
                    det = eu + ev + ew
                    if not outside and det != 0.0:
                        tt = eu * (sz * a[kz]) + ev * (sz * b[kz]) + ew * (sz * c[kz])
                        if (det > 0.0 and tt >= 0.0) or (det < 0.0 and tt <= 0.0):
                            rcp = 1.0 / det
                            t = tt * rcp
                            keep = int(1)
                            if skip_body >= 0:
                                own = tri_base + i - tri0
                                if own == skip_tri or (t < skip_t and g.tri_body[own] == skip_body):
                                    keep = 0
                            if t < best and t >= 0.0 and keep != 0:
                                best = t
                                best_u = eu * rcp
                                best_v = ev * rcp
                                best_face = i
                                hit = 1
                if any_hit != 0 and hit != 0:
                    break
            else:
                # The child boxes decoded in the node's frame (accel/blas.quantised:
                # they contain the exact ones), then the slab distances.
                qn = g.blas_q[first]
                fr = g.blas_frame[first]
                lo = vec12()
                hi = vec12()
                for k in range(12):
                    lo[k] = (fr[k // 4] + wp.float32(qn[k]) * fr[3 + k // 4] - o12[k]) * inv12[k]
                    hi[k] = (fr[k // 4] + wp.float32(qn[12 + k]) * fr[3 + k // 4] - o12[k]) * inv12[k]
                links = g.blas_link[first]
                e = wp.vec4()
                hits = int(0)
                for k in range(4):
                    near = fmax(fmax(fmax(fmin(lo[k], hi[k]), fmin(lo[4 + k], hi[4 + k])),
                                     fmin(lo[8 + k], hi[8 + k])), 0.0)
                    far = fmin(fmin(fmin(fmax(lo[k], hi[k]), fmax(lo[4 + k], hi[4 + k])),
                                    fmax(lo[8 + k], hi[8 + k])) * SLAB_GROW, best)
                    if near <= far and links[k] >= 0:
                        e[k] = near
                        hits += 1
                    else:
                        e[k] = INF
                e, links = sort4(e, links)
                if hits > 0:
                    next_link = links[0]
                    if sp + hits - 1 <= STACK_SIZE:
                        for k in range(3):
                            j = 3 - k
                            if j < hits:
                                st_node[sp] = links[j]
                                st_s[sp] = e[j]
                                sp += 1
            while next_link < 0 and sp > 0:
                sp -= 1
                if st_s[sp] <= best:
                    next_link = st_node[sp]
            cur = next_link
        return hit, best, best_u, best_v, best_face - tri0

    return blas_query
