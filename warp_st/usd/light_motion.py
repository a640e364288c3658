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

__all__ = ["light_in_motion"]


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
