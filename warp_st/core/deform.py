"""Deforming surfaces: world-space points at USD's sample times (docs/spec.md §2.2).

Backend-free: the USD reader fills :class:`PointSamples` through USD's own evaluation
(time-sampled ``points``, UsdSkel's ``BakeSkinning``, the world transform at each time
code), so a pickled scene needs no stage; the extrusion (``warp_st.spacetime.deform``)
slices it into prisms of three tetrahedra each.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PointSamples", "deforming", "surface_hull_points"]


@dataclass(frozen=True, eq=False)
class PointSamples:
    """A surface's world-space points, lab frame, float64, at lab times ``times``.

    times: increasing lab times (the stage's light speed x time codes), (N,) with N >= 2:
        USD's sample times of the points and of every xformOp above them, refined until
        linear interpolation between neighbours follows USD (a rotating transform bends a
        point's path between samples);
    points: the surface's points at each time, (N, P, 3), in the order of
        ``Surface.points`` (``spacetime:fourVelocity``'s uniform motion not included).
    Between the times a point moves linearly; before the first and after the last it is
    held, as USD holds values.
    """

    times: np.ndarray
    points: np.ndarray

    def at(self, t: float) -> np.ndarray:
        """The points at lab time ``t``, (P, 3): linear between the samples, held outside."""
        times = self.times
        if t <= times[0]:
            return self.points[0].copy()
        if t >= times[-1]:
            return self.points[-1].copy()
        k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2))
        f = (t - times[k]) / (times[k + 1] - times[k])
        return self.points[k] + f * (self.points[k + 1] - self.points[k])


def deforming(body) -> bool:
    """True when a surface of ``body`` carries point samples (it is traced on the tet path)."""
    return any(getattr(s, "samples", None) is not None for s in body.surfaces)


def surface_hull_points(surface) -> np.ndarray:
    """Every position a surface's points take (its samples' and its own), (M, 3): a ball
    or box holding them holds the surface at every lab time (before the body's uniform motion)."""
    pts = np.asarray(surface.points, dtype=np.float64).reshape(-1, 3)
    samples = getattr(surface, "samples", None)
    if samples is None:
        return pts
    return np.concatenate([pts, np.asarray(samples.points, dtype=np.float64).reshape(-1, 3)])
