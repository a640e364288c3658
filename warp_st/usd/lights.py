"""UsdLux lights -> :class:`warp_st.core.scene.Light` (docs/spec.md §3, docs/design/usdlux.md).

UsdLux's emission: a light's surface emits the radiance

    L = intensity * 2^exposure * color * blackbody(colorTemperature) * diffuse / sizeFactor

(sizeFactor = 1 unless ``inputs:normalize``: then the light's world-space surface area,
or for a DistantLight pi sin^2(theta_max), so that its intensity is the irradiance at
normal incidence). What a Lambert surface sees of it, as ``Light.radiance``:

- SphereLight of world radius r: a uniform sphere seen from outside is exactly a point of
  radiant intensity I = L pi r^2 at its centre (while the whole sphere is above the
  surface's horizon): radiance = I / pi = L r^2. ``treatAsPoint`` keeps that power and
  shrinks the geometry to the centre (hard shadows).
- DistantLight of angular diameter ``angle``: the cap of half-angle theta_max gives
  E = L pi sin^2(theta_max) at normal incidence (E = L for angle 0) and E cos(theta)
  when tilted: radiance = E / pi.
- RectLight / DiskLight: radiance = L / pi, integrated over the light by
  ``warp_st.core.light_samples``.
"""
from __future__ import annotations

import math

import numpy as np
from pxr import Gf, UsdLux

from warp_st.core.limits import MAX_MAGNITUDE
from warp_st.core.scene import Light
from warp_st.usd import attributes as A

__all__ = ["SUPPORTED", "read_light", "distant_size_factor", "emission"]

#: The UsdLux types rendered; other lights are ignored with a warning.
SUPPORTED = ("SphereLight", "DistantLight", "RectLight", "DiskLight")


def distant_size_factor(angle_degrees: float) -> float:
    """UsdLux's sizeFactor of a DistantLight: E at normal incidence = L * this (1 for a zero angle)."""
    theta = min(max(math.radians(angle_degrees) / 2.0, 0.0), math.pi)
    if theta == 0.0:
        return 1.0
    s2 = math.sin(theta) ** 2
    return math.pi * (s2 if theta <= math.pi / 2 else 2.0 - s2)


