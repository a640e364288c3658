"""Temporal extrusion: triangles x worldlines -> prisms -> three tetrahedra each.

docs/spec.md §2: an authored world-space point p of a body with pivot o, velocity v and
reference time t_ref follows the worldline

- coupled:   x(t) = o + v (t - t_ref) + A r,   A = I - (1 - 1/gamma) v^ v^T,  r = p - o
  (the authored shape is the proper shape, Lorentz contracted along v about o);
- decoupled: x(t) = o + v (t - t_ref) + r.

Each body is sliced at lab-simultaneous times t_0 < ... < t_K covering its visible
time window; the points at consecutive slices bound one prism per triangle. Thesis
§4.3.1 splits each prism into three tetrahedra; we choose the diagonals by a rule on
global vertex indices (each side quad is cut from its lower-index bottom vertex to its
higher-index top vertex), so neighbouring prisms share faces and a closed mesh
extrudes to a watertight world-tube. Every tetrahedron's vertex indices come out
sorted ascending, which the kernel relies on to evaluate shared faces bit-identically.
"""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field

import numpy as np

from warp_st.core.extent import column_max, column_min, row_squares, shifted, transformed
from warp_st.core.lorentz import contraction_matrix
from warp_st.core.scene import Body, Scene, surface_keep, surface_triangles
from warp_st.core.thread_pool import thread_pool
from warp_st.spacetime.deform import deform_slices, deformed_events, deformed_triangles, deforming, slice_velocities
from warp_st.spacetime.visibility import intervals

__all__ = [
    "TriangleTables",
    "SpacetimeMesh",
    "BodyTriangles",
    "body_triangles",
    "once_per_array",
    "extrude_scene",
    "body_slices",
]


@dataclass(frozen=True, eq=False)
class TriangleTables:
    """Per-triangle shading tables, lab frame, float64 on the host (the extrusion's and
    the rigid shapes' alike; ``rendering.device.ShadingTables`` uploads them).

    vertex_normals: shading normals of the contracted surface in the lab, (V, 3);
        only meaningful for triangles with ``tri_smooth``.
    tri_normal: unit lab-frame normal of each contracted triangle, (T, 3).
    tri_smooth: 1 where the triangle interpolates vertex normals, (T,), int32.
    tri_size: longest edge of each contracted triangle, (T,).
    tri_body, tri_material: indices into ``bodies`` / ``materials``, (T,), int32.
    tri_st: texture coordinates at each triangle's corners, (T, 3, 2): in the order the
        tracing's barycentrics weigh them (the rigid path: the triangle's own; the 4D
        extrusion: ascending vertex index, see ``extrude_scene``); zeros untextured.
    """

    vertex_normals: np.ndarray
    tri_normal: np.ndarray
    tri_smooth: np.ndarray
    tri_size: np.ndarray
    tri_body: np.ndarray
    tri_material: np.ndarray
    materials: tuple
    bodies: tuple
    tri_st: np.ndarray


