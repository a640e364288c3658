"""Benchmark scenes: host scenes built without USD and the shipped parade stage.

The sphere grid and the single analytic sphere are shared with the tests
(``warp_st.testing``); the cube cloud, the lights and the parade are the benchmarks' own.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from warp_st.core import tessellate
from warp_st.core.scene import Body, Light, Material, Surface
from warp_st.testing import rest_camera, synthetic_scene

ROOT = Path(__file__).resolve().parents[3]
PARADE_USD = ROOT / "usd_scenes" / "relativistic_parade.usda"


def sun() -> Light:
    d = np.array([0.3, 0.8, 0.5])
    return Light("distant", (1.0, 1.0, 1.0), direction=tuple(d / np.linalg.norm(d)), prim_path="/Sun")


def lamp() -> Light:
    return Light("sphere", (40.0, 40.0, 40.0), position=(0.0, 8.0, -20.0), prim_path="/Lamp")


def cube_cloud_scene(count: int, seed: int = 1, *, lights=None):
    """``count`` cubes on a jittered 3D grid in front of the camera, random velocities:
    20% at rest, the rest up to 0.95c in random directions, one third of the moving
    ones Lorentz decoupled; one distant light (``lights`` overrides)."""
    rng = np.random.default_rng(seed)
    cam = rest_camera()
    side = max(1, round(count ** (1.0 / 3.0)))
    pts, tris = tessellate.cube(0.8)
    bodies = []
    for i in range(count):
        ix, iy, iz = i % side, (i // side) % side, i // (side * side)
        centre = np.array([(ix - (side - 1) / 2) * 3.2, (iy - (side - 1) / 2) * 1.8, -14.0 - 2.0 * iz])
        centre += rng.uniform(-0.3, 0.3, 3)
        if rng.random() < 0.2:
            v, decoupled = np.zeros(3), False
        else:
            d = rng.normal(size=3)
            v = rng.uniform(0.1, 0.95) * d / np.linalg.norm(d)
            decoupled = bool(rng.random() < 1.0 / 3.0)
        path = f"/Cubes/Cube_{i}"
        surf = Surface(path, pts + centre, tris, Material(diffuse=tuple(rng.uniform(0.2, 0.9, 3))))
        t_ref = cam.time - float(np.linalg.norm(centre - cam.position))
        bodies.append(Body(path, (surf,), centre, v, t_ref, (-math.inf, math.inf), decoupled))
    return synthetic_scene("cubes", bodies, [sun()] if lights is None else list(lights), cam)


def distinct_shapes(scene):
    """``scene`` with every body's one surface scaled about its pivot by 1 + 0.001 i (body
    i): the same rays meet nearly the same shapes, but no two bodies share one (no instancing)."""
    bodies = []
    for i, b in enumerate(scene.bodies):
        surf = b.surfaces[0]
        pts = (surf.points - b.origin) * (1.0 + 1e-3 * i) + b.origin
        bodies.append(dataclasses.replace(b, surfaces=(dataclasses.replace(surf, points=pts),)))
    return dataclasses.replace(scene, bodies=tuple(bodies))


def load_parade():
    import warp_st

    return warp_st.load(str(PARADE_USD))


def static_version(scene):
    """Every body at rest at its authored position, unbounded lifetime."""
    bodies = tuple(
        dataclasses.replace(b, velocity=np.zeros(3), decoupled=False, lifetime=(-math.inf, math.inf)) for b in scene.bodies
    )
    return dataclasses.replace(scene, bodies=bodies)


def fixed_tessellation(scene, segments: int | None = None):
    """``scene`` with adaptive sphere tessellation off: every analytic sphere keeps the
    reader's tessellation (``segments`` None) or gets ``segments`` longitudes."""
    from warp_st.spacetime.adaptive import retessellate_sphere

    bodies = []
    for b in scene.bodies:
        surfaces = []
        for s in b.surfaces:
            if s.sphere is not None and segments is not None:
                s = retessellate_sphere(s, segments)
            surfaces.append(dataclasses.replace(s, sphere=None))
        bodies.append(dataclasses.replace(b, surfaces=tuple(surfaces)))
    return dataclasses.replace(scene, bodies=tuple(bodies))
