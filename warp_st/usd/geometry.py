"""Gprims → world-space triangle surfaces (materials: ``warp_st.usd.materials``).

Everything is read once at the stage's static time code (``Where.time``: the 4D
database never changes between frames) and returned in float64 world space at the
body's reference time (docs/spec.md §2). USD matrices act on row vectors:
``p_world = p_local @ M[:3, :3] + M[3, :3]``.

Read: Mesh (polygons fan-triangulated, holes removed; a subdivision surface renders its
control cage), Sphere, Cube, Cylinder, Cone, Capsule (and Cylinder_1 / Capsule_1) and
Plane (``warp_st.core.tessellate``), PointInstancer. Other gprims (Points, curves,
patches, volumes) are skipped with a warning; so is every authored thing not honoured
(``warp_st.usd.diagnostics.check_prim``, run on each gprim and its ancestors).
"""
from __future__ import annotations

import numpy as np
from pxr import Gf, Tf, Usd, UsdGeom

from warp_st.core import tessellate
from warp_st.core.limits import MAX_MAGNITUDE
from warp_st.core.scene import SceneError, Surface
from warp_st.usd import attributes as A
from warp_st.usd.attributes import DEFAULT_TIME, Where
from warp_st.usd.diagnostics import Notes, check_prim
from warp_st.usd.materials import MaterialReader
from warp_st.usd.textures import corner_st

__all__ = [
    "SUPPORTED_GPRIMS",
    "is_hidden",
    "fan_triangulate",
    "transform_surface",
    "GprimReader",
    "world_transform",
]

#: The gprim types turned into surfaces (docs/spec.md §2). Other gprims are skipped with a warning.
SUPPORTED_GPRIMS = (UsdGeom.Mesh, UsdGeom.Sphere, UsdGeom.Cube, UsdGeom.Cylinder, UsdGeom.Cylinder_1, UsdGeom.Cone,
                    UsdGeom.Capsule, UsdGeom.Capsule_1, UsdGeom.Plane)

#: The attribute that scales each analytic shape (named when its world coordinates overflow).
_SIZE_ATTRIBUTE = {"Sphere": "radius", "Cube": "size", "Cylinder": "radius", "Cone": "radius", "Capsule": "radius",
                   "Cylinder_1": "radiusBottom", "Capsule_1": "radiusBottom", "Plane": "width"}

#: Prims visited below a prototype root: "over" prototypes are allowed, classes are not.
_PROTOTYPE_PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimIsLoaded & ~Usd.PrimIsAbstract)


def _within(values) -> bool:
    a = np.asarray(values, dtype=np.float64)
    return bool(np.isfinite(a).all() and (np.abs(a) <= MAX_MAGNITUDE).all())


def world_transform(where: Where, prim, compute, time=DEFAULT_TIME) -> Gf.Matrix4d:
    """``compute()`` (the prim's local-to-world matrix) when it is finite and within
    MAX_MAGNITUDE; else a SceneError naming the prim and the xformOp at fault.

    USD raises for an op of the wrong type and silently multiplies NaN, infinite or
    overflowing values; either becomes one error naming the prim (the gprim or the
    ancestor) and the op attribute.
    """
    try:
        matrix = compute()
    except Tf.ErrorException:
        matrix = None
    if matrix is not None and _within(matrix):
        return matrix
    raise _blame_transform(where, prim, time)


def _blame_transform(where: Where, prim, time):
    p = prim
    while p and not p.IsPseudoRoot():
        if p.IsA(UsdGeom.Xformable):
            try:
                ops = UsdGeom.Xformable(p).GetOrderedXformOps()
            except Tf.ErrorException:
                return where.error(p, "xformOpOrder", "cannot be evaluated")
            for op in ops:
                name = op.GetName()
                kind = UsdGeom.XformOp.GetOpTypeToken(op.GetOpType())
                try:
                    matrix = op.GetOpTransform(time)
                except Tf.ErrorException:
                    return where.error(p, name, f"has type {op.GetTypeName()}, which a {kind} op cannot use")
                if not _within(matrix):
                    return where.error(p, name, f"value {op.Get(time)} is not finite or gives a transform "
                                                f"beyond +-{MAX_MAGNITUDE:g}")
        p = p.GetParent()
    return where.error(prim, "xformOpOrder", f"the world transform (the product of its ancestors' transforms) "
                                             f"is not finite or exceeds +-{MAX_MAGNITUDE:g}")