@dataclass(frozen=True, eq=False)
class SpacetimeMesh(TriangleTables):
    """The static 4D database, lab frame, float64 on the host (and ``TriangleTables``).

    vertices: events (t, x, y, z), shape (V, 4); ``vertex_normals`` has a row per vertex.
    tets: vertex indices, ascending in each row, shape (N, 4), int32.
    tet_tri: the triangle each tetrahedron was extruded from, (N,), int32.
    prisms: the same extrusion as prisms (each the union of three of the tetrahedra):
        bottom vertex indices ascending, then the matching top ones, shape (P, 6), int32.
    prism_tri: the triangle of each prism, (P,), int32.
    prism_span: lab times (t_lo, t_hi) in which each prism's triangle is tested, (P, 2):
        its segment [t0, t1] widened by PRISM_OVERLAP of its length where it meets the
        next segment (see ``prism_spans``).
    primitive: what a BVH built over this mesh indexes, "tet" or "prism"
        (``renderer.build_database`` reorders that array into leaf order).
    body_points: per body, its points per slice when it deforms (the stride between a
        vertex and the same point at the next slice), else 0, (B,), int32.
    vertex_velocity: a deforming body's vertices' lab velocities over the slice interval
        above them (``deform.slice_velocities``), zeros for other bodies, (V, 3); (0, 3)
        when no body deforms.
    vertex_clock: each vertex's proper time less its lab time since the body's reference
        time, tau - (t - t_ref), for a deforming body with ``Body.clock`` (its pivot's,
        ``spacetime.turning``), zeros for other bodies, (V,); (0,) when no body has one:
        the kernel blends it with the hit's barycentrics (linear between slices).
    """

    vertices: np.ndarray
    tets: np.ndarray
    tet_tri: np.ndarray
    prisms: np.ndarray
    prism_tri: np.ndarray
    prism_span: np.ndarray
    primitive: str = "tet"
    body_points: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    vertex_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    vertex_clock: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def tet_count(self) -> int:
        return int(len(self.tets))

    @property
    def prim_count(self) -> int:
        """Number of primitives of the kind a BVH over this mesh indexes."""
        return int(len(self.prisms if self.primitive == "prism" else self.tets))

    def prim_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """4D bounding boxes (lo, hi) of every primitive, each (N, 4): a tetrahedron's
        four events, or a prism's triangle swept over its whole span."""
        if self.primitive != "prism":
            ev = self.vertices[self.tets]
            return ev.min(axis=1), ev.max(axis=1)
        bottom = self.vertices[self.prisms[:, :3]]  # (P, 3, 4) at t0
        top = self.vertices[self.prisms[:, 3:]]
        t0, t1 = bottom[:, :1, :1], top[:, :1, :1]
        rate = (top - bottom) / np.where(t1 > t0, t1 - t0, 1.0)  # (1, v) per vertex
        ends = [bottom + rate * (span - t0) for span in (self.prism_span[:, None, 0:1], self.prism_span[:, None, 1:2])]
        ev = np.concatenate(ends, axis=1)
        return ev.min(axis=1), ev.max(axis=1)

    def tet_events(self) -> np.ndarray:
        """Events of every tetrahedron, shape (N, 4, 4): [tet, corner, (t, x, y, z)]."""
        return self.vertices[self.tets]


#: Fraction of a body's size it may sweep per time segment.
SWEEP_FRACTION = 0.5
#: A finely tessellated body gets shorter segments: a triangle's 4D box is as long as the
#: body's sweep in its segment, so with triangles much smaller than the body every ray
#: point lies in many boxes. A segment then sweeps at most TRIANGLE_SWEEP x the body's
#: median triangle size, but never less than MIN_SWEEP_FRACTION of the body (memory).
#: Measured (docs/design/performance-0.3.2.md, "Time-segment length"): a 3 x 3 grid of 128-segment
#: spheres up to 0.9c traced 2x faster at a quarter of the half-size sweep, for 3x the
#: tetrahedra; 24-segment spheres gained 20% at half of it.
TRIANGLE_SWEEP = 4.0
MIN_SWEEP_FRACTION = 0.125


def body_slices(
    body: Body, window: tuple[float, float], *, max_segments: int = 4096, fraction: float | None = None,
    fine: bool = True, view=None,
) -> np.ndarray:
    """Slice times covering ``window`` for one body, ascending, at least two.

    The window is split into K segments so that the body sweeps at most
    ``segment_sweep(body)`` per segment (``fraction`` x its size when given; with
    ``fine`` False, SWEEP_FRACTION x its size: the coarser rule the renderer falls
    back to when the finer one would not fit in memory): the 4D boxes of its
    primitives then stay within a triangle or two of their triangle. A deforming body's
    slices also follow USD within half a pixel of ``view`` (``deform.SliceView``).
    """
    t0, t1 = float(window[0]), float(window[1])
    if fraction is None and not fine:
        fraction = SWEEP_FRACTION
    size = segment_sweep(body) if fraction is None else fraction * _body_size(body)
    if deforming(body):  # per-vertex worldlines from USD's samples (docs/spec.md §2.2)
        return deform_slices(body, window, size, max_segments=max_segments, view=view)
    sweep = body.speed * (t1 - t0)
    k = 1 if sweep <= size else int(min(np.ceil(sweep / size), max_segments))
    return np.linspace(t0, t1, k + 1)


