"""Temporal extrusion: triangles x worldlines -> prisms -> three tetrahedra each.

SPEC §2: an authored world-space point p of a body with pivot o, velocity v and
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

from dataclasses import dataclass

import numpy as np

from .scene import Body, Scene

__all__ = ["SpacetimeMesh", "contraction_matrix", "extrude_scene", "body_slices"]


@dataclass(frozen=True, eq=False)
class SpacetimeMesh:
    """The static 4D database, lab frame, float64 on the host.

    vertices: events (t, x, y, z), shape (V, 4).
    vertex_normals: shading normals of the contracted surface in the lab, (V, 3);
        only meaningful for triangles with ``tri_smooth``.
    tets: vertex indices, ascending in each row, shape (N, 4), int32.
    tet_tri: the triangle each tetrahedron was extruded from, (N,), int32.
    tri_normal: unit lab-frame normal of each contracted triangle, (T, 3).
    tri_smooth: 1 where the triangle interpolates vertex normals, (T,), int32.
    tri_size: longest edge of each contracted triangle, (T,).
    tri_body, tri_material: indices into ``bodies`` / ``materials``, (T,), int32.
    """

    vertices: np.ndarray
    vertex_normals: np.ndarray
    tets: np.ndarray
    tet_tri: np.ndarray
    tri_normal: np.ndarray
    tri_smooth: np.ndarray
    tri_size: np.ndarray
    tri_body: np.ndarray
    tri_material: np.ndarray
    materials: tuple
    bodies: tuple

    @property
    def tet_count(self) -> int:
        return int(len(self.tets))

    def tet_events(self) -> np.ndarray:
        """Events of every tetrahedron, shape (N, 4, 4): [tet, corner, (t, x, y, z)]."""
        return self.vertices[self.tets]


def contraction_matrix(velocity: np.ndarray, decoupled: bool) -> np.ndarray:
    """A = I - (1 - 1/gamma) v^ v^T: maps proper (authored) offsets to lab offsets, (3, 3)."""
    v = np.asarray(velocity, dtype=np.float64)
    speed = float(np.linalg.norm(v))
    if decoupled or speed == 0.0:
        return np.eye(3)
    vhat = v / speed
    inv_gamma = np.sqrt(max(1.0 - speed * speed, 0.0))
    return np.eye(3) - (1.0 - inv_gamma) * np.outer(vhat, vhat)


def body_slices(body: Body, window: tuple[float, float], *, max_segments: int = 4096) -> np.ndarray:
    """Slice times covering ``window`` for one body, ascending, at least two.

    The window is split into K segments so that the body sweeps at most about its own
    size per segment: the 4D boxes of its tetrahedra then stay about twice the body.
    """
    t0, t1 = float(window[0]), float(window[1])
    size = _body_size(body)
    sweep = body.speed * (t1 - t0)
    k = 1 if sweep <= size else int(min(np.ceil(sweep / size), max_segments))
    return np.linspace(t0, t1, k + 1)


def _body_size(body: Body) -> float:
    pts = np.concatenate([s.points for s in body.surfaces]) if body.surfaces else np.zeros((1, 3))
    extent = float(np.max(pts.max(axis=0) - pts.min(axis=0))) if len(pts) else 0.0
    return max(extent, 1e-6)


def extrude_scene(scene: Scene, windows: list[tuple[float, float] | None]) -> SpacetimeMesh:
    """Extrude every body of ``scene`` over its visible time window.

    windows[i] is the lab-time interval of body i that the frames can see (already
    intersected with its lifetime), or None when the body is never visible.
    """
    materials: list = []
    mat_index: dict = {}
    verts, vnorms, tets, tet_tri = [], [], [], []
    tri_normal, tri_smooth, tri_size, tri_body, tri_material = [], [], [], [], []
    v_base = 0
    t_base = 0
    for b_index, (body, window) in enumerate(zip(scene.bodies, windows)):
        if window is None or not body.surfaces:
            continue
        slices = body_slices(body, window)
        A = contraction_matrix(body.velocity, body.decoupled)
        A_inv_t = np.linalg.inv(A).T
        for surf in body.surfaces:
            tris = np.asarray(surf.triangles, dtype=np.int64).reshape(-1, 3)
            # Degenerate index triples carry no surface.
            keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
            tris = tris[keep]
            if len(tris) == 0:
                continue
            pts = np.asarray(surf.points, dtype=np.float64)
            n_pts = len(pts)
            # Contracted offsets from the pivot at the reference time.
            local = (pts - body.origin) @ A.T + body.origin
            ev = _slice_events(local, body.velocity, body.reference_time, slices)  # (K+1, P, 4)
            verts.append(ev.reshape(-1, 4))
            if surf.normals is not None:
                nrm = np.asarray(surf.normals, dtype=np.float64) @ A_inv_t.T
                nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
            else:
                nrm = np.zeros((n_pts, 3))
            vnorms.append(np.broadcast_to(nrm, (len(slices), n_pts, 3)).reshape(-1, 3))

            # Triangle normals of the contracted shape (lab frame, constant in time).
            e1 = local[tris[:, 1]] - local[tris[:, 0]]
            e2 = local[tris[:, 2]] - local[tris[:, 0]]
            e3 = local[tris[:, 2]] - local[tris[:, 1]]
            tri_size.append(np.sqrt(np.max([(e * e).sum(axis=1) for e in (e1, e2, e3)], axis=0)))
            fn = np.cross(e1, e2)
            fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)
            key = surf.material
            if key not in mat_index:
                mat_index[key] = len(materials)
                materials.append(key)
            n_tri = len(tris)
            tri_normal.append(fn)
            tri_smooth.append(np.full(n_tri, 1 if surf.normals is not None else 0, dtype=np.int32))
            tri_body.append(np.full(n_tri, b_index, dtype=np.int32))
            tri_material.append(np.full(n_tri, mat_index[key], dtype=np.int32))

            tets.append(_prism_tets(tris, n_pts, len(slices) - 1) + v_base)
            tet_tri.append(np.tile(np.arange(n_tri, dtype=np.int64), 3 * (len(slices) - 1)) + t_base)
            v_base += len(slices) * n_pts
            t_base += n_tri

    def cat(parts, shape, dtype):
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(shape, dtype=dtype)

    return SpacetimeMesh(
        vertices=cat(verts, (0, 4), np.float64),
        vertex_normals=cat(vnorms, (0, 3), np.float64),
        tets=cat(tets, (0, 4), np.int32),
        tet_tri=cat(tet_tri, (0,), np.int32),
        tri_normal=cat(tri_normal, (0, 3), np.float64),
        tri_smooth=cat(tri_smooth, (0,), np.int32),
        tri_size=cat(tri_size, (0,), np.float64),
        tri_body=cat(tri_body, (0,), np.int32),
        tri_material=cat(tri_material, (0,), np.int32),
        materials=tuple(materials),
        bodies=tuple(scene.bodies),
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
