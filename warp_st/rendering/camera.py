"""Observer (event, velocity, orientation, lens) -> kernel camera parameters.

Pinhole model of docs/spec.md §3: pixel (i, j) (row 0 at the top) looks along
((x_ndc hAp/2 + hOff)/f, (y_ndc vAp/2 + vOff)/f, -1) in camera space, with
x_ndc = 2 (i + 1/2)/W - 1 and y_ndc = 1 - 2 (j + 1/2)/H. The vertical aperture is
conformed to the image aspect (vAp = hAp H / W), keeping the horizontal field of view.
:func:`pixel_directions` and :func:`ray_directions` are the same model in float64 NumPy
(for oracles, measurements and benchmarks); ``make_camera`` fills the kernel's twin.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.core.conventions import LightSpeed
from warp_st.core.lorentz import aberrate
from warp_st.core.scene import CameraState
from warp_st.core.thread_pool import each_on_threads
from warp_st.kernels import Kernels
from warp_st.rendering.launches import tile_launches

__all__ = ["make_camera", "camera_rays", "camera_velocity_gamma",
           "pixel_directions", "ray_directions", "DIRECTION_FRAMES"]

#: Where :func:`ray_directions` expresses a look direction: "camera" (the camera's rest
#: frame, camera axes: -Z forward, +Y up), "rest" (the camera's rest frame, lab axes) or
#: "lab" (the lab frame: "rest" aberrated by the camera's velocity, docs/spec.md §3).
DIRECTION_FRAMES = ("camera", "rest", "lab")


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
    origin=(0.0, 0.0, 0.0, 0.0),
):
    """Kernel camera. samples > 1 jitters rays in the pixel (a strata x strata grid) and
    in camera time over [t_c, t_c + shutter] (4D anti-aliasing and motion blur). ``origin``:
    the camera event relative to the geometry's anchor (``rendering.anchor``), the rays' origin.
    Its table of the pixel centres' directions (``dirs``) is empty: the kernel computes
    them, until ``camera_rays`` makes one."""
    c = k.Camera()
    c.origin = k.vec4(*[float(x) for x in origin])
    c.lab_from_camera = wp.mat33d(*np.asarray(cam.rotation, dtype=np.float64).reshape(-1).tolist())
    c.focal = float(cam.focal_length)
    c.h_ap = float(cam.horizontal_aperture)
    c.v_ap = float(cam.horizontal_aperture) * height / width
    c.h_off = float(cam.horizontal_aperture_offset)
    c.v_off = float(cam.vertical_aperture_offset)
    c.width = int(width)
    c.height = int(height)
    c.velocity = k.vec3(*[float(x) for x in cam.velocity])
    c.gamma = camera_velocity_gamma(cam)
    # Moving when v.v is a normal number in the kernels' float type: a speed whose square
    # underflows there (|v| < ~1e-19 in float32) is at rest to their precision, and the
    # boosts' (gamma - 1) / v.v would be 0 / 0 (NaN depth on every hit).
    ns = np.float32 if k.scalar == wp.float32 else np.float64
    v = np.asarray(cam.velocity, dtype=np.float64).astype(ns).astype(np.float64)
    c.moving = 1 if float(np.dot(v, v)) >= float(np.finfo(ns).tiny) else 0
    c.decoupled = 1 if cam.decoupled else 0
    c.finite = 1 if LightSpeed(light_speed) == LightSpeed.FINITE else 0
    c.samples = int(samples)
    c.strata = max(1, int(np.ceil(np.sqrt(samples))))
    c.shutter = float(shutter)
    c.seed = int(seed)
    # The kernel's camera_direction at the pixel centres, in its order of float64
    # operations (the centre px + 0.5 is exact in float32, as the kernel forms it).
    x_ndc = (np.arange(width, dtype=np.float64) + 0.5) / float(width) * 2.0 - 1.0
    y_ndc = 1.0 - (np.arange(height, dtype=np.float64) + 0.5) / float(height) * 2.0
    c.col = wp.array((x_ndc * c.h_ap * 0.5 + c.h_off) / c.focal, dtype=wp.float64, device="cpu")
    c.row = wp.array((y_ndc * c.v_ap * 0.5 + c.v_off) / c.focal, dtype=wp.float64, device="cpu")
    c.dirs = wp.empty(0, dtype=k.vec3, device="cpu")
    return c


def camera_rays(k: Kernels, c, threads: int = 1) -> wp.array:
    """The lab direction of every pixel centre's ray of kernel camera ``c``, row by row
    (its ``dirs``): the pixel kernel's own float64 pinhole (``pixel_direction``), run in
    ``threads`` bands at once. It depends on the lens, orientation, image size and velocity
    only (``frame_inputs.lens_key``), not on the camera's event."""
    n = c.width * c.height
    out = wp.empty(n, dtype=k.vec3, device="cpu")
    step = -(-n // max(1, threads))
    each_on_threads(tile_launches(wp, k.camera_rays, [c, out], per_thread=1, end=False),
                    [(first, min(step, n - first)) for first in range(0, n, step)], threads)
    return out


def ray_directions(cam: CameraState, width: int, height: int, px, py, *, frame: str = "rest") -> np.ndarray:
    """Unit look directions through image positions (``px``, ``py``) in pixels, float64.

    (0, 0) is the image's top-left corner and pixel (i, j)'s centre is (i + 1/2, j + 1/2);
    ``px`` and ``py`` broadcast, and the result has their shape plus a last axis of 3.
    The kernel's ``camera_direction`` in NumPy, in the same order of operations: the
    camera-space ray ((x_ndc hAp/2 + hOff)/f, (y_ndc vAp/2 + vOff)/f, -1), rotated by
    ``cam.rotation`` (lab_from_camera), normalised, and for ``frame="lab"`` aberrated by
    the camera's velocity (relativistic, or Galilean for a decoupled camera). ``frame``:
    one of DIRECTION_FRAMES.
    """
    if frame not in DIRECTION_FRAMES:
        raise ValueError(f"frame must be one of {DIRECTION_FRAMES}, got {frame!r}")
    px, py = np.broadcast_arrays(np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64))
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    f = float(cam.focal_length)
    x = ((2.0 * px / width - 1.0) * 0.5 * h_ap + float(cam.horizontal_aperture_offset)) / f
    y = ((1.0 - 2.0 * py / height) * 0.5 * v_ap + float(cam.vertical_aperture_offset)) / f
    d = np.stack([x, y, -np.ones_like(x)], axis=-1)
    if frame != "camera":
        d = d @ np.asarray(cam.rotation, dtype=np.float64).T
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    if frame == "lab" and np.any(cam.velocity):
        d = aberrate(d, np.asarray(cam.velocity, dtype=np.float64), classical=bool(cam.decoupled))
    return d


def pixel_directions(cam: CameraState, width: int, height: int, *, frame: str = "rest") -> np.ndarray:
    """Unit look directions through every pixel centre, (H, W, 3), row 0 at the top:
    :func:`ray_directions` at (i + 1/2, j + 1/2)."""
    j, i = np.mgrid[0:height, 0:width]
    return ray_directions(cam, width, height, i + 0.5, j + 0.5, frame=frame)
