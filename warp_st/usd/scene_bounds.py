"""The world bounds a stage without a camera is framed by (docs/spec.md §3, the default camera)."""
from __future__ import annotations

import numpy as np

from warp_st.core.deform import surface_hull_points

__all__ = ["scene_bounds"]


def _box_corners(points: np.ndarray) -> np.ndarray:
    """The 8 corners of the axis-aligned box of ``points`` (P, 3), (8, 3)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    pick = (np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1
    return np.where(pick == 1, hi, lo)


def scene_bounds(bodies, stage) -> tuple[np.ndarray, np.ndarray]:
    """World bounds of every triangle's vertices over the stage's time-code range (lab time =
    time code for a camera at rest): a uniformly moving body's at both ends of the range, an
    animated rigid body's (``Body.motion``) turned and moved to every probe of its worldline
    (the box of its points about the pivot under each L(t): a turning body stays in frame), a
    deforming surface's at every sample; a body at rest's as authored."""
    times = {float(stage.GetStartTimeCode()), float(stage.GetEndTimeCode())}
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for body in bodies:
        shifts = [np.zeros(3)] if not body.velocity.any() else [body.velocity * (t - body.reference_time)
                                                                  for t in times]
        for surface in body.surfaces:
            used = np.unique(surface.triangles)
            if not len(used):
                continue
            points = surface.points[used] if getattr(surface, "samples", None) is None else surface_hull_points(surface)
            with np.errstate(over="ignore", invalid="ignore"):
                moved = [points + shift for shift in shifts]
                m = body.motion
                if m is not None:  # every probe: o(t) + (p - o(t_s)) L(t), on the corners of the box
                    corners = _box_corners(np.asarray(points, dtype=np.float64)) - m.static_pivot
                    moved.append((np.einsum("cj,njk->nck", corners, m.linear) + m.pivot[:, None, :]).reshape(-1, 3))
                for pts in moved:
                    lo, hi = np.fmin(lo, pts.min(axis=0)), np.fmax(hi, pts.max(axis=0))
    return lo, hi
