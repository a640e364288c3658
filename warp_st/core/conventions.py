"""Physical and numerical conventions shared by every module.

- Natural units: c = 1; time and length share one unit.
- Events are ordered (t, x, y, z); the Minkowski signature is (-, +, +, +):
  ``a.b = -a_t b_t + a_x b_x + a_y b_y + a_z b_z``.
- The lab frame is USD world space. A primary ray from the camera event
  C = (t_c, c) with unit spatial direction n is the past null line
  E(s) = (t_c - s, c + s n), s >= 0 (s = lookback = distance travelled by the light).
- With infinite light speed the ray stays on the camera's time slice:
  E(s) = (t_c, c + s n).
"""
from __future__ import annotations

import enum

__all__ = [
    "C",
    "LightSpeed",
    "Precision",
    "MINKOWSKI",
    "BOX_PAD_ULPS",
]

import numpy as np

#: Speed of light in scene units per time unit.
C = 1.0

#: Metric diag(-1, 1, 1, 1) in (t, x, y, z) order.
MINKOWSKI = np.diag([-1.0, 1.0, 1.0, 1.0])

#: Node boxes are rounded outward by this many ulps after recentring so that a
#: float64 box always lies inside its kernel-precision copy, with room for the
#: kernel's per-face rounding tolerance.
BOX_PAD_ULPS = 4


class LightSpeed(str, enum.Enum):
    """``spacetime:lightSpeed`` on the camera."""

    FINITE = "finite"
    INFINITE = "infinite"


class Precision(str, enum.Enum):
    """``spacetime:precision``: the scalar type of the render kernels."""

    FLOAT32 = "float32"
    FLOAT64 = "float64"


#: (width, height) of a render when neither the render settings nor the caller give one.
DEFAULT_RESOLUTION = (640, 360)