def _blame_largest_op(where: Where, prim, time=DEFAULT_TIME):
    """SceneError naming the xformOp of largest magnitude on the prim or an ancestor."""
    best = None
    p = prim
    while p and not p.IsPseudoRoot():
        if p.IsA(UsdGeom.Xformable):
            for op in UsdGeom.Xformable(p).GetOrderedXformOps():
                if op.GetOpType() in (UsdGeom.XformOp.TypeOrient,) or UsdGeom.XformOp.GetOpTypeToken(
                        op.GetOpType()).startswith("rotate"):
                    continue  # rotations do not change magnitudes
                try:
                    size = float(np.abs(np.asarray(op.Get(time), dtype=np.float64)).max())
                except (TypeError, ValueError, Tf.ErrorException):
                    continue
                if best is None or size > best[0]:
                    best = (size, p, op.GetName(), op.Get(time))
        p = p.GetParent()
    if best is None:
        return where.error(prim, "xformOpOrder", f"the world-space coordinates exceed +-{MAX_MAGNITUDE:g}")
    _, p, name, value = best
    return where.error(p, name, f"value {value} puts the world-space coordinates of {prim.GetPath()} "
                                f"beyond +-{MAX_MAGNITUDE:g}")


def is_hidden(prim, time=DEFAULT_TIME) -> bool:
    """True when the prim (and so its whole subtree) is not rendered at ``time``.

    ``visibility = invisible`` and the ``guide`` / ``proxy`` purposes hide a subtree
    (a final-frame renderer draws the ``default`` and ``render`` purposes only).
    """
    if not prim.IsA(UsdGeom.Imageable):
        return False
    img = UsdGeom.Imageable(prim)
    if img.GetVisibilityAttr().Get(time) == UsdGeom.Tokens.invisible:
        return True
    return img.GetPurposeAttr().Get(time) in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)


