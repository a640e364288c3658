"""Float64 kinematics derived a second way, to check warp_st.core.lorentz and the renderer
without calling the functions they are made of.

- The boost is the exponential of its generator, Λ(v) = exp(-φ K), φ = artanh|v|,
  K = [[0, v̂ᵀ], [v̂, 0]], summed as a Taylor series after scaling by 2^-m and squared back
  m times (no closed-form cosh/sinh or γ²/(1 + γ) as in ``lorentz.boost``). Float64: the
  series converges to round-off, each squaring roughly doubles the relative error, so the
  entries are good to ~2^m eps γ² at worst (m = 4 + log2 φ).
- Proper time: the time coordinate of the event in the body's rest frame whose origin is
  the event (t_ref, o): the first row of Λ applied to E - (t_ref, o) (docs/spec.md §2).
- Doppler: D = (k·u_cam) / (k·u_body) with k the photon's 4-momentum read off the light's
  path from the emission event to the camera event (not the look direction), u the
  4-velocities as the first columns of Λ(-v) (lab_from_rest), Minkowski products written
  out with the (-, +, +, +) signature.
"""
from __future__ import annotations

import numpy as np


def _generator(v_hat: np.ndarray) -> np.ndarray:
    """K (..., 4, 4): the boost generator along the unit vector v̂."""
    k = np.zeros(v_hat.shape[:-1] + (4, 4))
    k[..., 0, 1:] = v_hat
    k[..., 1:, 0] = v_hat
    return k


def boost_by_exponential(v) -> np.ndarray:
    """rest_from_lab for lab velocities v (..., 3), |v| < 1: exp(-artanh(|v|) K(v̂))."""
    v = np.asarray(v, dtype=np.float64)
    speed = np.linalg.norm(v, axis=-1)
    v_hat = np.where(speed[..., None] > 0, v / np.where(speed > 0, speed, 1.0)[..., None], 0.0)
    phi = np.arctanh(speed)
    m = int(np.ceil(np.log2(max(float(np.max(phi, initial=0.0)), 1.0)))) + 4  # |scaled φ| <= 1/16
    a = -(phi / 2.0**m)[..., None, None] * _generator(v_hat)
    term = np.broadcast_to(np.eye(4), a.shape).copy()
    total = term.copy()
    for n in range(1, 20):  # (1/16)^20 / 20! is far below round-off
        term = term @ a / n
        total = total + term
    for _ in range(m):
        total = total @ total
    return total


def minkowski(a, b) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return -a[..., 0] * b[..., 0] + np.sum(a[..., 1:] * b[..., 1:], axis=-1)


def rest_frame_event(event, origin_event, v) -> np.ndarray:
    """Coordinates (..., 4) of the lab event in the frame moving with v whose origin is ``origin_event``."""
    d = np.asarray(event, dtype=np.float64) - np.asarray(origin_event, dtype=np.float64)
    return np.einsum("...ij,...j->...i", boost_by_exponential(v), d)


def proper_time(event, origin, t_ref, v, *, decoupled: bool = False) -> np.ndarray:
    """docs/spec.md §2 proper time of a body at the lab event (..., 4): coupled, the rest-frame
    time of the event; decoupled, lab time since t_ref."""
    event = np.asarray(event, dtype=np.float64)
    if decoupled:
        return event[..., 0] - t_ref
    o = np.concatenate([[float(t_ref)], np.asarray(origin, dtype=np.float64)])
    return rest_frame_event(event, o, v)[..., 0]


def four_velocity(v, *, decoupled: bool = False) -> np.ndarray:
    """u (..., 4): the rest frame's time axis in the lab, Λ(-v) e_t; (1, v) when decoupled."""
    v = np.asarray(v, dtype=np.float64)
    if decoupled:
        return np.concatenate([np.ones(v.shape[:-1] + (1,)), v], axis=-1)
    return boost_by_exponential(-v)[..., :, 0]


def doppler(event, cam_event, u_body, u_cam, *, light_speed: str = "finite") -> np.ndarray:
    """Received / emitted frequency of light from ``event`` to ``cam_event`` (both (..., 4)).

    Finite light speed: the photon runs along the null separation cam_event - event, so
    k ∝ that separation (any positive scale cancels). Infinite: the c → ∞ limit of a signal
    along the same spatial path, k → (1, 0, 0, 0)."""
    sep = np.asarray(cam_event, dtype=np.float64) - np.asarray(event, dtype=np.float64)
    if light_speed == "infinite":
        sep = np.concatenate([np.ones(sep.shape[:-1] + (1,)), np.zeros(sep.shape[:-1] + (3,))], axis=-1)
    return minkowski(sep, u_cam) / minkowski(sep, u_body)
