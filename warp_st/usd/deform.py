"""Deforming gprims sampled through USD (docs/spec.md §2.2).

A mesh deforms when its ``points`` are time-sampled, or when UsdSkel skins it (a
SkelRoot above it, a skeleton bound to it, joint indices on it). Its world points at lab
time t are USD's: ``ComputeLocalToWorldTransform`` at the fractional time code t applied
to the points USD gives at t (linear between point samples). Skinned points are
UsdSkel's own: ``UsdSkel.BakeSkinning`` run once on an in-memory flattened copy of the
stage (the user's layers are never touched), read back at the same prim path; nothing
here re-implements skinning. The samples start at USD's sample times (points and
xformOps) and are refined by bisection until linear interpolation between neighbours
follows USD within ``PROBE_TOLERANCE`` (a rotating transform bends a point's path).
"""
from __future__ import annotations

import math

import numpy as np
from pxr import Tf, Usd, UsdGeom, UsdSkel

from warp_st.core.deform import PointSamples
from warp_st.usd.animation import PROBE_TOLERANCE, xform_sample_times
from warp_st.usd.geometry import world_transform

__all__ = ["points_sample_times", "is_skinned", "SkinnedStage", "sample_surface", "posed_points", "MAX_DEFORM_DEPTH"]

#: At most 2^MAX_DEFORM_DEPTH sample intervals per interval between USD's samples.
MAX_DEFORM_DEPTH = 8


def points_sample_times(prim) -> tuple[float, ...]:
    """USD's sample times of a point-based prim's ``points`` (empty: fewer than two)."""
    if not prim.IsA(UsdGeom.PointBased):
        return ()
    attr = UsdGeom.PointBased(prim).GetPointsAttr()
    if not attr or not attr.ValueMightBeTimeVarying():
        return ()
    return tuple(float(t) for t in attr.GetTimeSamples())


def is_skinned(prim) -> bool:
    """A mesh UsdSkel skins: below a SkelRoot, a skeleton bound (or inherited), joint indices authored."""
    if not prim.IsA(UsdGeom.Mesh) or not UsdSkel.Root.Find(prim):
        return False
    binding = UsdSkel.BindingAPI(prim)
    return bool(binding.GetInheritedSkeleton()) and binding.GetJointIndicesPrimvar().HasAuthoredValue()


class SkinnedStage:
    """The stage's skinned meshes as UsdSkel bakes them, on a flattened in-memory copy
    (made on first use: stages without UsdSkel never pay for it)."""

    def __init__(self, stage: Usd.Stage):
        self.stage = stage
        self._copy = None
        self.failed: dict[str, str] = {}  # SkelRoot path -> why UsdSkel could not bake it

    def prim(self, path):
        """The baked copy's prim at ``path`` (None when its SkelRoot could not be baked)."""
        if self._copy is None:
            copy = Usd.Stage.Open(self.stage.Flatten())
            for prim in copy.Traverse():
                if prim.IsA(UsdSkel.Root):
                    try:
                        baked = UsdSkel.BakeSkinning(UsdSkel.Root(prim))
                    except Tf.ErrorException as exc:
                        self.failed[str(prim.GetPath())] = str(exc).strip().splitlines()[-1]
                        continue
                    if not baked:
                        self.failed[str(prim.GetPath())] = "UsdSkel.BakeSkinning failed"
            self._copy = copy
        prim = self._copy.GetPrimAtPath(path)
        root = UsdSkel.Root.Find(prim) if prim else None
        return None if not prim or root and str(root.GetPath()) in self.failed else prim

    def why(self, prim) -> str:
        """Why ``prim``'s SkelRoot was not baked."""
        root = UsdSkel.Root.Find(prim)
        return self.failed.get(str(root.GetPath()) if root else "", "it is not in the baked copy")


