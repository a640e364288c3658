"""How early a ball at rest can still cast a shadow the frames see (``spacetime.reach``).

``visibility_windows`` bounds the shadow rays of a body's hit events by balls around its
pieces; a floor of two triangles is one ball of its whole size, and every time such a
ball can be seen at reaches the occluders. For the stand-ins of animated bodies (balls at
rest over their chunks' times) a tighter bound holds where the scene is simple enough:
every light distant with a fixed direction, every other body at rest, no mirror path.

A shadow ray towards a distant light leaves a hit event H = (t_H, x_H) along l (towards
the light) back in time, x_H + s l at t_H - s. It meets the ball B(m, rho) only if x_H
lies within rho of the line m - s' l with s' = (m - x_H).l >= -rho, and then at
s <= s' + rho. x_H lies on a surface: s' <= S, the largest s' of any surface point of
the scene within that cylinder (per triangle: its vertices' range of s', cut to the
ellipse the cylinder makes in its plane; per analytic shape or stand-in ball: its ball's).
H is seen: t_H = t_c - |x_H - c| for a camera event (t_c, c), and |x_H - m| <= s + rho.
So the occluding event is at t >= t_c - |m - c| - 2 S - 3 rho, and, as every event on
the path, at t <= t_c.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.deform import deforming
from warp_st.core.scene import Scene

__all__ = ["analytic_ball", "static_shadow_scene", "earliest_shadow_times"]


def analytic_ball(surface):
    """(centre, radius) of a ball holding the analytic sphere or quadric ``surface``'s
    triangles approximate (traced exactly, or re-tessellated finer, it reaches past its
    points); None for a surface whose triangles are exact."""
    shape = surface.sphere if surface.sphere is not None else surface.quadric
    if shape is None:
        return None
    m = np.asarray(shape[-1], dtype=np.float64).reshape(4, 4)
    if surface.sphere is not None:
        half = float(surface.sphere[0])
    else:
        kind, _axis, radius, height = surface.quadric[:4]
        half = radius + 0.5 * height if kind == "capsule" else float(np.hypot(radius, 0.5 * height))
    return m[3, :3].copy(), float(np.linalg.norm(m[:3, :3], ord=2)) * half


def static_shadow_scene(scene: Scene, animated: set, balls: np.ndarray, max_depth: int):
    """(triangles (T, 3, 3), balls (K, 4): centre and radius) of every surface a hit can
    lie on, or None where the bound does not hold (a light not distant or animated, a body
    moving other than the animated ones, a mirror path). ``animated``: the indices of the
    bodies ``balls`` (their stand-ins, which must be at rest) replace."""
    if any(light.kind != "distant" or light.motion is not None for light in scene.lights):
        return None
    if max_depth > 0 and any(s.material.metallic > 0.0 for b in scene.bodies for s in b.surfaces):
        return None
    triangles, shapes = [], [np.asarray(balls, dtype=np.float64).reshape(-1, 4)]
    for i, body in enumerate(scene.bodies):
        if i in animated:
            continue
        if body.motion is not None or deforming(body) or np.any(np.asarray(body.velocity) != 0.0):
            return None
        for s in body.surfaces:
            ball = analytic_ball(s)
            if ball is None:
                triangles.append(np.asarray(s.points, dtype=np.float64)[np.asarray(s.triangles, dtype=np.int64)])
            else:
                shapes.append(np.array([[*ball[0], ball[1]]]))
    tri = np.concatenate(triangles) if triangles else np.zeros((0, 3, 3))
    return tri, np.concatenate(shapes)


def _deepest(m: np.ndarray, rho: float, l: np.ndarray, tri: np.ndarray, balls: np.ndarray) -> float:
    """S: the largest s' = (m - x).l of a surface point x within rho of the line m - s' l
    (s' >= -rho); -inf where none."""
    best = -np.inf
    if len(balls):
        rel = balls[:, :3] - m
        along = rel @ l
        perp = np.linalg.norm(rel - along[:, None] * l, axis=1)
        near = (perp <= rho + balls[:, 3]) & (-along + balls[:, 3] >= -rho)
        if near.any():
            best = float((-along + balls[:, 3])[near].max())
    if len(tri):
        s = (m - tri) @ l  # (T, 3): s' of the vertices
        lo, hi = s.min(axis=1), s.max(axis=1)
        centre = tri.mean(axis=1)
        reach = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1)
        rel = centre - m
        perp = np.linalg.norm(rel - (rel @ l)[:, None] * l, axis=1)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        nn = np.linalg.norm(n, axis=1)
        nl = n @ l
        slanted = np.abs(nl) > 1e-9 * nn
        with np.errstate(divide="ignore", invalid="ignore"):
            s0 = np.einsum("ij,ij->i", n, m - tri[:, 0]) / nl
            half = rho * np.sqrt(np.maximum(nn * nn - nl * nl, 0.0)) / np.abs(nl)
        lo = np.where(slanted, np.maximum(lo, s0 - half), lo)
        hi = np.where(slanted, np.minimum(hi, s0 + half), hi)
        near = (perp <= rho + reach) & (lo <= hi) & (hi >= -rho)
        if near.any():
            best = max(best, float(hi[near].max()))
    return best


def earliest_shadow_times(shadow_scene, lights, balls: np.ndarray, cameras) -> np.ndarray:
    """Per ball (K, 4) at rest: the earliest lab time at which it can occlude a shadow ray
    of an event the camera events ``cameras`` see (+inf: none), by the module's bound."""
    tri, shapes = shadow_scene
    times = np.array([c.time for c in cameras], dtype=np.float64)
    where = np.array([np.asarray(c.position, dtype=np.float64) for c in cameras])
    out = np.full(len(balls), np.inf)
    for k, (cx, cy, cz, rho) in enumerate(balls):
        m = np.array([cx, cy, cz])
        deepest = max((_deepest(m, rho, np.asarray(light.direction, dtype=np.float64), tri, shapes)
                       for light in lights), default=-np.inf)
        if not np.isfinite(deepest):
            continue  # no surface behind the ball from any light: it shadows nothing
        out[k] = float((times - np.linalg.norm(where - m, axis=1)).min()) - 2.0 * deepest - 3.0 * rho
    return out
