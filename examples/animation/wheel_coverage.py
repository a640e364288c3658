"""Primary-ray coverage of the 0.45c rolling wheel (rolling_wheel.usda, issue 18) against a
float64 march of every pixel's primary ray through the closed-form rotating, contracted
wheel (docs/spec.md §2.1's coupled convention: the rest shape turned, then contracted along
the pivot's velocity about the pivot). Counts the holes (march-shrunk says wheel, the
render does not) and extras (the render says wheel, the march grown does not) away from the
silhouette (not within 1 px of a pixel the shrunk and grown marches disagree on, or whose
3 x 3 neighbours the shrunk march does not agree on).

    python examples/animation/wheel_coverage.py FRAME [WIDTH HEIGHT] [--pieces]

--pieces: primitive="rigid" asked for explicitly (the pieces of uniform motion, as before
per-vertex worldlines took coupled bodies on a moving pivot); default: the worldlines.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

WHEEL = Path(__file__).resolve().parent / "rolling_wheel.usda"
SPEED = 0.45  # the pivot: x from -22.5 to 22.5 over time codes 0-100, at y = 1
GAMMA = 1.0 / np.sqrt(1.0 - SPEED * SPEED)
RATE = -2887.1530072877395 / 100.0  # rotateZ, degrees per time code
SPOKES = (0.0, 45.0, 90.0, 135.0)  # each a unit cube scaled (1.9, 0.12, 0.3) at z + 0.2
SPOKE_HALF = np.array([0.95, 0.06, 0.15])
TYRE = (1.0, 0.125)  # radius, half height, about Z
TOL = 0.01  # the march's shrink and growth (> the half-pixel modelling error at 160 x 90)


def wheel_coordinates(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Lab points at lab times t in the wheel's rest axes (closed form): about the pivot,
    the contraction along x undone (x gamma), then the turn undone."""
    y = p - np.stack([-22.5 + SPEED * t, np.ones_like(t), np.zeros_like(t)], axis=-1)
    y = y * np.array([GAMMA, 1.0, 1.0])
    th = np.radians(RATE * t)
    c, s = np.cos(th), np.sin(th)
    return np.stack([y[..., 0] * c + y[..., 1] * s, -y[..., 0] * s + y[..., 1] * c, y[..., 2]], axis=-1)


def inside_wheel(q: np.ndarray, grow: float) -> np.ndarray:
    """Whether rest points q (wheel axes) are in the tyre or a spoke grown by ``grow``."""
    rho = np.hypot(q[..., 0], q[..., 1])
    inside = (rho <= TYRE[0] + grow) & (np.abs(q[..., 2]) <= TYRE[1] + grow)
    for a in np.radians(SPOKES):
        c, s = np.cos(a), np.sin(a)
        local = np.stack([q[..., 0] * c + q[..., 1] * s, -q[..., 0] * s + q[..., 1] * c, q[..., 2] - 0.2], axis=-1)
        inside |= (np.abs(local) <= SPOKE_HALF + grow).all(-1)
    return inside


def march(cam, width: int, height: int, frame: float, grow: float) -> np.ndarray:
    """(H, W) bool: the primary ray (finite c: the event at distance s is at t_c - s) meets
    the wheel grown by ``grow`` (negative: shrunk), sampled every ~1.2e-3 along the slab
    of the wheel's z extent (the only place it can be)."""
    from warp_st.rendering.camera import pixel_directions

    n = pixel_directions(cam, width, height).reshape(-1, 3).astype(np.float64)
    c = np.asarray(cam.position, dtype=np.float64)
    lo, hi = -TYRE[1] - abs(grow), 0.35 + abs(grow)
    with np.errstate(divide="ignore"):
        s0, s1 = (hi - c[2]) / n[:, 2], (lo - c[2]) / n[:, 2]
    s0, s1 = np.minimum(s0, s1), np.maximum(s0, s1)
    f = np.linspace(0.0, 1.0, 512)
    out = np.zeros(len(n), bool)
    for a in range(0, len(n), 2048):
        s = s0[a:a + 2048, None] + f[None] * (s1 - s0)[a:a + 2048, None]
        q = wheel_coordinates(c + s[..., None] * n[a:a + 2048, None, :], frame - s)
        out[a:a + 2048] = inside_wheel(q, grow).any(1)
    return out.reshape(height, width)


def away_from_silhouette(inside: np.ndarray, outside: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels not within 1 px of one the shrunk (``inside``) and grown
    (``~outside``) marches disagree on, or whose 3 x 3 neighbours ``inside`` does not agree on."""
    edge = ~(inside | outside)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            edge |= np.roll(inside, (dy, dx), (0, 1)) != inside
    away = ~edge
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            away &= ~np.roll(edge, (dy, dx), (0, 1))
    return away


def coverage(frame: float, width: int = 160, height: int = 90, primitive: str | None = None) -> dict:
    """{holes, extras, wheel (march-shrunk pixels), model, tau (the largest |properTime -
    t / gamma| over the wheel's hits, t their lab time: the pivot's proper time from t_ref 0),
    intervals (motion segments or sample intervals), tetrahedra, seconds (the render, after
    a first one that builds the database and compiles)} of a render of ``frame``."""
    import warp_st
    from warp_st.rendering.renderer import Renderer
    from warp_st.spacetime.turning import is_worldlines

    scene = warp_st.load(str(WHEEL))
    index = [b.prim_path for b in scene.bodies].index("/Wheel")
    renderer = Renderer(scene, frames=[frame], width=width, height=height, primitive=primitive)
    import time

    image = renderer.render(frame)
    start = time.perf_counter()
    image = renderer.render(frame)
    seconds = time.perf_counter() - start
    rendered = image.object_id == index + 1
    tau = np.abs(image.proper_time[rendered].astype(np.float64) - image.event_time[rendered] / GAMMA)
    cam = scene.camera_state(None, frame)
    inside, outside = march(cam, width, height, frame, -TOL), ~march(cam, width, height, frame, TOL)
    away = away_from_silhouette(inside, outside)
    model = "worldlines" if is_worldlines(dict(renderer.animation)[index]) else "pieces"
    stats = renderer.describe()
    return {"holes": int((inside & ~rendered & away).sum()), "extras": int((outside & rendered & away).sum()),
            "wheel": int(inside.sum()), "model": model, "tau": float(tau.max()) if tau.size else float("nan"),
            "intervals": stats["animated_segments"], "tetrahedra": renderer.stats.tetrahedra, "seconds": seconds}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frame", type=float)
    parser.add_argument("size", type=int, nargs="*", default=[160, 90])
    parser.add_argument("--pieces", action="store_true")
    args = parser.parse_args(argv)
    width, height = args.size
    result = coverage(args.frame, width, height, "rigid" if args.pieces else None)
    print(f"frame {args.frame:g}, {width} x {height}, {result['model']}: {result['holes']} holes, "
          f"{result['extras']} extras away from the silhouette ({result['wheel']} wheel pixels); "
          f"properTime - t / gamma up to {result['tau']:.2e}; {result['intervals']} motion segments or sample "
          f"intervals, {result['tetrahedra']} tetrahedra; a frame {result['seconds']:.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
