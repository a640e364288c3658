"""Helpers (not tests): a wheel animated in its own rest frame (``spacetime:animationFrame =
"rest"``, docs/spec.md §2.1, addition 0.7.0) and its closed-form world-tube.

The wheel is a convex N-gon prism (circumradius R, thickness H, axis Z) below the body
prim /Wheel, whose pivot o is at ``PIVOT``; in the frame S' moving with v = (V, 0, 0) it
turns about Z at w' = V / R (rim speed V, rolling without slipping on the ground y =
o_y - R), rotateZ sampled every time code. The oracle is the Lorentz boost of that
rotation (``warp_st.core.lorentz``, float64), not the code under test.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.lorentz import boost, lab_from_rest

V, R, H, N = 0.8, 1.0, 0.3, 24
PIVOT = np.array([0.5, 1.0, -0.25])
T_REF = 3.0  # spacetime:referenceTime: S' has t' = 0 at the lab event (T_REF, PIVOT)
REST_CODES = (-12, 12)  # the rest frame's time codes sampled (t' = time code: light speed 1)
OMEGA = V / R  # rad per rest time unit
PHASE = 0.1  # the first vertex's angle (so no vertex starts exactly at the top)


def rest_vertices() -> np.ndarray:
    """The prism's vertices at t' = 0, relative to the pivot, (2N, 3)."""
    phi = PHASE + 2.0 * np.pi * np.arange(N) / N
    ring = np.stack([R * np.cos(phi), R * np.sin(phi), np.zeros(N)], axis=1)
    return np.concatenate([ring + (0, 0, H / 2), ring - (0, 0, H / 2)])


def wheel_stage(*, camera_z: float = 8.0, frame_attrs: str = 'custom uniform token spacetime:animationFrame = "rest"',
                spin: bool = True, caps: bool = True) -> str:
    """The stage's text: a camera at rest on +Z looking at the pivot; the wheel (no lights: the
    visible windows stay short); without ``caps`` only its tread (the prism's sides)."""
    pts = rest_vertices()
    counts = ([N, N] if caps else []) + [4] * N
    top = list(range(N)) if caps else []
    bottom = list(range(2 * N - 1, N - 1, -1)) if caps else []
    sides = [i for k in range(N) for i in (k, N + k, N + (k + 1) % N, (k + 1) % N)]
    lo, hi = REST_CODES
    angles = {t: -np.degrees(OMEGA * t) if spin else 0.0 for t in range(lo, hi + 1)}
    samples = ", ".join(f"{t}: {float(a)!r}" for t, a in angles.items())
    points = ", ".join(f"({float(x)!r}, {float(y)!r}, {float(z)!r})" for x, y, z in pts)
    ox, oy, oz = (float(c) for c in PIVOT)
    return f'''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 20
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeCameraAPI"])
{{
    double3 xformOp:translate = ({ox!r}, {oy!r}, {camera_z!r})
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 30
}}
def Xform "Wheel" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    {frame_attrs}
    custom double4 spacetime:fourVelocity = (2, {2 * V!r}, 0, 0)
    custom double spacetime:referenceTime = {T_REF!r}
    double3 xformOp:translate = ({ox!r}, {oy!r}, {oz!r})
    double xformOp:rotateZ.timeSamples = {{ {samples} }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    def Mesh "Rim"
    {{
        point3f[] points = [{points}]
        int[] faceVertexCounts = {counts}
        int[] faceVertexIndices = {top + bottom + sides}
    }}
}}
'''


def rotation(t_rest) -> np.ndarray:
    """Rot_z(-w' t') (column vectors): USD's rotateZ of -degrees(w' t'), (..., 3, 3)."""
    a = -OMEGA * np.asarray(t_rest, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    m = np.zeros(np.shape(a) + (3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1], m[..., 2, 2] = c, -s, s, c, 1.0
    return m


def lab_event(r, t_rest) -> np.ndarray:
    """The lab event (t, x) of the rest offset ``r`` (at t' = 0) at rest time ``t_rest``: the
    boost of (t', Rot(w' t') r), shifted to S'’s origin event (T_REF, PIVOT)."""
    y = rotation(t_rest) @ np.asarray(r, dtype=np.float64)
    rest = np.concatenate([[t_rest], y])
    return np.concatenate([[T_REF], PIVOT]) + lab_from_rest(np.array([V, 0.0, 0.0])) @ rest


def to_rest(times, points) -> tuple[np.ndarray, np.ndarray]:
    """Lab events -> (t', the offset at t' = 0 that is there: Rot(w' t')^-1 y)."""
    ev = np.concatenate([np.asarray(times, dtype=np.float64)[:, None] - T_REF, np.asarray(points) - PIVOT], axis=1)
    rest = ev @ boost(np.array([V, 0.0, 0.0])).T
    t_rest, y = rest[:, 0], rest[:, 1:]
    return t_rest, np.einsum("nji,nj->ni", rotation(t_rest), y)  # R^-1 = R^T


def prism_distance(r, *, caps: bool = True) -> np.ndarray:
    """|signed distance| of rest offsets from the N-gon prism: the largest of its face planes'
    n.r - d (exact inside; a lower bound outside, exact near a face's middle); without
    ``caps`` from its tread, the side planes only (hits have |z| <= H / 2: checked)."""
    r = np.asarray(r, dtype=np.float64)
    mid = PHASE + 2.0 * np.pi * (np.arange(N) + 0.5) / N  # the side faces' normals
    apothem = R * np.cos(np.pi / N)
    sides = r[:, :1] * np.cos(mid) + r[:, 1:2] * np.sin(mid) - apothem  # (n, N)
    if not caps:
        assert (np.abs(r[:, 2]) <= H / 2 + 2e-3).all()
        return np.abs(sides.max(axis=1))
    z = np.abs(r[:, 2:]) - H / 2
    return np.abs(np.concatenate([sides, z], axis=1).max(axis=1))
