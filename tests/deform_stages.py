"""Helpers (not tests): small stages whose meshes USD deforms (docs/spec.md §2.2), and the
oracle that measures a lab event's distance from USD's own interpolated surface."""
from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel

from animation_stages import HEADER as _PLAIN

#: ``animation_stages.HEADER`` with its camera applying SpacetimeCameraAPI: the stage uses
#: our schemas, so its light speed is 1 stage unit per time code (docs/spec.md §1).
HEADER = _PLAIN.replace('def Camera "Cam"\n', 'def Camera "Cam" (prepend apiSchemas = ["SpacetimeCameraAPI"])\n', 1)
assert HEADER != _PLAIN


def _points(values) -> str:
    return "[" + ", ".join(f"({float(x)!r}, {float(y)!r}, {float(z)!r})" for x, y, z in np.asarray(values)) + "]"


def grid(nx: int, ny: int, width: float, height: float) -> tuple[np.ndarray, list, list]:
    """An nx x ny grid of points in the XY plane centred on the origin, its quads' counts and indices."""
    xs, ys = np.linspace(-width / 2, width / 2, nx), np.linspace(-height / 2, height / 2, ny)
    pts = np.array([(x, y, 0.0) for y in ys for x in xs])
    indices = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i
            indices += [a, a + 1, a + nx + 1, a + nx]
    return pts, [4] * ((nx - 1) * (ny - 1)), indices


def mesh_stage(name: str, samples: dict, counts, indices, extra: str = "", header: str = HEADER,
               schemas: tuple = ()) -> str:
    """A stage with the camera of ``HEADER`` and one Mesh /``name`` whose points are time-sampled
    (``schemas``: API schemas it applies; ``extra``: more of its attributes)."""
    body = ",\n        ".join(f"{t!r}: {_points(p)}" for t, p in samples.items())
    api = " (prepend apiSchemas = [" + ", ".join(f'"{x}"' for x in schemas) + "])" if schemas else ""
    return header + f'''def Mesh "{name}"{api}
{{
    {extra}
    point3f[] points.timeSamples = {{
        {body}
    }}
    int[] faceVertexCounts = {list(counts)}
    int[] faceVertexIndices = {list(indices)}
}}
'''


def translating_quad_stages(extra: str = "", *, start=(-30.0, 0.0, 0.0), velocity=(0.6, 0.0, 0.0), inside: str = "",
                            schemas: tuple = (), yaw: float = 0.0) -> tuple[str, str]:
    """Two stages: a 3 x 2 quad grid (in the XY plane turned ``yaw`` degrees about +Y, its
    centre at ``start`` at time 0) whose points are sampled at 0 and 100 moved by 100
    ``velocity``, and its twin at time 0 moved by spacetime:fourVelocity (1, velocity),
    decoupled. ``extra``: more prims for both; ``inside``, ``schemas``: more attributes and
    API schemas of the quad in both."""
    pts, counts, indices = grid(4, 3, 3.0, 2.0)
    c, s = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
    pts = pts @ np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]]) + np.asarray(start, dtype=np.float64)
    v = [float(x) for x in velocity]
    deforming = mesh_stage("Quad", {0.0: pts, 100.0: pts + 100.0 * np.array(v)}, counts, indices, inside, schemas=schemas)
    twin = (f"custom double4 spacetime:fourVelocity = (1, {v[0]!r}, {v[1]!r}, {v[2]!r})\n"
            f"    custom bool spacetime:lorentzDecoupled = true\n    {inside}")
    uniform = mesh_stage("Quad", {0.0: pts}, counts, indices, twin, schemas=("SpacetimeBodyAPI", *schemas))
    return deforming + extra, uniform + extra


def flag_samples(t_end: float = 20.0):
    """A 9 x 5 flag 4 wide and 2 high whose points move at different speeds: at ``t_end``
    each is lifted along Z by a wave and its right half pushed along +X (time samples 0 and t_end)."""
    pts, counts, indices = grid(9, 5, 4.0, 2.0)
    moved = pts.copy()
    moved[:, 2] += 1.2 * np.sin(1.6 * pts[:, 0]) * (0.5 + 0.25 * pts[:, 1])
    moved[:, 0] += 0.3 * np.maximum(pts[:, 0], 0.0)
    return {0.0: pts, t_end: moved}, counts, indices


