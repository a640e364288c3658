"""A body's motion from USD animation, sampled once by the reader (docs/spec.md §2.1).

Backend-free: the USD reader fills it through USD's own interpolation, the renderer turns
it into pieces of uniform motion (``warp_st.spacetime.animation``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from warp_st.core.lorentz import contraction_matrix

__all__ = ["BodyMotion", "velocity_gradient"]


def velocity_gradient(linear: np.ndarray, rate: np.ndarray, velocity: np.ndarray, decoupled: bool) -> np.ndarray:
    """W, (3, 3), column vectors: the velocity relative to the pivot of the body point at
    offset y from it is W y, for a body held at y = r L A (row vectors, r the authored
    offset, A = A(velocity) of §2, I decoupled) while L changes at ``rate`` = dL/dt:
    r L' A = y A^-1 L^-1 L' A, so W = (A^-1 L^-1 L' A)^T (docs/spec.md §2.1, Doppler)."""
    a = contraction_matrix(velocity, decoupled)
    return (np.linalg.solve(a, np.linalg.solve(linear, rate)) @ a).T


@dataclass(frozen=True, eq=False)
class BodyMotion:
    """Probes of a rigid body's animated worldline, lab frame, float64.

    times: lab times of the probes, increasing, (N,) with N >= 2: USD's sample times of
        every time-sampled xformOp of the body's prim and its ancestors, refined until
        linear interpolation between neighbours follows USD within ``PROBE_TOLERANCE``;
    pivot: the pivot o(t) at each probe (``spacetime:fourVelocity``'s uniform motion
        added), (N, 3);
    linear: L(t), (N, 3, 3): a body point p authored at the start time code is at
        o(t) + (p - o(t_s)) @ L(t) (row vectors);
    static_pivot: o(t_s), the pivot the surfaces' points are authored about, (3,);
    sample_times: USD's own sample times (for messages and reports);
    hold_velocity: the pivot's velocity before the first and after the last probe
        (``spacetime:fourVelocity``'s v; zero without it: USD holds the values).
    """

    times: np.ndarray
    pivot: np.ndarray
    linear: np.ndarray
    static_pivot: np.ndarray
    sample_times: tuple
    hold_velocity: np.ndarray

    def at(self, t: np.ndarray):
        """(pivot, linear) at lab times ``t`` within [times[0], times[-1]], interpolated
        linearly between the probes (within PROBE_TOLERANCE of USD), (K, 3) and (K, 3, 3)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
        f = ((t - self.times[k]) / (self.times[k + 1] - self.times[k]))[:, None]
        pivot = self.pivot[k] + f * (self.pivot[k + 1] - self.pivot[k])
        linear = self.linear[k] + f[:, :, None] * (self.linear[k + 1] - self.linear[k])
        return pivot, linear

    def chord_velocities(self) -> np.ndarray:
        """The pivot's velocity between neighbouring probes, (N - 1, 3)."""
        return np.diff(self.pivot, axis=0) / np.diff(self.times)[:, None]

    def point_speeds(self, points: np.ndarray, decoupled: bool) -> np.ndarray:
        """The largest lab speed of the body points ``points`` (authored at the start time
        code, (P, 3)) in each probe interval, (N - 1,): between probes a point moves with
        v_k + (p - o(t_s)) L'_k A(v_k), v_k the chord velocity and L'_k the interval's
        constant rate of L (the probes' linear interpolation)."""
        r = np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.static_pivot
        v = self.chord_velocities()
        rate = np.diff(self.linear, axis=0) / np.diff(self.times)[:, None, None]
        out = np.linalg.norm(v, axis=1)
        if not len(r):
            return out
        for k in range(len(v)):
            u = v[k] + r @ (rate[k] @ contraction_matrix(v[k], decoupled))
            out[k] = float(np.sqrt(np.einsum("ij,ij->i", u, u).max()))
        return out
