"""Adaptive sphere tessellation: the cheapest UV sphere whose error stays under half a pixel.

Called by the renderer, which knows the resolution, the lens and every frame's camera
event, before extrusion.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.core import tessellate
from warp_st.core.lorentz import contraction_matrix
from warp_st.core.scene import Body, Scene
from warp_st.spacetime.visibility import frame_window

__all__ = ["adapt_sphere_tessellation", "sphere_tessellation", "retessellated", "sphere_segments_for_view",
           "min_pixel_angle", "retessellate_sphere"]


# --------------------------------------------------------------------------- adaptive spheres
#
# A UsdGeom.Sphere keeps its analytic shape on the Surface (``Surface.sphere``); the
# renderer, which knows the resolution, the lens and every frame's camera event, picks
# the cheapest UV tessellation whose error stays under half a pixel and re-tessellates
# before extrusion. Why the bound holds (examples/benchmarks/README.md, "How the adaptive
# sphere tessellation works"):
#
# - All vertices lie on the sphere, so in the body frame the polyhedron lies between
#   ball(R - g) and ball(R), g = R (1 - cos(sqrt(2) pi / n)) < 2 R (1 - cos(pi / n)) (the
#   widest triangle spans a quad's diagonal: twice the great-circle sagitta). The outline
#   moves in by at most g / L and a visible point along its normal by at most g, seen at
#   distance L, i.e. an angle g / L.
# - Coupled bodies: g is a rest-frame length seen at rest-frame distance L'; the angle
#   scales by omega' / omega to the camera frame and the distance by omega / omega', so
#   the camera sees g / Z with Z the camera-frame distance (no extra factor for speed).
#   Decoupled bodies (Galilean): along the ray the co-moving position is A + s (n + v),
#   so the image stretches angles by |n + v| / (1 + n.v) <= gamma = 1 / sqrt(1 - beta^2)
#   (1 along or against v); evaluated over the directions the sphere covers in the window.
#   At beta >= 1 there is no bound: keep the default.
# - Z >= (lab lookback) x gamma_c (1 - beta_c) for a moving camera (Galilean camera:
#   1 - beta_c and angles stretched by 1 / (1 - beta_c)), and the lab lookback of any
#   event on the sphere is at least min |centre(t) - c| - R over the lab times t the
#   frame can see (visibility.frame_window on the sphere's own ball) and, with finite
#   light speed, at least t_c - (the window's end): the lookback of an event is t_c - t.
# - One pixel subtends at least the smallest angle between neighbouring pixel centres
#   (at the image corners for a pinhole).
#
# Not covered (documented): shadow edges on grazing receivers and reflections in curved
# mirrors can magnify the error; mirror spheres and scenes with mirrors therefore never
# go below the reader's default tessellation.


def min_pixel_angle(cam, width: int, height: int) -> float:
    """Smallest angle (radians, camera rest frame) between neighbouring pixel centres.

    The pinhole's angular pixel size falls with the distance from the principal point
    (radially as cos^2 of the field angle), so the minimum is at an image corner.
    """
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    f = float(cam.focal_length)

    def direction(i, j):
        x = ((i + 0.5) / width * 2.0 - 1.0) * 0.5 * h_ap + float(cam.horizontal_aperture_offset)
        y = (1.0 - (j + 0.5) / height * 2.0) * 0.5 * v_ap + float(cam.vertical_aperture_offset)
        d = np.array([x, y, -f], dtype=np.float64)
        return d / np.linalg.norm(d)

    best = np.inf
    for i, di in ((0, 1), (width - 1, -1)):
        for j, dj in ((0, 1), (height - 1, -1)):
            a = direction(i, j)
            for b in (direction(i + di, j), direction(i, j + dj)):
                best = min(best, float(np.arctan2(np.linalg.norm(np.cross(a, b)), float(a @ b))))
    return best


def sphere_segments_for_view(radius: float, distance: float, pixel_angle: float, *, pixels: float = 0.5,
                             lo: int = 8, hi: int = 512) -> int:
    """UV-sphere longitudes n whose tessellation error, seen from ``distance`` or farther,
    stays under ``pixels`` pixels of angle ``pixel_angle``: the diagonal gap
    g < 2 r (1 - cos(pi / n)) must be <= pixels x distance x pixel_angle. Even n (the
    latitude bands are n / 2, so their step equals the longitude step)."""
    if not (distance > 0.0 and np.isfinite(distance)):
        return hi if not np.isinf(distance) else lo
    tolerance = pixels * distance * pixel_angle
    n = tessellate.sphere_segments_for_sagitta(radius, 0.5 * tolerance, lo=lo, hi=hi)
    return int(min(n + (n % 2), hi))


def retessellate_sphere(surface, segments: int):
    """``surface`` (a UsdGeom.Sphere with ``surface.sphere`` set) with ``segments``
    longitudes: the reader's transform applied to ``tessellate.sphere`` (points affinely,
    normals by the inverse transpose, winding reversed by a mirroring transform)."""
    radius, m = surface.sphere
    m = np.asarray(m, dtype=np.float64).reshape(4, 4)
    pts, tris, nrm = tessellate.sphere(radius, segments)
    linear, shift = m[:3, :3], m[3, :3]
    world = pts @ linear + shift
    det = float(np.linalg.det(linear))
    normals = None
    if abs(det) > 1e-300:
        n = nrm @ np.linalg.inv(linear).T
        length = np.linalg.norm(n, axis=1, keepdims=True)
        normals = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    if det < 0:
        tris = tris[:, [0, 2, 1]]
    st = None  # a sphere has no st primvar: its textures read the reader's constant fallback
    if surface.st is not None and len(surface.st):
        st = np.broadcast_to(np.asarray(surface.st)[:1, :1], (len(tris), 3, 2))
    return dataclasses.replace(surface, points=world, triangles=np.ascontiguousarray(tris, dtype=np.int64),
                               normals=normals, st=st)


def _camera_stretch(cam) -> float:
    """Factor by which a moving camera can magnify angles relative to (size / lab lookback); inf: no bound."""
    beta = float(np.linalg.norm(cam.velocity))
    if beta == 0.0:
        return 1.0
    if beta >= 1.0:
        return np.inf
    if cam.decoupled:
        return (1.0 + beta) / (1.0 - beta)
    return float(np.sqrt((1.0 + beta) / (1.0 - beta)))


def _decoupled_stretch(direction: np.ndarray, v: np.ndarray, cap: float) -> float:
    """Largest angular magnification |n + v| / (1 + n.v) of a decoupled body's retarded
    image over the look directions n within ``cap`` radians of ``direction`` (|v| < 1).

    It depends on the angle psi between n and v only and peaks at cos psi = -|v|
    (value gamma); it is 1 looking along or against v.
    """
    beta = float(np.linalg.norm(v))
    if beta == 0.0:
        return 1.0
    psi0 = float(np.arccos(np.clip(direction @ v / beta, -1.0, 1.0)))
    lo, hi = max(psi0 - cap, 0.0), min(psi0 + cap, np.pi)
    peak = float(np.arccos(-beta))
    psi = peak if lo <= peak <= hi else (lo if abs(lo - peak) < abs(hi - peak) else hi)
    u = np.cos(psi)
    return float(np.sqrt(max(1.0 + beta * beta + 2.0 * beta * u, 0.0)) / (1.0 + beta * u))


def _sphere_view_distance(body: Body, centre_ref: np.ndarray, r_world: float, cameras, modes) -> float:
    """min over frames of (nearest lab distance of the sphere's surface to the camera over
    the lab times the frame can see) / (magnification of the image: camera motion, and for
    a decoupled body its retarded stretch); 0 when a camera is inside, inf when no frame
    sees it, NaN when there is no bound (a camera or decoupled body at |v| >= 1)."""
    A = contraction_matrix(body.velocity, body.decoupled)
    m0 = (centre_ref - body.origin) @ A.T + body.origin
    v = np.asarray(body.velocity, dtype=np.float64)
    if body.decoupled and body.speed >= 1.0:
        return np.nan
    best = np.inf
    for cam in cameras:
        stretch = _camera_stretch(cam)
        if not np.isfinite(stretch):
            return np.nan
        c = np.asarray(cam.position, dtype=np.float64)
        for infinite in modes:
            win = frame_window(m0, r_world, v, body.reference_time, cam.time, c, infinite=infinite)
            if win is None:
                continue
            lo, hi = max(win[0], body.lifetime[0]), min(win[1], body.lifetime[1])
            if not lo <= hi:
                continue
            # nearest point of the centre's segment m0 + v (t - t_ref), t in [lo, hi], to c
            a = m0 + v * (lo - body.reference_time) - c
            seg = v * (hi - lo)
            ss = float(seg @ seg)
            u = 0.0 if ss == 0.0 or not np.isfinite(ss) else float(np.clip(-(a @ seg) / ss, 0.0, 1.0))
            d = float(np.linalg.norm(a + u * seg)) - r_world
            if not infinite:  # every event seen is at lookback t_c - t >= t_c - hi
                d = max(d, float(cam.time) - hi)
            if d <= 0.0:
                return 0.0
            body_stretch = 1.0
            if body.decoupled and not infinite and body.speed > 0.0:
                # the retarded stretch over the window (sampled; the window of one frame is short)
                for x in np.unique(np.concatenate([np.linspace(0.0, 1.0, 17), [u]])):
                    w = a + x * seg
                    dist = float(np.linalg.norm(w))
                    cap = float(np.arcsin(min(1.0, r_world / dist)))
                    body_stretch = max(body_stretch, _decoupled_stretch(w / dist, v, cap))
            best = min(best, d / (stretch * body_stretch))
    return best


def adapt_sphere_tessellation(scene: Scene, cameras, *, width: int, height: int, modes=(False,),
                              max_depth: int = 0, pixels: float = 0.5):
    """Re-tessellate every UsdGeom.Sphere of ``scene`` at the cheapest level whose error
    stays under ``pixels`` pixels in every frame.

    cameras: the CameraStates of every frame (and shutter sample) the database serves;
    modes: the light-speed modes in use (True = infinite).
    Returns (scene, {surface prim path: segments}); the scene is ``scene`` itself when it
    has no analytic sphere. Surfaces without ``sphere`` are untouched.
    """
    chosen = sphere_tessellation(scene, cameras, width=width, height=height, modes=modes, max_depth=max_depth,
                                 pixels=pixels)
    return retessellated(scene, chosen), chosen


def sphere_tessellation(scene: Scene, cameras, *, width: int, height: int, modes=(False,), max_depth: int = 0,
                        pixels: float = 0.5) -> dict[str, int]:
    """The choice of ``adapt_sphere_tessellation`` without re-tessellating: {surface
    prim path: segments} for every analytic sphere that gets one (cheap: no triangles)."""
    cameras = list(cameras)
    if not cameras or not any(s.sphere is not None for b in scene.bodies for s in b.surfaces):
        return {}
    angle = min((min_pixel_angle(c, width, height) for c in cameras), default=np.inf)
    mirrors = max_depth > 0 and any(s.material.metallic > 0.0 for b in scene.bodies for s in b.surfaces)
    chosen: dict[str, int] = {}
    for body in scene.bodies:
        for surf in body.surfaces:
            if surf.sphere is None:
                continue
            radius, m = surf.sphere
            m = np.asarray(m, dtype=np.float64).reshape(4, 4)
            r_world = float(radius) * float(np.linalg.svd(m[:3, :3], compute_uv=False).max())
            distance = _sphere_view_distance(body, m[3, :3], r_world, cameras, modes)
            if np.isnan(distance):  # no bound on the magnification: keep the reader's tessellation
                continue
            n = sphere_segments_for_view(r_world, distance, angle, pixels=pixels)
            if mirrors:  # reflections can magnify: never coarser than the reader's default
                n = max(n, tessellate.DEFAULT_SPHERE_SEGMENTS)
            chosen[surf.prim_path] = max(n, chosen.get(surf.prim_path, 0))  # an animated body's pieces share it
    return chosen


def retessellated(scene: Scene, chosen: dict[str, int]) -> Scene:
    """``scene`` with every analytic sphere named in ``chosen`` re-tessellated at its
    segments (``scene`` itself when ``chosen`` is empty)."""
    if not chosen:
        return scene
    bodies = []
    for body in scene.bodies:
        surfaces = tuple(retessellate_sphere(s, chosen[s.prim_path]) if s.sphere is not None and s.prim_path in chosen
                         else s for s in body.surfaces)
        changed = any(a is not b for a, b in zip(surfaces, body.surfaces))
        bodies.append(dataclasses.replace(body, surfaces=surfaces) if changed else body)
    return dataclasses.replace(scene, bodies=tuple(bodies))
