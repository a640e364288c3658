"""Bodies animated in their own rest frame: ``spacetime:animationFrame`` (docs/spec.md §2.1, addition 0.7.0).

With ``"rest"`` a Lorentz-coupled ``SpacetimeBodyAPI`` body's time-sampled xformOps (and
time-sampled points) are its motion in the frame S' moving with its
``spacetime:fourVelocity``, their time codes S'’s time t' (t' = stage light speed x time
code, 0 at the lab event (``spacetime:referenceTime``, the pivot)). Each surface is
sampled through USD as a deforming surface is (``usd.deform.sample_surface``: world points
at USD's sample times, refined until linear interpolation follows USD), read as rest-frame
positions, checked below c, and boosted to common lab times (``core.rest_frame``). The
body is then a deforming body (§2.2): its points are lab positions, their contraction
already in them.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from pxr import UsdGeom

from warp_st.core.deform import PointSamples
from warp_st.core.rest_frame import (
    BEND_TOLERANCE,
    MAX_BEND_LEVELS,
    bend_edges,
    edge_bends,
    lab_samples,
    midpoint_subdivide,
    rest_speeds,
)
from warp_st.usd import attributes as A
from warp_st.usd.animation import animated_op, xform_sample_times
from warp_st.usd.deform import points_sample_times, sample_surface

__all__ = ["ANIMATION_FRAME", "FRAMES", "animation_frame", "rest_frame_surfaces"]

ANIMATION_FRAME = "spacetime:animationFrame"
#: Most rest-sample values (times x points x 3) a surface may be subdivided to (160 MB).
MAX_SUBDIVIDED_VALUES = 20_000_000
#: "lab": the animation is lab-frame kinematics (§2.1); "rest": it is the body's own rest frame's.
FRAMES = ("lab", "rest")


def animation_frame(where: A.Where, prim, decoupled: bool) -> str:
    """The validated ``spacetime:animationFrame`` of a ``SpacetimeBodyAPI`` prim ("lab" unless
    authored); "rest" on a Lorentz-decoupled body is bad input (it has no rest frame)."""
    frame = A.token(where, prim, ANIMATION_FRAME, FRAMES, "lab")
    if frame == "rest" and decoupled:
        raise where.error(prim, ANIMATION_FRAME, '"rest" needs a Lorentz-coupled body (a decoupled body has '
                                                 "no rest frame); unset spacetime:lorentzDecoupled or use \"lab\"")
    return frame


def _rest_samples(where: A.Where, stage, surface, notes) -> PointSamples:
    """The surface's points in S' at rest times (lab units), at least two samples."""
    if surface.samples is not None:  # time-sampled points: already sampled through USD
        return surface.samples
    prim = stage.GetPrimAtPath(surface.prim_path)
    if prim and prim.IsA(UsdGeom.Gprim):
        samples = sample_surface(where, prim, surface)
        if samples is not None:
            return samples
    else:
        notes.warn(surface.prim_path, None, "an instance in a body animated in its rest frame: it does not follow "
                                            "the animation (it rests in the body's frame)", "NotHonoured")
    t = where.lab_per_code * (where.static or 0.0)
    points = np.asarray(surface.points, dtype=np.float64)
    return PointSamples(times=np.array([t, t + 1.0]), points=np.stack([points, points]))


def _check_speed(where: A.Where, stage, surface, rest: PointSamples) -> None:
    """A point at >= c in S' is bad input: one line naming what moves it."""
    speeds = rest_speeds(rest)
    if not speeds.size or not float(speeds.max()) >= 1.0:
        return
    k = int(np.argmax(speeds))
    prim = stage.GetPrimAtPath(surface.prim_path)
    owner, op = (prim, "points") if points_sample_times(prim) else animated_op(prim)
    a, b = (float(t) / where.lab_per_code for t in rest.times[k:k + 2])  # refined samples: USD's around them
    usd = sorted(set(points_sample_times(prim)) | set(xform_sample_times(prim))) or [a, b]
    lo, hi = max([s for s in usd if s <= a] or [a]), min([s for s in usd if s >= b] or [b])
    raise where.error(owner, op, f"a point of the body moves at {float(speeds[k]):.6g} c in its rest frame "
                                 f"(spacetime:animationFrame = \"rest\") between time codes {lo:g} and {hi:g} "
                                 "(>= the speed of light); slow the animation")


def rest_frame_surfaces(where: A.Where, stage, body, notes) -> list:
    """``body``'s surfaces (a reader ``_BodyBuilder`` with ``origin``, ``velocity``,
    ``reference_time``) with lab ``samples`` boosted from their rest-frame motion, each cut
    (midpoint subdivision) until its edges' lab bend is estimated within BEND_TOLERANCE x
    the body's size (a bend quarters per level), at most MAX_BEND_LEVELS times."""
    surfaces = list(body.surfaces)
    rest = [_rest_samples(where, stage, s, notes) for s in surfaces]
    for surface, samples in zip(surfaces, rest):
        _check_speed(where, stage, surface, samples)
    every = np.concatenate([r.points.reshape(-1, 3) for r in rest])
    size = float(np.max(every.max(axis=0) - every.min(axis=0))) if len(every) else 0.0
    labs = lab_samples(rest, body.origin, body.velocity, body.reference_time, size)
    edges = [bend_edges(s, r, body.velocity) for s, r in zip(surfaces, rest)]
    bends = edge_bends(rest, labs, edges, body.origin, body.velocity, body.reference_time)
    tol = BEND_TOLERANCE * max(size, 1e-12)
    levels = [min(MAX_BEND_LEVELS, max(0, math.ceil(math.log(b / tol, 4)))) if b > tol else 0 for b in bends]
    for i, r in enumerate(rest):  # a level quadruples the points (and their samples): within the budget
        while levels[i] and r.points.size * 4 ** levels[i] > MAX_SUBDIVIDED_VALUES:
            levels[i] -= 1
    for i, level in enumerate(levels):
        for _ in range(level):
            surfaces[i], rest[i] = midpoint_subdivide(surfaces[i], rest[i])
    cut = [i for i, level in enumerate(levels) if level]  # at the lab times their first vertices needed
    for i, lab in zip(cut, lab_samples([rest[i] for i in cut], body.origin, body.velocity, body.reference_time,
                                       size, grid=labs[0].times)):
        labs[i] = lab
    left = max((b / 4.0 ** level for b, level in zip(bends, levels)), default=0.0)
    notes.info(body.prim_path, ANIMATION_FRAME, f"animated in its rest frame: {len(labs[0].times)} lab samples; "
                                                f"surfaces cut {max(levels, default=0)} time(s) for the bend of "
                                                f"simultaneity (largest {max(bends, default=0.0):.3g}, now about "
                                                f"{left:.3g}; tolerance {tol:.3g})", "RestFrame")
    if left > 4.0 * tol:  # more than a level short (the subdivision budget): visible at fine resolutions
        notes.warn(body.prim_path, ANIMATION_FRAME, f"the lab slices of its edges bend by about {left:.3g} off the "
                                                    f"drawn edges (> {tol:.3g}): refine the mesh", "RestFrameBend")
    t_static = where.lab_per_code * (where.static or 0.0)
    return [dataclasses.replace(surface, samples=lab, points=lab.at(t_static), sphere=None, quadric=None)
            for surface, lab in zip(surfaces, labs)]
