"""Primary-ray coverage of circular_orbit.usda's coupled moon (issue 18) against a float64
march of every pixel's primary ray through the closed-form moon: its pivot on the circle of
radius 5 at 0.8c, the rest shape (a unit ball and a 0.6 cube at z = 1) turned with the orbit,
then contracted along the pivot's instantaneous velocity about the pivot (docs/spec.md
§2.1's coupled convention). The moon holds a Sphere, so it is traced as pieces of uniform
motion (spacetime/turning.py), and this counts what their seams cost: holes (the shrunk
march says moon, the render does not) and extras (the render says moon, the grown march
does not) away from the silhouette (``wheel_coverage.away_from_silhouette``). The planet
in front of the moon is left out of the march's moon, as it is of the render's.

    python examples/animation/orbit_coverage.py FRAME [WIDTH HEIGHT]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from wheel_coverage import away_from_silhouette

ORBIT = Path(__file__).resolve().parent / "circular_orbit.usda"
RATE = np.radians(916.7324722093172 / 100.0)  # the orbit's rotateY, radians per time code (0..100)
RADIUS, HEIGHT = 5.0, 1.5  # the pivot's circle about the y axis, at y = 1.5
BALL = 1.0
MARKER_CENTRE, MARKER_HALF = np.array([0.0, 0.0, 1.0]), 0.3
PLANET = (np.array([0.0, 1.5, 0.0]), 1.5)
REACH = 1.4  # the moon's points lie within this of its pivot (the marker's far corner: 1.36)


def pivot(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pivot, velocity, turn angle) at lab times t (held outside time codes 0..100)."""
    th = RATE * np.clip(t, 0.0, 100.0)
    moving = ((t > 0.0) & (t < 100.0)).astype(np.float64)
    c, s = np.cos(th), np.sin(th)
    o = np.stack([RADIUS * c, np.full_like(t, HEIGHT), -RADIUS * s], axis=-1)
    v = (RADIUS * RATE * moving)[..., None] * np.stack([-s, np.zeros_like(t), -c], axis=-1)
    return o, v, th


def moon_coordinates(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Lab points p at lab times t in the moon's rest axes: about the pivot, the contraction
    along the velocity undone (x gamma along it), then the turn about y undone."""
    o, v, th = pivot(t)
    y = p - o
    speed = np.linalg.norm(v, axis=-1, keepdims=True)
    gamma = 1.0 / np.sqrt(1.0 - speed * speed)
    unit = np.divide(v, speed, out=np.zeros_like(v), where=speed > 0.0)
    y = y + (gamma - 1.0) * np.sum(y * unit, axis=-1, keepdims=True) * unit
    c, s = np.cos(th), np.sin(th)  # USD's rotateY: x' = x c + z s, z' = -x s + z c; undone
    return np.stack([y[..., 0] * c - y[..., 2] * s, y[..., 1], y[..., 0] * s + y[..., 2] * c], axis=-1)


def inside_moon(q: np.ndarray, grow: float) -> np.ndarray:
    """Whether rest points q (moon axes) are in the ball or the marker grown by ``grow``."""
    ball = np.linalg.norm(q, axis=-1) <= BALL + grow
    return ball | (np.abs(q - MARKER_CENTRE) <= MARKER_HALF + grow).all(-1)


def march(cam, width: int, height: int, frame: float, grow: float, samples: int = 4096) -> np.ndarray:
    """(H, W) bool: the primary ray (the event at distance s is at t_c - s) meets the moon
    grown by ``grow`` before the planet, sampled ``samples`` times across the slab of the
    orbit's height (the only place the moon can be)."""
    from warp_st.rendering.camera import pixel_directions

    n = pixel_directions(cam, width, height).reshape(-1, 3).astype(np.float64)
    c = np.asarray(cam.position, dtype=np.float64)
    lo, hi = HEIGHT - REACH - abs(grow), HEIGHT + REACH + abs(grow)
    with np.errstate(divide="ignore", invalid="ignore"):
        s0, s1 = (hi - c[1]) / n[:, 1], (lo - c[1]) / n[:, 1]
    s0, s1 = np.maximum(np.minimum(s0, s1), 0.0), np.maximum(s0, s1)
    s1 = np.where(np.isfinite(s1), s1, 0.0)
    centre, radius = PLANET  # the planet's first crossing (static): the moon behind it is hidden
    w = c - centre
    b = n @ w
    disc = b * b - (w @ w - radius * radius)
    with np.errstate(invalid="ignore"):
        planet = np.where(disc >= 0.0, -b - np.sqrt(np.maximum(disc, 0.0)), np.inf)
    planet = np.where(planet > 0.0, planet, np.inf)
    f = np.linspace(0.0, 1.0, samples)
    out = np.zeros(len(n), bool)
    for a in range(0, len(n), 256):
        s = s0[a:a + 256, None] + f[None] * (s1 - s0)[a:a + 256, None]
        q = moon_coordinates(c + s[..., None] * n[a:a + 256, None, :], frame - s)
        out[a:a + 256] = (inside_moon(q, grow) & (s < planet[a:a + 256, None])).any(1)
    return out.reshape(height, width)


def coverage(frame: float, width: int = 160, height: int = 90, tol: float | None = None) -> dict:
    """{holes, extras, moon (march-shrunk pixels), pieces (the moon's motion segments),
    seconds (a warm render)} of a render of ``frame``; ``tol``: the march's shrink and
    growth (default 0.05 x 160 / width: above the half-pixel modelling error)."""
    import warp_st
    from warp_st.rendering.renderer import Renderer

    tol = 0.05 * 160.0 / width if tol is None else tol
    scene = warp_st.load(str(ORBIT))
    index = scene.body_paths().index("/Orbit/Moon")
    renderer = Renderer(scene, frames=[frame], width=width, height=height)
    renderer.render(frame)
    start = time.perf_counter()
    image = renderer.render(frame)
    seconds = time.perf_counter() - start
    rendered = image.object_id == index + 1
    cam = scene.camera_state(None, frame)
    inside, outside = march(cam, width, height, frame, -tol), ~march(cam, width, height, frame, tol)
    away = away_from_silhouette(inside, outside)
    return {"holes": int((inside & ~rendered & away).sum()), "extras": int((outside & rendered & away).sum()),
            "moon": int(inside.sum()), "pieces": renderer.describe()["animated_segments"], "seconds": seconds}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frame", type=float)
    parser.add_argument("size", type=int, nargs="*", default=[160, 90])
    args = parser.parse_args(argv)
    width, height = args.size
    r = coverage(args.frame, width, height)
    print(f"frame {args.frame:g}, {width} x {height}: {r['holes']} holes, {r['extras']} extras away from the "
          f"silhouette ({r['moon']} moon pixels); {r['pieces']} motion segments; a frame {r['seconds']:.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
