"""Texture lookups at a hit (UsdUVTexture, docs/spec.md §2 textures): pure Warp device code.

The hit's barycentrics weigh the four vertex slots of its primitive (``prim_vidx``);
``prim_corner`` says which corner of the triangle each slot is (2 bits per slot; an
empty table means slots (0, 1, 2, 0): the rigid path's triangles and the prisms), and
``tri_st`` holds three st per triangle in that corner order. The st at the hit is the
barycentric blend of its corners, so a moving body carries its texture.

Filtering is nearest-texel: texel (x, y) = (floor(s W), floor((1 - t) H)), row 0 at the
top of the image (USD's t runs up), after the wrap mode of each axis: 0 repeat,
1 clamp, 2 mirror, 3 black (outside [0, 1) the texture's ``border``). The texels carry
the texture's scale and bias already (host side), linear.
"""
import functools

import warp as wp

__all__ = ["make_textures", "CORNERS_DEFAULT", "pack_corners", "pack_info"]

#: prim_corner of slots (0, 1, 2, 0).
CORNERS_DEFAULT = 0 | (1 << 2) | (2 << 4)


def pack_corners(c0, c1, c2, c3):
    """The prim_corner code of slots (c0, c1, c2, c3) (NumPy arrays or ints)."""
    return c0 | (c1 << 2) | (c2 << 4) | (c3 << 6)


def pack_info(wrap_s: int, wrap_t: int, channel: int) -> int:
    """``info[3]`` of a texture: wrap modes and the output channel (-1 rgb, 0..3)."""
    return wrap_s | (wrap_t << 2) | ((channel + 1) << 4)


@functools.lru_cache(maxsize=None)
def make_textures(scalar):
    vec2 = wp.types.vector(2, scalar)
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)

    @wp.struct
    class Textures:
        tri_st: wp.array(dtype=vec2)  # 3 per triangle, in prim_corner's corner order
        prim_corner: wp.array(dtype=wp.int32)  # per primitive; empty: CORNERS_DEFAULT
        mat_tex: wp.array(dtype=wp.vec3i)  # per material: texture of diffuse, emissive, metallic; -1 none
        info: wp.array(dtype=wp.vec4i)  # per texture: (first texel, width, height, pack_info)
        border: wp.array(dtype=vec4)  # per texture: the value outside [0, 1) under "black" wrap
        texel: wp.array(dtype=vec4)  # every texture's texels, rows from the top

    @wp.func
    def wrap_index(i: int, n: int, mode: int) -> int:
        """Texel index i on an axis of n texels under ``mode``; -1 outside under black."""
        if mode == 0:
            return ((i % n) + n) % n
        if mode == 1:
            return wp.min(wp.max(i, 0), n - 1)
        if mode == 2:
            m = ((i % (2 * n)) + 2 * n) % (2 * n)
            if m >= n:
                m = 2 * n - 1 - m
            return m
        if i < 0 or i >= n:
            return -1
        return i

    @wp.func
    def lookup(tx: Textures, t: int, st: vec2) -> vec4:
        info = tx.info[t]
        w = info[1]
        h = info[2]
        x = wrap_index(int(wp.floor(st[0] * scalar(w))), w, info[3] & 3)
        y = wrap_index(int(wp.floor((scalar(1.0) - st[1]) * scalar(h))), h, (info[3] >> 2) & 3)
        if x < 0 or y < 0:
            return tx.border[t]
        return tx.texel[info[0] + y * w + x]

    @wp.func
    def colour(tx: Textures, t: int, st: vec2) -> vec3:
        v = lookup(tx, t, st)
        channel = (tx.info[t][3] >> 4) - 1
        if channel < 0:
            return vec3(v[0], v[1], v[2])
        return vec3(v[channel], v[channel], v[channel])

    @wp.func
    def hit_st(tx: Textures, prim: int, tri: int, lam: vec4) -> vec2:
        code = int(CORNERS_DEFAULT)
        if tx.prim_corner.shape[0] > 0:
            code = tx.prim_corner[prim]
        st = vec2(scalar(0.0))
        for k in range(4):
            st = st + lam[k] * tx.tri_st[3 * tri + ((code >> (2 * k)) & 3)]
        return st

    @wp.func
    def surface_inputs(tx: Textures, prim: int, tri: int, lam: vec4, mat: int, diffuse: vec3, emissive: vec3,
                       metallic: scalar):
        """(diffuseColor, emissiveColor, metallic) at the hit: the material's constants,
        or its textures at the hit's st."""
        tex = tx.mat_tex[mat]
        if tex[0] < 0 and tex[1] < 0 and tex[2] < 0:
            return diffuse, emissive, metallic
        st = hit_st(tx, prim, tri, lam)
        if tex[0] >= 0:
            diffuse = colour(tx, tex[0], st)
        if tex[1] >= 0:
            emissive = colour(tx, tex[1], st)
        if tex[2] >= 0:
            metallic = wp.clamp(colour(tx, tex[2], st)[0], scalar(0.0), scalar(1.0))
        return diffuse, emissive, metallic

    return Textures, surface_inputs
