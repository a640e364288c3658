"""Rigid motion from time-sampled xformOps, sampled through USD's own interpolation (docs/spec.md §2.1).

A body is animated when an xformOp of its prim or of an ancestor has time samples. Its
world transform M(t) is USD's ``ComputeLocalToWorldTransform`` at the fractional time code
t (lab time = time code); the probes start at USD's sample times and are refined until
linear interpolation between neighbours follows USD within PROBE_TOLERANCE (a slerped
``orient`` or a rotating ancestor bends the pivot's path between samples). The renderer
turns the probes into pieces of uniform motion (``warp_st.spacetime.animation``).
"""
from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdGeom

from warp_st.core.motion import BodyMotion
from warp_st.usd.attributes import Where
from warp_st.usd.geometry import world_transform

__all__ = ["xform_sample_times", "sample_motion", "PROBE_TOLERANCE", "MAX_PROBE_DEPTH"]

#: Probes are refined until linear interpolation between neighbours is within this of USD's
#: value at the quarter points: relative to (1 + |pivot|) for positions, absolutely for the
#: linear part L (a fraction of the body's size once applied to it).
PROBE_TOLERANCE = 1.0e-5
#: At most 2^MAX_PROBE_DEPTH probe intervals per interval between USD samples.
MAX_PROBE_DEPTH = 12


def xform_sample_times(prim) -> tuple[float, ...]:
    """USD's sample times of every xformOp of ``prim`` and its ancestors, sorted, distinct."""
    times: set[float] = set()
    p = prim
    while p and not p.IsPseudoRoot():
        if p.IsA(UsdGeom.Xformable):
            times.update(float(t) for t in UsdGeom.Xformable(p).GetTimeSamples())
        p = p.GetParent()
    return tuple(sorted(times))


def animated_op(prim):
    """(the prim, the xformOp attribute name) of the first time-sampled xformOp of ``prim``,
    else of its nearest ancestor with one: what moves it. (prim, "xformOpOrder") if none."""
    p = prim
    while p and not p.IsPseudoRoot():
        if p.IsA(UsdGeom.Xformable):
            for op in UsdGeom.Xformable(p).GetOrderedXformOps():
                if op.GetNumTimeSamples() > 1:
                    return p, op.GetName()
        p = p.GetParent()
    return prim, "xformOpOrder"


def sample_motion(where: Where, prim, velocity: np.ndarray, reference_time: float,
                  samples: tuple[float, ...]) -> BodyMotion:
    """The probes of ``prim``'s animated worldline over USD's ``samples`` (>= 2 time codes), the
    uniform motion ``velocity`` (from the lab time ``reference_time``) added; the probes' times
    are lab times (time codes x ``where.lab_per_code``)."""
    xformable = UsdGeom.Xformable(prim)
    v = np.asarray(velocity, dtype=np.float64)

    def evaluate(t: float):
        tc = Usd.TimeCode(t)
        m = np.array(world_transform(where, prim, lambda: xformable.ComputeLocalToWorldTransform(tc), tc),
                     dtype=np.float64).reshape(4, 4)
        return m

    static = evaluate(where.static if where.static is not None else samples[0])
    static_inv = np.linalg.inv(static)

    k = where.lab_per_code  # probe times are time codes until the end; lab time = k x time code

    def probe(t: float):
        m = evaluate(t)
        return m[3, :3] + v * (k * t - reference_time), (static_inv @ m)[:3, :3]

    times, pivots, linears = [samples[0]], [], []
    o0, l0 = probe(samples[0])
    pivots.append(o0)
    linears.append(l0)
    for a, b in zip(samples[:-1], samples[1:]):
        ob, lb = probe(b)
        _refine(probe, a, b, pivots[-1], linears[-1], ob, lb, 0, times, pivots, linears)
        times.append(b)
        pivots.append(ob)
        linears.append(lb)
    return BodyMotion(times=k * np.array(times), pivot=np.array(pivots), linear=np.array(linears),
                      static_pivot=static[3, :3].copy(), sample_times=tuple(samples), hold_velocity=v.copy())


def _refine(probe, a, b, oa, la, ob, lb, depth, times, pivots, linears) -> None:
    """Append the probes strictly inside (a, b) that linear interpolation needs."""
    if depth >= MAX_PROBE_DEPTH:
        return
    inner = [(a + f * (b - a), *probe(a + f * (b - a))) for f in (0.25, 0.5, 0.75)]
    scale = PROBE_TOLERANCE * (1.0 + max(float(np.abs(oa).max()), float(np.abs(ob).max())))
    linear_ok = all(
        float(np.abs(o - (oa + f * (ob - oa))).max()) <= scale
        and float(np.abs(lin - (la + f * (lb - la))).max()) <= PROBE_TOLERANCE
        for f, (_, o, lin) in zip((0.25, 0.5, 0.75), inner))
    if linear_ok:
        return
    m, om, lm = inner[1]
    if not (math.isfinite(m) and a < m < b):
        return
    _refine(probe, a, m, oa, la, om, lm, depth + 1, times, pivots, linears)
    times.append(m)
    pivots.append(om)
    linears.append(lm)
    _refine(probe, m, b, om, lm, ob, lb, depth + 1, times, pivots, linears)
