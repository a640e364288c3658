"""Observer (event, velocity, orientation, lens) -> kernel camera parameters.

Pinhole model of docs/spec.md §3: pixel (i, j) (row 0 at the top) looks along
((x_ndc hAp/2 + hOff)/f, (y_ndc vAp/2 + vOff)/f, -1) in camera space, with
x_ndc = 2 (i + 1/2)/W - 1 and y_ndc = 1 - 2 (j + 1/2)/H. The vertical aperture is
conformed to the image aspect (vAp = hAp H / W), keeping the horizontal field of view.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.conventions import LightSpeed
from warp_st.core.scene import CameraState
from warp_st.kernels import Kernels

__all__ = ["make_camera", "camera_velocity_gamma"]


def camera_velocity_gamma(cam: CameraState) -> float:
    speed = float(np.linalg.norm(cam.velocity))
    if cam.decoupled or speed == 0.0:
        return 1.0
    return 1.0 / np.sqrt(1.0 - speed * speed)


def make_camera(
    k: Kernels,
    cam: CameraState,
    width: int,
    height: int,
    light_speed: LightSpeed,
    *,
    samples: int = 1,
    shutter: float = 0.0,
    seed: int = 0,
):
    """Kernel camera. samples > 1 jitters rays in the pixel (a strata x strata grid) and
    in camera time over [t_c, t_c + shutter] (4D anti-aliasing and motion blur)."""
    c = k.Camera()
    c.lab_from_camera = k.mat33(*np.asarray(cam.rotation, dtype=np.float64).reshape(-1).tolist())
    c.focal = float(cam.focal_length)
    c.h_ap = float(cam.horizontal_aperture)
    c.v_ap = float(cam.horizontal_aperture) * height / width
    c.h_off = float(cam.horizontal_aperture_offset)
    c.v_off = float(cam.vertical_aperture_offset)
    c.width = int(width)
    c.height = int(height)
    c.velocity = k.vec3(*[float(x) for x in cam.velocity])
    c.gamma = camera_velocity_gamma(cam)
    c.moving = 1 if float(np.linalg.norm(cam.velocity)) > 0.0 else 0
    c.decoupled = 1 if cam.decoupled else 0
    c.finite = 1 if LightSpeed(light_speed) == LightSpeed.FINITE else 0
    c.samples = int(samples)
    c.strata = max(1, int(np.ceil(np.sqrt(samples))))
    c.shutter = float(shutter)
    c.seed = int(seed)
    return c
