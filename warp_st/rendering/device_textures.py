"""NumPy -> Warp for the materials' textures (``kernels/texture.py``), one flat atlas, and
for the sky's map (``kernels/sky.py``).

Each distinct texel array is stored once; each texture (a UsdUVTexture output) is a row of
``info`` (first texel, width, height, wraps and channel) and ``border``. Untextured
scenes upload empty tables (the kernel never reads them); a scene without a DomeLight an
empty sky.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.core.scene import WRAP_MODES
from warp_st.kernels import Kernels
from warp_st.kernels.sky import make_sky
from warp_st.kernels.texture import make_textures, pack_corners, pack_info

__all__ = ["texture_tables", "tet_corners", "sky_struct"]

_DEVICE = "cpu"


def tet_corners(tets: np.ndarray) -> np.ndarray:
    """prim_corner codes of the extrusion's tetrahedra (``extrude._prism_tets``).

    A tetrahedron's sorted vertices are one of (a, b, c, c'), (a, b, b', c'),
    (a, a', b', c') with a < b < c a triangle's vertices and ' the next slice (+ the
    body's point count, larger than any difference within a slice): the largest step
    between consecutive indices says which, and so which of the triangle's ascending
    corners each slot is."""
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    jump = np.argmax(np.diff(tets, axis=1), axis=1)
    codes = np.array([pack_corners(0, 0, 1, 2), pack_corners(0, 1, 1, 2), pack_corners(0, 1, 2, 2)], np.int32)
    return codes[jump] if len(tets) else np.zeros(0, np.int32)


def texture_tables(k: Kernels, tables, tets: np.ndarray | None = None):
    """The ``Textures`` struct of ``tables`` (TriangleTables); ``tets``: the database's
    tetrahedra (leaf order) when it traces tetrahedra."""
    ns = np.float32 if k.scalar == wp.float32 else np.float64
    Textures, _ = make_textures(k.scalar)
    vec2 = wp.types.vector(2, k.scalar)
    mats = tables.materials or ()
    slots, info, border, texels, first = {}, [], [], [], {}
    offset = 0
    mat_tex = np.full((len(mats), 3), -1, np.int32)
    for i, m in enumerate(mats):
        for j, tex in enumerate(m.textures):
            if tex is None:
                continue
            if id(tex) not in slots:
                key = id(tex.texels)
                if key not in first:
                    first[key] = offset
                    texels.append(np.asarray(tex.texels, dtype=ns).reshape(-1, 4))
                    offset += len(texels[-1])
                h, w = tex.texels.shape[:2]
                slots[id(tex)] = len(info)
                info.append((first[key], w, h, pack_info(WRAP_MODES.index(tex.wrap[0]), WRAP_MODES.index(tex.wrap[1]),
                                                          tex.channel)))
                border.append(tex.border)
            mat_tex[i, j] = slots[id(tex)]
    textured = bool(info)
    t = Textures()
    st = np.asarray(tables.tri_st, dtype=ns).reshape(-1, 2) if textured else np.zeros((0, 2), ns)
    t.tri_st = wp.array(st, dtype=vec2, device=_DEVICE, copy=False)  # the host table's memory when of ns
    corners = tet_corners(tets) if (textured and tets is not None) else np.zeros(0, np.int32)
    t.prim_corner = wp.array(corners, dtype=wp.int32, device=_DEVICE)
    t.mat_tex = wp.array(mat_tex, dtype=wp.vec3i, device=_DEVICE)
    t.info = wp.array(np.array(info, np.int32).reshape(-1, 4), dtype=wp.vec4i, device=_DEVICE)
    t.border = wp.array(np.array(border, ns).reshape(-1, 4), dtype=k.vec4, device=_DEVICE)
    t.texel = wp.array(np.concatenate(texels) if texels else np.zeros((0, 4), ns), dtype=k.vec4, device=_DEVICE)
    return t


def sky_struct(k: Kernels, dome):
    """The ``Sky`` struct of a ``Dome`` (None: no sky, the background shows)."""
    ns = np.float32 if k.scalar == wp.float32 else np.float64
    Sky, _radiance, _irradiance = make_sky(k.scalar)
    sky = Sky()
    sky.present = 0 if dome is None else 1
    sky.radiance = k.vec3(*(dome.radiance if dome is not None else (0.0, 0.0, 0.0)))
    rot = np.eye(3) if dome is None else np.asarray(dome.local_from_lab, dtype=np.float64)
    sky.local_from_lab = wp.types.matrix((3, 3), k.scalar)(*rot.reshape(-1).tolist())
    texels = None if dome is None else dome.texels
    sky.height, sky.width = (0, 0) if texels is None else texels.shape[:2]
    flat = np.zeros((0, 4), ns) if texels is None else np.asarray(texels, dtype=ns).reshape(-1, 4)
    sky.texel = wp.array(flat, dtype=k.vec4, device=_DEVICE)
    coef = np.zeros((9, 3)) if dome is None or dome.irradiance is None else np.asarray(dome.irradiance)
    sky.irradiance = wp.array(coef.astype(ns), dtype=k.vec3, device=_DEVICE)
    return sky