def sample_surface(where, prim, surface, source=None, notes=None) -> PointSamples | None:
    """World points of ``surface`` (read from ``prim``) at USD's sample times, refined (as
    lab times: time codes x ``where.lab_per_code``);
    ``source``: the prim to evaluate (the baked copy's for a skinned mesh; default ``prim``).
    None when nothing moves the points (fewer than two sample times), or when the point
    count changes between samples (a warning in ``notes``: the static points are used)."""
    source = prim if source is None else source
    times = sorted(set(points_sample_times(source)) | set(xform_sample_times(source)))
    if len(times) < 2:
        return None
    n_surface = len(surface.points)
    xformable = UsdGeom.Xformable(source)
    static = where.static if where.static is not None else times[0]
    local_static = _local_of(surface.points, _world(where, source, xformable, static))
    mesh_points = UsdGeom.PointBased(source).GetPointsAttr() if source.IsA(UsdGeom.PointBased) else None
    remap = None
    if mesh_points is not None and points_sample_times(source):
        raw = _raw_points(mesh_points, static)
        if n_surface != len(raw):  # per-corner normals: one surface point per face corner
            remap = np.asarray(UsdGeom.Mesh(source).GetFaceVertexIndicesAttr().Get(where.time), dtype=np.int64)
        counts = {len(_raw_points(mesh_points, t)) for t in points_sample_times(source)}
        if counts != {len(raw)}:
            if notes is not None:
                notes.warn(prim, "points", f"the point count changes between time samples ({sorted(counts)}); "
                                           f"every frame uses the points at time code {static:g}", "TimeSampled")
            return None
    else:
        mesh_points = None

    def evaluate(t: float) -> np.ndarray:
        local = local_static
        if mesh_points is not None:
            local = _raw_points(mesh_points, t)
            local = local if remap is None else local[remap]
        m = _world(where, source, xformable, t)
        return local @ m[:3, :3] + m[3, :3]

    out_t, out_p = [times[0]], [evaluate(times[0])]
    for a, b in zip(times[:-1], times[1:]):
        pb = evaluate(b)
        _refine(evaluate, a, b, out_p[-1], pb, 0, out_t, out_p)
        out_t.append(b)
        out_p.append(pb)
    # lab time = the stage's light speed x time code (docs/spec.md §1)
    return PointSamples(times=where.lab_per_code * np.array(out_t, dtype=np.float64),
                        points=np.array(out_p, dtype=np.float64))


def posed_points(where, source, surface) -> np.ndarray | None:
    """A skinned mesh's world points at the start time code as UsdSkel baked them (a
    skeleton posed but not animated: no samples), in ``surface``'s point order; None when
    the counts do not match."""
    t = where.static if where.static is not None else 0.0
    raw = _raw_points(UsdGeom.PointBased(source).GetPointsAttr(), t)
    if len(raw) != len(surface.points):  # per-corner normals: one surface point per face corner
        indices = np.asarray(UsdGeom.Mesh(source).GetFaceVertexIndicesAttr().Get(where.time), dtype=np.int64)
        if len(indices) != len(surface.points) or (len(indices) and indices.max() >= len(raw)):
            return None
        raw = raw[indices]
    m = _world(where, source, UsdGeom.Xformable(source), t)
    return raw @ m[:3, :3] + m[3, :3]


def _raw_points(attr, t: float) -> np.ndarray:
    value = attr.Get(Usd.TimeCode(t))
    return np.zeros((0, 3)) if value is None else np.asarray(value, dtype=np.float64).reshape(-1, 3)


def _world(where, prim, xformable, t: float) -> np.ndarray:
    tc = Usd.TimeCode(t)
    m = world_transform(where, prim, lambda: xformable.ComputeLocalToWorldTransform(tc), tc)
    return np.array(m, dtype=np.float64).reshape(4, 4)


def _local_of(world_points, m: np.ndarray) -> np.ndarray:
    """The local points that ``m`` (row vectors) takes to ``world_points``."""
    return np.linalg.solve(m[:3, :3].T, (np.asarray(world_points, dtype=np.float64) - m[3, :3]).T).T


def _refine(evaluate, a, b, pa, pb, depth, times, points) -> None:
    """Append the samples strictly inside (a, b) that linear interpolation needs."""
    if depth >= MAX_DEFORM_DEPTH:
        return
    inner = [(f, evaluate(a + f * (b - a))) for f in (0.25, 0.5, 0.75)]
    scale = PROBE_TOLERANCE * (1.0 + max(float(np.abs(pa).max(initial=0.0)), float(np.abs(pb).max(initial=0.0))))
    if all(float(np.abs(p - (pa + f * (pb - pa))).max(initial=0.0)) <= scale for f, p in inner):
        return
    m, pm = a + 0.5 * (b - a), inner[1][1]
    if not (math.isfinite(m) and a < m < b):
        return
    _refine(evaluate, a, m, pa, pm, depth + 1, times, points)
    times.append(m)
    points.append(pm)
    _refine(evaluate, m, b, pm, pb, depth + 1, times, points)
