"""UsdLux DomeLight -> :class:`Dome`: the sky at rest in the lab at infinity (docs/spec.md §3).

Read: ``inputs:texture:file`` (through ``images.py``, colour space ``auto``) in the
``latlong`` format, and ``automatic`` (a latlong map: UsdLux's default orientation follows
OpenEXR's latitude-longitude convention, and the other layouts are not detected); then
``color``, ``intensity``, ``exposure`` (radiance = intensity x color x 2^exposure, times the
texels) and the prim's world rotation. The other formats (mirroredBall, angular,
cubeMapVerticalCross) and an unreadable file are warnings: the sky is then the constant
radiance. One dome is the sky; every further DomeLight is a warning. Surfaces get the
dome's diffuse irradiance, projected on spherical harmonics (``core.sky_irradiance``),
without shadowing.
"""
from __future__ import annotations

import numpy as np
from pxr import Sdf

from warp_st.core.scene import Dome, SceneError
from warp_st.core.sky_irradiance import irradiance_coefficients
from warp_st.usd import attributes as A
from warp_st.usd.attributes import Where
from warp_st.usd.diagnostics import Notes
from warp_st.usd.images import ImageError, read_image
from warp_st.usd.lights import emission

__all__ = ["read_dome", "DOME_FORMATS"]

#: inputs:texture:format tokens of UsdLux.DomeLight.
DOME_FORMATS = ("automatic", "latlong", "mirroredBall", "angular", "cubeMapVerticalCross")


def read_dome(where: Where, notes: Notes, prims: list, world) -> Dome | None:
    """The first of ``prims`` (DomeLights, traversal order) as the sky; ``world(prim)``
    gives a prim's world transform (a Gf.Matrix4d, USD's row-vector convention)."""
    if not prims:
        return None
    for extra in prims[1:]:
        notes.warn(extra, None, f"only one DomeLight is the sky ({prims[0].GetPath()}); this one is ignored",
                   "NotHonoured")
    prim = prims[0]
    rgb = emission(where, prim, diffuse=False)
    m = np.array(world(prim), dtype=np.float64).reshape(4, 4)[:3, :3]
    # Row vectors: d_lab = d_local @ M, so d_local = d_lab @ M^-1; as a column-vector
    # matrix acting on d_lab that is (M^-1)^T. Scale and shear are dropped (directions).
    u, _s, vt = np.linalg.svd(m)
    rotation = u @ vt  # the nearest rotation (polar decomposition) of the linear part
    local_from_lab = np.linalg.inv(rotation).T
    texels = _texels(where, notes, prim)
    return Dome(radiance=tuple(float(c) for c in rgb), texels=texels, local_from_lab=local_from_lab,
                prim_path=str(prim.GetPath()), irradiance=irradiance_coefficients(rgb, texels, local_from_lab))


def _texels(where: Where, notes: Notes, prim) -> np.ndarray | None:
    attr = prim.GetAttribute("inputs:texture:file")
    asset = attr.Get(where.time) if attr else None
    if not isinstance(asset, Sdf.AssetPath) or not asset.path:
        return None
    instead = "the sky is its constant radiance (color x intensity x 2^exposure)"
    try:
        fmt = A.token(where, prim, "inputs:texture:format", DOME_FORMATS, "automatic")
    except SceneError as exc:
        notes.value_error(exc, instead)
        return None
    if fmt not in ("automatic", "latlong"):
        notes.warn(prim, "inputs:texture:format", f"{fmt!r} maps are not supported (latlong and automatic are); "
                   f"{instead}", "NotHonoured")
        return None
    if not asset.resolvedPath:
        notes.warn(prim, "inputs:texture:file", f"{asset.path} cannot be found; {instead}", "MissingTexture")
        return None
    try:
        image = read_image(asset.resolvedPath, "auto")
    except ImageError as exc:
        notes.warn(prim, "inputs:texture:file", f"{asset.path} cannot be read ({exc}); {instead}", "MissingTexture")
        return None
    texels = image.texels
    h, w = texels.shape[:2]
    if fmt == "automatic" and w != 2 * h:
        notes.warn(prim, "inputs:texture:format", f"'automatic': the map is {w} x {h}, not a 2:1 latlong map; it is "
                   "read as latlong (other layouts are not detected)", "NotHonoured")
    rgba = np.ones(texels.shape[:2] + (4,), np.float32)
    rgba[..., :3] = texels[..., :1] if texels.shape[2] < 3 else texels[..., :3]
    return rgba