def skinned_box_stage(path: str) -> str:
    """A SkelRoot /Arm: a 0.4 x 2 x 0.4 box (three rings of four points, sides only) skinned
    to two joints; the upper joint (at y = 1) turns 60 degrees about Z between time codes 0
    and 10 (a SkelAnimation). The camera of ``HEADER`` looks at it. Written with USD's API."""
    stage = Usd.Stage.CreateNew(path)
    stage.GetRootLayer().ImportFromString(HEADER)
    root = UsdSkel.Root.Define(stage, "/Arm")
    root.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    skel = UsdSkel.Skeleton.Define(stage, "/Arm/Skel")
    joint = [Gf.Matrix4d(1), Gf.Matrix4d(1).SetTranslate(Gf.Vec3d(0, 1, 0))]
    skel.CreateJointsAttr(["lower", "lower/upper"])
    skel.CreateBindTransformsAttr(joint)
    skel.CreateRestTransformsAttr(joint)
    anim = UsdSkel.Animation.Define(stage, "/Arm/Skel/Bend")
    anim.CreateJointsAttr(["lower", "lower/upper"])
    anim.CreateTranslationsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(0, 1, 0)])
    anim.CreateScalesAttr().Set([Gf.Vec3h(1, 1, 1), Gf.Vec3h(1, 1, 1)])
    rotations = anim.CreateRotationsAttr()
    rotations.Set([Gf.Quatf(1, 0, 0, 0), Gf.Quatf(1, 0, 0, 0)], 0.0)
    rotations.Set([Gf.Quatf(1, 0, 0, 0), Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), 60).GetQuat())], 10.0)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    mesh = UsdGeom.Mesh.Define(stage, "/Arm/Box")
    ring = [(-0.2, -0.2), (0.2, -0.2), (0.2, 0.2), (-0.2, 0.2)]
    pts = [(x, y, z) for y in (0.0, 1.0, 2.0) for x, z in ring]
    indices = []
    for level in range(2):
        for i in range(4):
            a, b = level * 4 + i, level * 4 + (i + 1) % 4
            indices += [a, b, b + 4, a + 4]
    mesh.CreatePointsAttr(pts)
    mesh.CreateFaceVertexCountsAttr([4] * 8)
    mesh.CreateFaceVertexIndicesAttr(indices)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateJointIndicesPrimvar(False, 1).Set([0 if p[1] < 1.0 else 1 for p in pts])
    binding.CreateJointWeightsPrimvar(False, 1).Set([1.0] * len(pts))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(100)
    stage.GetRootLayer().Save()
    return path


def point_triangle_distance(x: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance of point ``x`` (3,) from each triangle of ``tri`` (T, 3, 3): to its plane
    where the foot lies inside it, else to the nearest of its three edges."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    height = np.einsum("ij,ij->i", x - a, n)
    foot = x - height[:, None] * n
    inside = np.ones(len(tri), bool)
    for p, q in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(q - p, foot - p), n) >= 0.0
    best = np.where(inside, np.abs(height), np.inf)
    for p, q in ((a, b), (b, c), (c, a)):
        e = q - p
        f = np.clip(np.einsum("ij,ij->i", x - p, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(x - (p + f[:, None] * e), axis=1))
    return best


def usd_surface_distance(stage, prim_path: str, times, points) -> np.ndarray:
    """Distance of each lab point from the mesh ``prim_path`` of ``stage`` as USD gives it at
    the point's (fractional) time code: its points (USD interpolates them linearly) through
    ComputeLocalToWorldTransform there, fan-triangulated."""
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(prim_path))
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get())
    indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get())
    tris, start = [], 0
    for count in counts:
        tris += [(indices[start], indices[start + k], indices[start + k + 1]) for k in range(1, count - 1)]
        start += count
    tris = np.array(tris)
    out = []
    for t, x in zip(times, points):
        tc = Usd.TimeCode(float(t))
        m = np.array(mesh.ComputeLocalToWorldTransform(tc), dtype=np.float64)
        world = np.asarray(mesh.GetPointsAttr().Get(tc), dtype=np.float64) @ m[:3, :3] + m[3, :3]
        out.append(float(point_triangle_distance(np.asarray(x, dtype=np.float64), world[tris]).min()))
    return np.array(out)
