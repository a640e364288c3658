"""Animated UsdLux lights: the light's worldline through USD's interpolation (docs/spec.md §3.4).

A light is animated when an xformOp of its prim or an ancestor has time samples; its
probes are a body's (``warp_st.usd.animation.sample_motion``: USD's
``ComputeLocalToWorldTransform`` at fractional time codes, refined until linear
interpolation follows it), kept on ``Light.motion``. The kernel finds, per hit event,
the emission event on that worldline (``warp_st.kernels.light_track``).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.core.scene import Light
from warp_st.usd.animation import animated_op, sample_motion

__all__ = ["light_in_motion", "light_report"]


def light_in_motion(where, prim, light: Light, samples: tuple[float, ...], notes) -> Light:
    """``light`` with its animated worldline over USD's ``samples`` (none: unchanged). A
    light animated at >= c warns (its retarded position is then not unique)."""
    if len(samples) < 2:
        return light
    motion = sample_motion(where, prim, np.zeros(3), 0.0, samples)
    speeds = np.linalg.norm(motion.chord_velocities(), axis=1)
    if speeds.size and float(speeds.max()) >= 1.0 and light.kind != "distant":
        owner, op = animated_op(prim)
        notes.warn(owner, op, f"the animated light {prim.GetPath()} moves at {float(speeds.max()):.6g} c "
                              "(>= the speed of light): each hit is lit from one of its emission events",
                   "Superluminal")
    return dataclasses.replace(light, motion=motion)


def light_report(lights) -> list[tuple[str, str]]:
    """(light prim path, one line) per animated light: its USD samples and its speed range
    (a DistantLight: its largest turn rate)."""
    lines = []
    for light in lights:
        m = light.motion
        if m is None:
            continue
        samples = m.sample_times
        text = f"animated light: {len(samples)} time samples ({samples[0]:g} to {samples[-1]:g}), "
        if light.kind == "distant":
            d = np.asarray(light.direction, dtype=np.float64) @ m.linear
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", d[:-1], d[1:]), -1.0, 1.0))) / np.diff(m.times)
            text += f"turning up to {float(turn.max()):.4g} degrees per time code (direction at each hit's time)"
        else:
            speeds = np.linalg.norm(m.chord_velocities(), axis=1)
            text += (f"speed {float(speeds.min()):.4g} to {float(speeds.max()):.4g} c "
                     "(each hit lit from its retarded position)")
        lines.append((light.prim_path, text))
    return lines