def fan_triangulate(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons: face f with n >= 3 vertices gives (v0, vk, vk+1), k = 1..n-2.

    counts: vertices per face, shape (F,); indices: flattened face vertex indices.
    Faces with fewer than 3 vertices are skipped. Returns (T, 3) int64.
    """
    counts = np.asarray(counts, dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    tri_per_face = np.where(counts >= 3, counts - 2, 0)
    total = int(tri_per_face.sum())
    face = np.repeat(np.arange(len(counts)), tri_per_face)
    k = np.arange(total) - np.repeat(np.cumsum(tri_per_face) - tri_per_face, tri_per_face)
    base = offsets[face]
    corners = np.stack([base, base + k + 1, base + k + 2], axis=1)
    return np.asarray(indices, dtype=np.int64)[corners].reshape(-1, 3)


def transform_surface(points, triangles, normals, world_from_local: Gf.Matrix4d):
    """Apply a USD (row-vector) matrix: points affinely, normals by the inverse transpose.

    A mirroring transform (negative determinant) reverses the triangle winding so
    that the orientation stays consistent with the authored one.
    """
    m = np.array(world_from_local, dtype=np.float64).reshape(4, 4)
    linear, shift = m[:3, :3], m[3, :3]
    world = np.asarray(points, dtype=np.float64) @ linear + shift
    det = float(np.linalg.det(linear))
    if normals is not None:
        if abs(det) > 1e-300:
            n = np.asarray(normals, dtype=np.float64) @ np.linalg.inv(linear).T
            length = np.linalg.norm(n, axis=1, keepdims=True)
            normals = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        else:
            normals = None
    if det < 0:
        triangles = triangles[:, [0, 2, 1]]
    return world, np.ascontiguousarray(triangles, dtype=np.int64), normals


class GprimReader:
    """Gprims and PointInstancers → :class:`Surface` objects in world space; what is not
    honoured goes to ``notes``."""

    def __init__(self, where: Where, xform_cache: UsdGeom.XformCache, notes: Notes | None = None):
        self.where = where
        self.xf = xform_cache
        self.notes = Notes(where.file) if notes is None else notes
        self.material = MaterialReader(where, self.notes)
        self.subdivided: list[str] = []  # meshes rendered as their control cage (one warning per stage)
        self._checked: set[str] = set()

    # -- single gprims ------------------------------------------------------------
    def surface(self, prim, world_from_local: Gf.Matrix4d | None = None, label: str | None = None):
        """The prim's triangles in world space, or None for an unsupported / empty gprim."""
        local = self._local_mesh(prim)
        if local is None:
            return None
        self.check(prim)  # what it authors (and its ancestors) that is not honoured
        points, triangles, normals, topology = local
        if world_from_local is None:
            world_from_local = world_transform(self.where, prim, lambda: self.xf.GetLocalToWorldTransform(prim),
                                               self.where.time)
        local_size = float(np.abs(points).max()) if len(points) else 0.0
        with np.errstate(over="ignore", invalid="ignore"):
            points, triangles, normals = transform_surface(points, triangles, normals, world_from_local)
        if not _within(points):
            # Both factors are within bounds; blame the larger one: the transform or the shape.
            if float(np.abs(np.asarray(world_from_local)).max()) >= local_size:
                raise _blame_largest_op(self.where, prim, self.where.time)
            what = _SIZE_ATTRIBUTE.get(str(prim.GetTypeName()), "points")
            raise self.where.error(prim, what, f"world-space coordinates (after the transforms of the prim, its "
                                               f"ancestors and instancers) are not finite or exceed +-{MAX_MAGNITUDE:g}")
        sphere = None
        if prim.IsA(UsdGeom.Sphere):  # the analytic shape, for re-tessellation at the render's resolution
            radius = A.real(self.where, prim, "radius", 1.0, positive=True)
            sphere = (float(radius), np.array(world_from_local, dtype=np.float64).reshape(4, 4))
        material = self.material(prim)
        subsets = self.material.subsets(prim) if topology is not None else []
        triangle_material = None
        if subsets:  # per-face materials: later subsets win where they overlap
            triangle_material = np.zeros(len(triangles), np.int32)
            for k, (faces, _m) in enumerate(subsets):
                triangle_material[np.isin(topology[1], faces)] = k + 1
        textures = [t for m in (material, *(m for _f, m in subsets)) for t in m.textures if t is not None]
        st = None
        if textures:
            st = corner_st(self.where, self.notes, prim, textures[0], len(triangles), topology)
            if np.linalg.det(np.array(world_from_local, dtype=np.float64).reshape(4, 4)[:3, :3]) < 0:
                st = st[:, [0, 2, 1]]  # transform_surface reversed the winding
        return Surface(
            prim_path=label or str(prim.GetPath()),
            points=points,
            triangles=triangles,
            material=material,
            normals=normals,
            sphere=sphere,
            quadric=self._quadric(prim, world_from_local),
            st=st,
            subset_materials=tuple(m for _f, m in subsets),
            triangle_material=triangle_material,
        )

    def _quadric(self, prim, world_from_local):
        """A Cylinder, Cone or Capsule's analytic shape (``Surface.quadric``), else None."""
        kind = str(prim.GetTypeName())
        if kind not in ("Cylinder", "Cone", "Capsule"):
            return None
        w = self.where
        radius = A.real(w, prim, "radius", 0.5 if kind == "Capsule" else 1.0, minimum=0.0)
        height = A.real(w, prim, "height", 1.0 if kind == "Capsule" else 2.0, minimum=0.0)
        if radius == 0.0 or (height == 0.0 and kind != "Capsule"):
            return None
        return (kind.lower(), A.token(w, prim, "axis", ("X", "Y", "Z"), "Z"), float(radius), float(height),
                np.array(world_from_local, dtype=np.float64).reshape(4, 4))

    def check(self, prim) -> None:
        """What the prim and its ancestors author that is not honoured (once per prim)."""
        while prim and not prim.IsPseudoRoot():
            path = str(prim.GetPath())
            if path in self._checked:
                return
            self._checked.add(path)
            check_prim(self.notes, prim, self.where.time)
            prim = prim.GetParent()

    def _local_mesh(self, prim):
        w = self.where
        kind = str(prim.GetTypeName())
        if prim.IsA(UsdGeom.Sphere):
            radius = A.real(w, prim, "radius", 1.0, positive=True)
            return (*tessellate.sphere(radius), None)
        if prim.IsA(UsdGeom.Cube):
            points, triangles = tessellate.cube(A.real(w, prim, "size", 2.0, positive=True))
            return points, triangles, None, None
        if prim.IsA(UsdGeom.Mesh):
            return self._mesh(prim)
        if kind in _SIZE_ATTRIBUTE:
            shape = self._shape(prim, kind)
            return None if shape is None else (*shape, None)
        self.notes.warn(prim, None, f"{kind or 'untyped'} gprims are not rendered; skipped", "UnsupportedPrim")
        return None

    def _shape(self, prim, kind: str):
        """Cylinder, Cone, Capsule (and the _1 variants with two radii) and Plane."""
        w = self.where
        axis = A.token(w, prim, "axis", ("X", "Y", "Z"), "Z")
        if kind == "Plane":
            return tessellate.plane(A.real(w, prim, "width", 2.0, positive=True),
                                    A.real(w, prim, "length", 2.0, positive=True), axis)
        height = A.real(w, prim, "height", 1.0 if kind.startswith("Capsule") else 2.0, minimum=0.0)
        if kind.endswith("_1"):
            bottom = A.real(w, prim, "radiusBottom", 0.5 if kind.startswith("Capsule") else 1.0, minimum=0.0)
            top = A.real(w, prim, "radiusTop", bottom, minimum=0.0)
        else:
            bottom = A.real(w, prim, "radius", 0.5 if kind == "Capsule" else 1.0, minimum=0.0)
            top = 0.0 if kind == "Cone" else bottom
        if kind.startswith("Capsule"):
            return tessellate.capsule(bottom, top, height, axis)
        if height == 0.0 or bottom == top == 0.0:
            return None  # no surface
        return tessellate.cylinder(bottom, top, height, axis)

    def _mesh(self, prim):
        """points / faceVertexCounts / faceVertexIndices, validated, fan-triangulated, holes
        removed; with the topology primvars are placed by (``textures.corner_st``). A mesh
        whose points or topology cannot be used (a real-world USD problem, docs/spec.md §7)
        is a warning and renders nothing."""
        try:
            return self._valid_mesh(prim)
        except SceneError as exc:
            self.notes.value_error(exc, "the mesh is not rendered")
            return None

    def _valid_mesh(self, prim):
        w = self.where
        points = A.vec3_array(w, prim, "points")
        counts = A.int_array(w, prim, "faceVertexCounts")
        indices = A.int_array(w, prim, "faceVertexIndices")
        points = np.zeros((0, 3)) if points is None else points
        counts = np.zeros(0, np.int64) if counts is None else counts
        indices = np.zeros(0, np.int64) if indices is None else indices
        if (counts < 0).any():
            raise w.error(prim, "faceVertexCounts", f"has a negative count at face {int(np.argmax(counts < 0))}")
        if int(counts.sum()) != len(indices):
            raise w.error(prim, "faceVertexCounts",
                          f"sums to {int(counts.sum())} but faceVertexIndices has {len(indices)} entries")
        bad = (indices < 0) | (indices >= len(points))
        if bad.any():
            i = int(np.argmax(bad))
            raise w.error(prim, "faceVertexIndices",
                          f"entry {i} = {int(indices[i])} is out of range for {len(points)} points")
        scheme = prim.GetAttribute("subdivisionScheme")
        if scheme and scheme.HasAuthoredValue() and scheme.Get() not in (UsdGeom.Tokens.none, None):
            self.subdivided.append(str(prim.GetPath()))
        corners = fan_triangulate(counts, np.arange(len(indices)))  # triangles of face-corner ids
        faces = np.repeat(np.arange(len(counts)), np.where(counts >= 3, counts - 2, 0))
        holes = self._holes(prim)
        if holes is not None:
            keep = ~np.isin(faces, holes)
            corners, faces = corners[keep], faces[keep]
        if len(corners) == 0:
            return None
        normals, per_corner = self._normals(prim, len(points), counts, len(indices))
        if UsdGeom.Mesh(prim).GetOrientationAttr().Get(w.time) == UsdGeom.Tokens.leftHanded:
            corners = corners[:, [0, 2, 1]]
        topology = (corners, faces, indices, len(points), len(counts))
        if per_corner:  # faceVarying / uniform normals: one vertex per face corner, at the same place
            points, triangles = points[indices], corners
        else:
            triangles = indices[corners]
        return points, np.ascontiguousarray(triangles, dtype=np.int64), normals, topology

    def _holes(self, prim):
        try:
            return A.int_array(self.where, prim, "holeIndices")
        except SceneError as exc:
            self.notes.value_error(exc, "no face is a hole")
            return None

    def _normals(self, prim, n_points: int, counts, n_corners: int):
        """(normals, per_corner): authored normals as per-point values (vertex / varying /
        constant) or per face corner (faceVarying / uniform), else (None, False): flat
        shading from the faces. Values that cannot be used are a warning."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
        if primvar and primvar.HasAuthoredValue():
            attr, interp = primvar.GetAttr(), primvar.GetInterpolation()
        else:
            attr = prim.GetAttribute("normals")
            if not attr or not attr.HasAuthoredValue():
                return None, False
            interp, primvar = UsdGeom.Mesh(prim).GetNormalsInterpolation(), None
        flat = "the faces' own (flat) normals are used"
        try:
            normals = A.vec3_array(self.where, prim, attr.GetName())
        except SceneError as exc:
            self.notes.value_error(exc, flat)
            return None, False
        if normals is None:
            return None, False
        if primvar is not None and primvar.IsIndexed():
            index = np.asarray(primvar.GetIndices(self.where.time), dtype=np.int64)
            if ((index < 0) | (index >= len(normals))).any():
                self.notes.warn(prim, f"{attr.GetName()}:indices", f"has an entry out of range for "
                                f"{len(normals)} normals; {flat}", "BadValue")
                return None, False
            normals = normals[index]
        faces = np.repeat(np.arange(len(counts)), counts)
        expected = {UsdGeom.Tokens.vertex: n_points, UsdGeom.Tokens.varying: n_points,
                    UsdGeom.Tokens.faceVarying: n_corners, UsdGeom.Tokens.uniform: len(counts),
                    UsdGeom.Tokens.constant: 1}
        if interp not in expected or len(normals) != expected[interp]:
            need = f"{interp} interpolation needs {expected[interp]}" if interp in expected else \
                f"interpolation {interp!r} is unknown"
            self.notes.warn(prim, attr.GetName(), f"has {len(normals)} values but {need}; {flat}", "BadValue")
            return None, False
        if interp == UsdGeom.Tokens.constant:
            return np.repeat(normals, n_points, axis=0), False
        if interp == UsdGeom.Tokens.faceVarying:
            return normals, True
        if interp == UsdGeom.Tokens.uniform:
            return normals[faces], True
        return normals, False

    # -- point instancers ---------------------------------------------------------
    def instancer_surfaces(self, prim) -> list[Surface]:
        """One surface per (visible instance, prototype gprim), in world space."""
        self.check(prim)
        world = world_transform(self.where, prim, lambda: self.xf.GetLocalToWorldTransform(prim), self.where.time)
        out = []
        for gprim, local, label in self._instanced_gprims(prim, depth=0):
            surface = self.surface(gprim, local * world, label)
            if surface is not None:
                out.append(surface)
        return out

    def _instanced_gprims(self, prim, depth: int):
        """(gprim, gprim-to-instancer matrix, label) for every instance of every prototype gprim.

        The label is the prototype gprim's path followed by the instance index, e.g.
        ``/World/Trees/Proto/Trunk[12]`` (one index per level of nested instancers).
        """
        w = self.where
        if depth > 8:
            raise w.error(prim, "prototypes", "point instancers are nested more than 8 deep")
        instancer = UsdGeom.PointInstancer(prim)
        prototypes = instancer.GetPrototypesRel().GetForwardedTargets()
        proto_indices = A.int_array(w, prim, "protoIndices")
        if proto_indices is None or len(proto_indices) == 0:
            return []
        bad = (proto_indices < 0) | (proto_indices >= len(prototypes))
        if bad.any():
            i = int(np.argmax(bad))
            raise w.error(prim, "protoIndices",
                          f"entry {i} = {int(proto_indices[i])} is out of range for {len(prototypes)} prototypes")
        for name in ("positions", "scales"):
            A.vec3_array(w, prim, name)  # typed, finite and within MAX_MAGNITUDE, or a SceneError
        try:
            xforms = instancer.ComputeInstanceTransformsAtTime(
                w.time, w.time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask
            )
        except Tf.ErrorException:
            xforms = None
        if xforms is None or len(xforms) != len(proto_indices):
            raise w.error(prim, "positions", "instance transforms could not be computed (positions, "
                          "orientations, scales and protoIndices must have matching lengths)")
        mask = instancer.ComputeMaskAtTime(w.time) or []
        per_prototype = [self._prototype_gprims(prim.GetStage().GetPrimAtPath(p), depth) for p in prototypes]
        out = []
        for i, (instance_xf, j) in enumerate(zip(xforms, proto_indices)):
            if len(mask) and not mask[i]:
                continue
            for gprim, local, label in per_prototype[int(j)]:
                out.append((gprim, local * instance_xf, f"{label}[{i}]"))
        return out

    def _prototype_gprims(self, root, depth: int):
        """(gprim, gprim-to-root matrix excluding root's own transform, label) below a prototype."""
        if not root:
            return []
        out = []
        it = iter(Usd.PrimRange(root, _PROTOTYPE_PREDICATE))
        for prim in it:
            if is_hidden(prim, self.where.time):
                it.PruneChildren()
                continue
            if prim.IsA(UsdGeom.PointInstancer) or prim.IsA(UsdGeom.Gprim):
                if prim == root:
                    rel = Gf.Matrix4d(1.0)
                else:
                    rel = world_transform(self.where, prim, lambda: self.xf.ComputeRelativeTransform(prim, root)[0],
                                          self.where.time)
                if prim.IsA(UsdGeom.PointInstancer):
                    out.extend((g, m * rel, lbl) for g, m, lbl in self._instanced_gprims(prim, depth + 1))
                    it.PruneChildren()
                else:
                    out.append((prim, rel, str(prim.GetPath())))
        return out