def emission(where, prim, *, diffuse: bool = True) -> np.ndarray:
    """intensity * 2^exposure * color (* blackbody) (* diffuse), linear RGB, validated
    (``diffuse``: the light's ``inputs:diffuse`` multiplier; a dome seen as the sky has none)."""
    intensity = A.real(where, prim, "inputs:intensity", 1.0, minimum=0.0)
    exposure = A.real(where, prim, "inputs:exposure", 0.0)
    color = A.vector(where, prim, "inputs:color", 3, (1.0, 1.0, 1.0))
    diffuse = A.real(where, prim, "inputs:diffuse", 1.0, minimum=0.0) if diffuse else 1.0
    if A.boolean(where, prim, "inputs:enableColorTemperature", False):
        kelvin = A.real(where, prim, "inputs:colorTemperature", 6500.0, positive=True)
        color = color * np.array(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        rgb = intensity * color * np.power(2.0, exposure) * diffuse
    if not (np.isfinite(rgb).all() and (np.abs(rgb) <= MAX_MAGNITUDE).all()):
        raise where.error(prim, "inputs:intensity * inputs:color * 2^inputs:exposure",
                          f"the light's radiance {tuple(rgb.tolist())} is not finite or exceeds {MAX_MAGNITUDE:g}")
    return rgb


def _size(where, prim, name: str, fallback: float, notes) -> float:
    """A radius, width, height or angle: negative values warn and count as 0 (UsdLux clips them)."""
    value = A.real(where, prim, name, fallback)
    if value < 0.0:
        notes.warn(prim, name, f"is negative ({value:g}); 0 is used", "NotHonoured")
        return 0.0
    return value


def _axis(where, prim, world: Gf.Matrix4d, row: int) -> np.ndarray:
    axis = np.array(world.GetRow3(row), dtype=np.float64)
    if not np.linalg.norm(axis) > 0.0:
        raise where.error(prim, "xformOpOrder", f"the world transform is singular (no +{'XYZ'[row]} axis)")
    return axis


def _rgb(where, prim, rgb: np.ndarray) -> tuple[float, float, float]:
    if not (np.isfinite(rgb).all() and (np.abs(rgb) <= MAX_MAGNITUDE).all()):
        raise where.error(prim, "inputs:normalize", f"the normalized radiance {tuple(rgb.tolist())} is not "
                                                    f"finite or exceeds {MAX_MAGNITUDE:g}")
    return tuple(float(c) for c in rgb)


def read_light(where, prim, world: Gf.Matrix4d, notes) -> Light | None:
    """The prim's Light (a supported, visible UsdLux light), else None after a warning."""
    if str(prim.GetTypeName()) not in SUPPORTED:
        why = ("environment lighting is not supported yet" if prim.IsA(UsdLux.DomeLight)
               else "only " + ", ".join(SUPPORTED[:-1]) + " and " + SUPPORTED[-1] + " are")
        notes.warn(prim, None, f"{prim.GetTypeName()} is not supported ({why}); ignored", "UnsupportedPrim")
        return None
    rgb = emission(where, prim)
    normalize = bool(A.boolean(where, prim, "inputs:normalize", False))
    path = str(prim.GetPath())
    position = tuple(float(c) for c in world.ExtractTranslation())
    x, y, z = (np.array(world.GetRow3(i), dtype=np.float64) for i in range(3))
    if prim.IsA(UsdLux.DistantLight):
        z = _axis(where, prim, world, 2)
        direction = tuple(float(c) for c in z / np.linalg.norm(z))
        size = distant_size_factor(min(_size(where, prim, "inputs:angle", 0.53, notes), 360.0))
        irradiance = rgb if normalize else rgb * size
        return Light("distant", _rgb(where, prim, irradiance / math.pi), direction=direction, prim_path=path)
    if prim.IsA(UsdLux.SphereLight):
        radius = _size(where, prim, "inputs:radius", 0.5, notes)
        point = bool(A.boolean(where, prim, "treatAsPoint", False))
        # a sphere's world radius under the transform's (mean) scale
        r = radius * float(np.cbrt(abs(x @ np.cross(y, z))))
        if normalize:
            intensity_over_pi = rgb / (4.0 * math.pi)  # L r^2 with L = rgb / (4 pi r^2), also as r -> 0
        else:
            intensity_over_pi = rgb * (r * r)
            if r == 0.0 and rgb.any():
                notes.warn(prim, "inputs:radius", "a SphereLight of radius 0 without inputs:normalize emits "
                                                  "nothing (UsdLux: radiance x area)", "NotHonoured")
        return Light("sphere", _rgb(where, prim, intensity_over_pi), position=position, prim_path=path,
                     radius=0.0 if point else r)
    if prim.IsA(UsdLux.RectLight):
        u = x * (0.5 * _size(where, prim, "inputs:width", 1.0, notes))
        v = y * (0.5 * _size(where, prim, "inputs:height", 1.0, notes))
        area = 4.0 * float(np.linalg.norm(np.cross(u, v)))
        kind = "rect"
    else:
        radius = _size(where, prim, "inputs:radius", 0.5, notes)
        u, v = x * radius, y * radius
        area = math.pi * float(np.linalg.norm(np.cross(u, v)))
        kind = "disk"
    if area == 0.0:
        notes.warn(prim, None, f"the {prim.GetTypeName()} has no area; ignored", "NotHonoured")
        return None
    radiance = (rgb / area if normalize else rgb) / math.pi
    back = np.cross(u, v)  # the surface's normal on its local +Z side (it emits along -Z)
    back *= (1.0 if z @ back >= 0.0 else -1.0) / np.linalg.norm(back)
    return Light(kind, _rgb(where, prim, radiance), position=position, direction=tuple(float(c) for c in back),
                 prim_path=path, axes=(tuple(float(c) for c in u), tuple(float(c) for c in v)))