def segment_sweep(body: Body) -> float:
    """The distance ``body`` may move per time segment (see TRIANGLE_SWEEP)."""
    size = _body_size(body)
    edges = [longest_edges(np.asarray(s.points, dtype=np.float64), surface_triangles(s)) for s in body.surfaces]
    edges = np.concatenate(edges) if edges else np.zeros(0)
    tri = float(np.median(edges)) if len(edges) else size
    return min(SWEEP_FRACTION * size, max(TRIANGLE_SWEEP * tri, MIN_SWEEP_FRACTION * size))


def longest_edges(pts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Length of each triangle's longest edge, (T,)."""
    corners = np.take(pts, tris, axis=0)  # (T, 3, 3): one gather (column gathers are ~4x slower)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    return np.sqrt(np.maximum(np.maximum(row_squares(b - a), row_squares(c - a)), row_squares(c - b)))


def _facets(local: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit facet normals (e1 x e2 normalised, as ``np.cross`` and ``np.linalg.norm``
    give them to the bit) and longest edges (``longest_edges``, to the bit) of ``tris``
    over ``local``. Coordinate by coordinate: each corner coordinate a gather of one
    column, each difference and product over contiguous arrays (the same operations in
    the same order as on (T, 3) rows, half the time of one (T, 3, 3) gather and its
    strided rows; 16k triangles: 0.5-1.8 against 1.0-2.3 ms)."""
    x, y, z = local[:, 0], local[:, 1], local[:, 2]
    i, j, k = tris[:, 0], tris[:, 1], tris[:, 2]
    ax, ay, az, bx, by, bz, cx, cy, cz = x[i], y[i], z[i], x[j], y[j], z[j], x[k], y[k], z[k]
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    e3x, e3y, e3z = cx - bx, cy - by, cz - bz
    fx, fy, fz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    norm = np.maximum(np.sqrt(fx * fx + fy * fy + fz * fz), 1e-300)
    longest = np.maximum(np.maximum(e1x * e1x + e1y * e1y + e1z * e1z, e2x * e2x + e2y * e2y + e2z * e2z),
                         e3x * e3x + e3y * e3y + e3z * e3z)
    return np.column_stack([fx / norm, fy / norm, fz / norm]), np.sqrt(longest)


def _body_size(body: Body) -> float:
    pts = np.concatenate([s.points for s in body.surfaces]) if body.surfaces else np.zeros((1, 3))
    extent = float(np.max(column_max(pts) - column_min(pts))) if len(pts) else 0.0
    return max(extent, 1e-6)


@dataclass(frozen=True, eq=False)
class BodyTriangles:
    """One body's surfaces as one triangle set (surfaces without triangles left out).

    rest: rest-frame positions r = p - o about the pivot, (P, 3) (the authored shape is
        the proper shape: docs/spec.md §2);
    local: the contracted lab positions at the reference time, o + A r, (P, 3);
    normals: contracted shading normals, unit, (P, 3) (zeros on flat surfaces);
    triangles: indices into the points, (T, 3); tri_normal / tri_smooth / tri_size /
        tri_material: as SpacetimeMesh's, per triangle; tri_st: each triangle's corner
        texture coordinates in its own corner order, (T, 3, 2).
    """

    rest: np.ndarray
    local: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    tri_normal: np.ndarray
    tri_smooth: np.ndarray
    tri_size: np.ndarray
    tri_material: np.ndarray
    tri_st: np.ndarray


def _material_index(material, materials: list, mat_index: dict) -> int:
    if material not in mat_index:
        mat_index[material] = len(materials)
        materials.append(material)
    return mat_index[material]


def body_triangles(body: Body, materials: list, mat_index: dict) -> BodyTriangles | None:
    """``body``'s triangle set (None without triangles); new materials are appended to
    ``materials`` (``mat_index`` maps a Material to its index). Facet normals and sizes are
    computed from the contracted offsets about the pivot, A r, so they do not depend on
    where the body is (nor lose digits to a far pivot)."""
    return _body_triangles(body, contraction_matrix(body.velocity, body.decoupled), materials, mat_index)


def bodies_triangles(bodies, materials: list, mat_index: dict, *, shared: bool) -> list:
    """``body_triangles`` of every body (None: no triangles), with the materials in the
    order calls body after body give them, the distinct triangle sets made on the
    process's thread pool, one thread per core (NumPy releases the GIL in their array
    work: 16 distinct 65k-triangle spheres took 58-78 ms on two threads against 133-162 in
    turn). The materials are registered first, in the calls' order, so their indices are
    the calls' and the threads only look them up.

    ``shared`` (the rigid path's float32 tables): bodies whose surfaces agree in float32
    relative to their pivots (instances: points about the pivot, normals, texture
    coordinates and triangles; the precision their shared shape is held in,
    ``spacetime.rigid``) with the same contraction share the shading tables of the first:
    only ``rest``, ``local`` and the materials are their own."""
    masks: dict = {}  # a surface's triangle array -> its surface_keep (instances share theirs)

    def kept(surf):
        return once_per_array(masks, surf.triangles, lambda _: surface_keep(surf))

    for body in bodies:
        for surf in body.surfaces:
            if kept(surf).any():  # a surface with triangles: _triangle_materials' order
                for material in (surf.material, *surf.subset_materials):
                    _material_index(material, materials, mat_index)
    pool = thread_pool(os.cpu_count() or 1)
    if not shared:
        return list(pool.map(lambda b: body_triangles(b, materials, mat_index) if b.surfaces else None, bodies))
    parts = {}  # body index -> (A, rest, key)
    made: dict = {}  # key -> the first such body's index, then its triangles
    seen: dict = {}  # id of an array the surfaces share -> its key bytes (made and hashed once)
    for i, body in enumerate(bodies):
        if body.surfaces:
            A = contraction_matrix(body.velocity, body.decoupled)
            rest = [shifted(s.points, -np.asarray(body.origin, dtype=np.float64)) for s in body.surfaces]
            parts[i] = (A, rest, _instance_key(body, A, rest, seen))
            made.setdefault(parts[i][2], i)
    firsts = list(made.values())
    first_kept = {i: [kept(s) for s in bodies[i].surfaces] for i in firsts}  # made here: the pool only reads them
    for key, bt in zip(made, pool.map(lambda i: _body_triangles(bodies[i], parts[i][0], materials, mat_index,
                                                                first_kept[i]), firsts)):
        made[key] = bt
    return [None if i not in parts else _own_copy(body, made[parts[i][2]], parts[i][0], parts[i][1],
                                                    [kept(s) for s in body.surfaces], materials, mat_index)
            for i, body in enumerate(bodies)]


def _own_copy(body: Body, shared: BodyTriangles | None, A: np.ndarray, rest: list, kept: list, materials: list,
              mat_index: dict) -> BodyTriangles | None:
    """``shared`` (the triangles of the first body with ``body``'s instance key) with
    ``body``'s own rest and lab points (``rest``: each surface's points about its pivot)
    and materials (``kept``: each surface's ``surface_keep``)."""
    if shared is None:
        return None
    own = _joined([r for r, k in zip(rest, kept) if k.any()])
    tri_mat = _joined([_triangle_materials(s, k, materials, mat_index) for s, k in zip(body.surfaces, kept)
                       if k.any()])
    return dataclasses.replace(shared, rest=own, local=shifted(transformed(own, A), body.origin), tri_material=tri_mat)


def _instance_key(body: Body, A: np.ndarray, rest: list, seen: dict) -> tuple:
    """What ``body_triangles`` computes the shading tables but the materials from, in
    float32: the contraction and each surface's points about the pivot (``rest``),
    triangles, normals and texture coordinates. ``seen``: the bytes of the surfaces'
    arrays by id, for arrays instances share (a bytes object caches its hash, so a shared
    one is hashed once; the arrays outlive the call that fills ``seen``)."""
    def f32(a):
        return None if a is None else np.asarray(a, dtype=np.float64).astype(np.float32).tobytes()

    key: list = [A.tobytes()]
    for s, r in zip(body.surfaces, rest):
        key += [f32(r), once_per_array(seen, s.triangles, lambda a: np.asarray(a).tobytes()),
                once_per_array(seen, s.normals, f32), once_per_array(seen, s.st, f32)]
    return tuple(key)


def once_per_array(seen: dict, a, convert):
    """``convert(a)`` (None for None), made once per array object: ``seen`` holds each
    array by id beside its result, so for arrays that bodies share (an instance's
    triangles, normals) the work is done once (their key bytes copied and, as a bytes
    object caches its hash, hashed once; their triangles' kept masks). Keeping the array
    keeps its id its own while ``seen`` lives."""
    if a is None:
        return None
    if id(a) not in seen:
        seen[id(a)] = (a, convert(a))
    return seen[id(a)][1]


def _triangle_materials(surf, keep: np.ndarray, materials: list, mat_index: dict) -> np.ndarray:
    """The material index of each of ``surf``'s kept triangles (new materials appended)."""
    own = (surf.material, *surf.subset_materials)
    index = np.array([_material_index(m, materials, mat_index) for m in own], dtype=np.int32)
    return index[np.zeros(int(keep.sum()), np.int64) if surf.triangle_material is None
                 else np.asarray(surf.triangle_material, dtype=np.int64)[keep]]


def _body_triangles(body: Body, A: np.ndarray, materials: list, mat_index: dict,
                    kept: list | None = None) -> BodyTriangles | None:
    """``body_triangles`` with contraction ``A``; ``kept``: each surface's ``surface_keep``
    when the caller has them."""
    A_inv_t = np.linalg.inv(A).T
    parts = []
    base = 0
    for index, surf in enumerate(body.surfaces):
        keep = surface_keep(surf) if kept is None else kept[index]
        tris = np.compress(keep, np.asarray(surf.triangles, dtype=np.int64).reshape(-1, 3), axis=0)  # [keep], faster
        if len(tris) == 0:
            continue
        pts = np.asarray(surf.points, dtype=np.float64)
        if surf.normals is not None:
            nrm = np.asarray(surf.normals, dtype=np.float64) @ A_inv_t.T
            nrm /= np.maximum(np.sqrt(row_squares(nrm)), 1e-300)[:, None]  # np.linalg.norm's bits
        else:
            nrm = np.zeros((len(pts), 3))
        tri_mat = _triangle_materials(surf, keep, materials, mat_index)
        st = np.zeros((len(tris), 3, 2)) if surf.st is None else np.asarray(surf.st, dtype=np.float64)[keep]
        parts.append((pts, nrm, tris + base, surf.normals is not None, tri_mat, st))
        base += len(pts)
    if not parts:
        return None
    rest = shifted(_joined([p[0] for p in parts]), -np.asarray(body.origin, dtype=np.float64))
    contracted = transformed(rest, A)  # contracted offsets from the pivot at the reference time
    local = shifted(contracted, body.origin)
    tris = _joined([p[2] for p in parts])
    # Triangle normals of the contracted shape (lab frame, constant in time).
    fn, size = _facets(contracted, tris)
    counts = [len(p[2]) for p in parts]
    return BodyTriangles(
        rest=rest, local=local, normals=_joined([p[1] for p in parts]), triangles=tris, tri_normal=fn,
        tri_smooth=np.repeat(np.array([1 if p[3] else 0 for p in parts], dtype=np.int32), counts),
        tri_size=size,
        tri_material=_joined([p[4] for p in parts]).astype(np.int32),
        tri_st=_joined([p[5] for p in parts]),
    )


def _joined(arrays: list) -> np.ndarray:
    """``np.concatenate(arrays)``, but one array is returned itself, not copied: the
    callers' parts are arrays made for the call, or a surface's points, which they only
    read (every result derived from those is a new array)."""
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


def extrude_scene(scene: Scene, windows: list, *, fine: bool = True, fraction: float | None = None,
                  view=None) -> SpacetimeMesh:
    """Extrude every body of ``scene`` over its visible time window.

    windows[i] is the lab-time window of body i that the frames can see (already
    intersected with its lifetime): an interval (lo, hi), a tuple of disjoint
    intervals (each extruded on its own), or None when the body is never visible.
    fine: time segments by ``segment_sweep`` (default) or by SWEEP_FRACTION of the body.
    fraction: when given, time segments in which each body sweeps ``fraction`` x its
    size, whatever ``fine`` says (``body_slices``; for measuring the rule).
    view: the render's cameras (``deform.SliceView``) for deforming bodies' slices.
    """
    materials: list = []
    mat_index: dict = {}
    verts, vnorms, tets, tet_tri, prisms, prism_tri, spans = [], [], [], [], [], [], []
    velocities, clocks, body_points = [], [], np.zeros(len(scene.bodies), np.int32)
    tri_normal, tri_smooth, tri_size, tri_body, tri_material, tri_st = [], [], [], [], [], []
    v_base = 0
    t_base = 0

    for b_index, (body, window) in enumerate(zip(scene.bodies, windows)):
        parts = intervals(window)
        if not parts or not body.surfaces:
            continue
        bt = body_triangles(body, materials, mat_index)
        if bt is None:
            continue
        if deforming(body):
            bt = deformed_triangles(body, bt, longest_edges)
        tris, n_pts, n_tri = bt.triangles, len(bt.local), len(bt.triangles)
        tri_normal.append(bt.tri_normal)
        tri_smooth.append(bt.tri_smooth)
        tri_size.append(bt.tri_size)
        tri_body.append(np.full(n_tri, b_index, dtype=np.int32))
        tri_material.append(bt.tri_material)
        # The prisms' and tetrahedra's barycentrics weigh the corners in ascending vertex order.
        tri_st.append(np.take_along_axis(bt.tri_st, np.argsort(tris, axis=1)[:, :, None], axis=1))
        for part in parts:  # each interval on its own
            slices = body_slices(body, part, fine=fine, fraction=fraction, view=view)
            if deforming(body):
                ev, normals = deformed_events(body, slices)
                velocities.append((v_base, slice_velocities(ev).reshape(-1, 3)))
                if body.clock is not None:  # the pivot's proper time at each slice (spacetime/turning.py)
                    lag = np.interp(slices, *body.clock) - (slices - body.reference_time)
                    clocks.append((v_base, np.repeat(lag, n_pts)))
                body_points[b_index] = n_pts
            else:
                ev = _slice_events(bt.local, body.velocity, body.reference_time, slices)  # (K+1, P, 4)
                normals = np.broadcast_to(bt.normals, (len(slices), n_pts, 3))
            verts.append(ev.reshape(-1, 4))
            vnorms.append(normals.reshape(-1, 3))
            tets.append(_prism_tets(tris, n_pts, len(slices) - 1) + v_base)
            tet_tri.append(np.tile(np.arange(n_tri, dtype=np.int64), 3 * (len(slices) - 1)) + t_base)
            prisms.append(_prisms(tris, n_pts, len(slices) - 1) + v_base)
            prism_tri.append(np.tile(np.arange(n_tri, dtype=np.int64), len(slices) - 1) + t_base)
            spans.append(np.repeat(prism_spans(slices), n_tri, axis=0))
            v_base += len(slices) * n_pts
        t_base += n_tri

    def cat(parts, shape, dtype):
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(shape, dtype=dtype)

    vertex_velocity = np.zeros((v_base if velocities else 0, 3))
    for start, rows in velocities:
        vertex_velocity[start:start + len(rows)] = rows
    vertex_clock = np.zeros(v_base if clocks else 0)
    for start, rows in clocks:
        vertex_clock[start:start + len(rows)] = rows

    return SpacetimeMesh(
        vertices=cat(verts, (0, 4), np.float64),
        vertex_normals=cat(vnorms, (0, 3), np.float64),
        tets=cat(tets, (0, 4), np.int32),
        tet_tri=cat(tet_tri, (0,), np.int32),
        prisms=cat(prisms, (0, 6), np.int32),
        prism_tri=cat(prism_tri, (0,), np.int32),
        prism_span=cat(spans, (0, 2), np.float64),
        tri_normal=cat(tri_normal, (0, 3), np.float64),
        tri_smooth=cat(tri_smooth, (0,), np.int32),
        tri_size=cat(tri_size, (0,), np.float64),
        tri_body=cat(tri_body, (0,), np.int32),
        tri_material=cat(tri_material, (0,), np.int32),
        materials=tuple(materials),
        bodies=tuple(scene.bodies),
        tri_st=cat(tri_st, (0, 3, 2), np.float64),
        body_points=body_points,
        vertex_velocity=vertex_velocity,
        vertex_clock=vertex_clock,
    )


def _slice_events(local: np.ndarray, velocity: np.ndarray, t_ref: float, slices: np.ndarray) -> np.ndarray:
    """Events of every point at every slice time, shape (K+1, P, 4)."""
    k1, n = len(slices), len(local)
    ev = np.empty((k1, n, 4))
    ev[:, :, 0] = slices[:, None]
    ev[:, :, 1:] = local[None, :, :] + (slices - t_ref)[:, None, None] * np.asarray(velocity)[None, None, :]
    return ev


def _prism_tets(tris: np.ndarray, n_pts: int, segments: int) -> np.ndarray:
    """Three tetrahedra per prism, for every triangle and segment, shape (3 T K, 4).

    With a < b < c the sorted point indices of a triangle and ' marking the next
    slice (index + n_pts), the prism splits into (a, b, c, c'), (a, b, b', c'),
    (a, a', b', c'): each side quad (i, j, j', i') with i < j is cut along i-j',
    a rule both prisms sharing that quad follow. Every row is ascending.
    """
    s = np.sort(tris, axis=1)
    a, b, c = s[:, 0], s[:, 1], s[:, 2]
    one = np.stack(
        [
            np.stack([a, b, c, c + n_pts], axis=1),
            np.stack([a, b, b + n_pts, c + n_pts], axis=1),
            np.stack([a, a + n_pts, b + n_pts, c + n_pts], axis=1),
        ]
    )  # (3, T, 4)
    offsets = (np.arange(segments, dtype=np.int64) * n_pts)[:, None, None, None]
    return (one[None] + offsets).reshape(-1, 4)


#: Consecutive prisms of a triangle overlap by this fraction of their segment's length.
#: Each prism moves its triangle as x + v (t - t0) from its own (rounded) bottom
#: events, so at a slice time the two neighbours' triangles differ by the rounding of
#: the stored positions, and a ray through a vertex or edge exactly there could fall
#: in the gap; with an overlap every hit time lies well inside one segment, whose
#: prisms alone are watertight. Only slice times between two segments are widened:
#: the extrusion's first and last times (lifetime ends, window ends) stay exact.
PRISM_OVERLAP = 1.0e-2


def prism_spans(slices: np.ndarray) -> np.ndarray:
    """(t_lo, t_hi) of each segment between ``slices``, widened by PRISM_OVERLAP of its
    length where it meets a neighbouring segment, shape (K, 2)."""
    t0, t1 = slices[:-1], slices[1:]
    pad = PRISM_OVERLAP * (t1 - t0)
    lo, hi = t0.copy(), t1.copy()
    lo[1:] -= pad[1:]
    hi[:-1] += pad[:-1]
    return np.column_stack([lo, hi])


def _prisms(tris: np.ndarray, n_pts: int, segments: int) -> np.ndarray:
    """Every triangle and segment as a prism: sorted bottom indices, then top, (T K, 6)."""
    s = np.sort(tris, axis=1)
    one = np.concatenate([s, s + n_pts], axis=1)  # (T, 6)
    offsets = (np.arange(segments, dtype=np.int64) * n_pts)[:, None, None]
    return (one[None] + offsets).reshape(-1, 6)
