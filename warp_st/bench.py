"""Performance benchmarks: speed against error (``warp-st bench``; a benchmark, not a test).

Suites (``--suites``, default all), every number measured by this script:

- ``scaling``: extrusion, BVH build and render time from ~10^3 to ~10^6 tetrahedra at
  a fixed resolution (a grid of moving UV spheres, unlit; a cloud of moving cubes, lit);
- ``sequence``: a frame sequence from one database (``Renderer(scene, frames=[...])``
  then ``render(f)``) against rebuilding per frame (``warp_st.render(scene, frame=f)``);
- ``precision``: float32 against float64 kernels on the analytic moving sphere
  (``warp_st.core.lorentz.sphere_hit``), at t = 0 and shifted to t = 10^6: time against the
  error of Z and eventTime (total, and beyond the tessellation's own bound);
- ``tessellation``: UV-sphere segments 16...512 against the measured silhouette and
  depth error in pixels and the render time, and the adaptive choice;
- ``slices``: the time-segment length of long extrusions (0.25x...8x the default
  "the body sweeps its own size per segment") against tetrahedra, box size and time;
- ``needs``: no lights means no shadow rays, no mirrors means no reflection rays,
  clipping to the visible window keeps long sequences small, and how much of the lit
  windows an image needs (the slack of the bound);
- ``adaptive``: the shipped parade scene with adaptive sphere tessellation against the
  fixed 64 segments, at several resolutions.

    warp-st bench --quick                       # smoke run, < 30 s with a warm kernel cache
    warp-st bench                               # full run, several minutes
    warp-st bench --suites scaling,precision --out docs/performance.md --json perf.json

Prints one summary table (markdown) on stdout, progress on stderr, and writes the full
report (``--out``, default docs/performance.md) with its plots (``--images``, default
``images/`` next to the report: perf_scaling.png, perf_error.png).

The shared scene builders (``sphere_grid_scene``, ``cube_cloud_scene``, ...) are the ones
``examples/benchmarks/bench_trace.py`` uses.
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import datetime
import json
import math
import os
import platform
import re
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from warp_st.core.scene import SceneError  # numpy only: no warp / pxr import until a suite runs
from warp_st.spacetime.extrude import MIN_SWEEP_FRACTION, SWEEP_FRACTION, TRIANGLE_SWEEP

__all__ = [
    "main",
    "SUITES",
    "summarize",
    "machine_info",
    "bench_camera",
    "synthetic_scene",
    "sphere_grid_scene",
    "cube_cloud_scene",
    "load_parade",
    "static_version",
    "pixel_directions",
    "SphereView",
    "sphere_view_scene",
    "sphere_errors",
    "uv_sphere_gap",
]

SUITES = ("scaling", "sequence", "precision", "tessellation", "slices", "needs", "adaptive")
PARADE_USD = Path(__file__).resolve().parents[1] / "usd_scenes" / "relativistic_parade.usda"


# =========================================================================== shared machinery


def summarize(values):
    values = list(values)
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "runs": values}


def machine_info():
    import warp as wp

    model = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    try:
        load = os.getloadavg()
    except OSError:
        load = (float("nan"),) * 3
    return {
        "cpu": model,
        "cpu_count": os.cpu_count(),
        "usable_cores": usable,
        "warp": wp.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "loadavg": [round(x, 2) for x in load],
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
    }


def _camera_fn(state):
    def camera_state(path, frame):
        return dataclasses.replace(state, time=float(frame) if frame is not None else float(state.time))

    return camera_state


def synthetic_scene(name, bodies, lights, cam_state):
    """A host Scene (no USD) with one camera whose time is the frame (docs/spec.md §3)."""
    from warp_st.core.scene import RenderSettings, Scene

    return Scene(
        source=f"<bench:{name}>",
        bodies=tuple(bodies),
        lights=tuple(lights),
        cameras=(cam_state.prim_path,),
        settings=RenderSettings(),
        camera_state=_camera_fn(cam_state),
        default_camera=cam_state.prim_path,
    )


def bench_camera(focal=27.0):
    """At rest at the origin at t_c = 0, looking down -Z, +Y up; 36 mm aperture."""
    from warp_st.core.scene import CameraState

    return CameraState("/Camera", 0.0, np.zeros(3), np.eye(3), focal_length=focal, horizontal_aperture=36.0,
                       vertical_aperture=20.25)


def sun():
    from warp_st.core.scene import Light

    d = np.array([0.3, 0.8, 0.5])
    return Light("distant", (1.0, 1.0, 1.0), direction=tuple(d / np.linalg.norm(d)), prim_path="/Sun")


def lamp():
    from warp_st.core.scene import Light

    return Light("sphere", (40.0, 40.0, 40.0), position=(0.0, 8.0, -20.0), prim_path="/Lamp")


#: (speed, direction, decoupled) cycled over the bodies of the sphere grid.
SPHERE_MOTIONS = (
    (0.0, (1, 0, 0), False),
    (0.5, (1, 0, 0), False),
    (0.9, (1, 0, 0), False),
    (0.0, (1, 0, 0), False),
    (0.7, (0, 1, 0), False),
    (0.9, (-1, 0, 1), False),
    (0.5, (1, 0, 0), True),
    (0.9, (-1, 0, 0), True),
    (0.6, (0, -1, 0), True),
    (0.3, (1, 1, 0), False),
)


def sphere_grid_scene(segments: int, n: int = 10, *, scale: float | None = None, moving: bool = True,
                      lights=(), mirror_centre: bool = False):
    """n x n tessellated spheres at z = -30 (the 10 x 10 grid of radius 1, spacing 4 x 2.25
    shrunk by ``scale``, default 10 / n, so any n covers the same part of the image),
    mixed velocities (``SPHERE_MOTIONS``) unless ``moving`` is False, unlit by default.

    Each body's reference time is chosen so its centre is seen (on the camera's past
    lightcone) at its grid position: t_ref = t_c - |centre - camera|.
    ``mirror_centre`` makes the sphere nearest the image centre a perfect mirror.
    """
    from warp_st.core import tessellate
    from warp_st.core.scene import Body, Material, Surface

    cam = bench_camera()
    scale = 10.0 / n if scale is None else float(scale)
    pts, tris, nrm = tessellate.sphere(scale, segments)
    bodies = []
    centre_index = (n // 2) * n + n // 2
    for iy in range(n):
        for ix in range(n):
            i = iy * n + ix
            centre = np.array([(ix - (n - 1) / 2) * 4.0 * scale, (iy - (n - 1) / 2) * 2.25 * scale, -30.0])
            speed, direction, decoupled = SPHERE_MOTIONS[i % len(SPHERE_MOTIONS)] if moving else (0.0, (1, 0, 0), False)
            d = np.asarray(direction, float)
            v = speed * d / np.linalg.norm(d)
            colour = tuple(0.25 + 0.6 * np.array([ix / max(n - 1, 1), iy / max(n - 1, 1), 0.5]))
            metallic = 1.0 if (mirror_centre and i == centre_index) else 0.0
            path = f"/Grid/Sphere_{iy}_{ix}"
            surf = Surface(path, pts + centre, tris, Material(diffuse=colour, metallic=metallic), nrm)
            t_ref = cam.time - float(np.linalg.norm(centre - cam.position))
            bodies.append(Body(path, (surf,), centre, v, t_ref, (-math.inf, math.inf), decoupled))
    return synthetic_scene("spheres", bodies, list(lights), cam)


def cube_cloud_scene(count: int, seed: int = 1, *, lights=None):
    """``count`` cubes on a jittered 3D grid in front of the camera, random velocities:
    20% at rest, the rest up to 0.95c in random directions, one third of the moving
    ones Lorentz decoupled; one distant light (``lights`` overrides)."""
    from warp_st.core import tessellate
    from warp_st.core.scene import Body, Material, Surface

    rng = np.random.default_rng(seed)
    cam = bench_camera()
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


def pixel_directions(cam, width, height, sub: int = 1):
    """Unit pixel directions in the camera's rest frame, lab axes, (H*sub, W*sub, 3), row 0
    at the top (docs/spec.md §3 pinhole, written out independently of warp_st/camera.py). With
    ``sub`` > 1 the directions of a sub x sub grid of sample positions in every pixel."""
    i = (np.arange(width * sub, dtype=np.float64) + 0.5) / sub
    j = (np.arange(height * sub, dtype=np.float64) + 0.5) / sub
    x_ndc = 2.0 * i / width - 1.0
    y_ndc = 1.0 - 2.0 * j / height
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    f = float(cam.focal_length)
    X, Y = np.meshgrid((x_ndc * h_ap / 2 + float(cam.horizontal_aperture_offset)) / f,
                       (y_ndc * v_ap / 2 + float(cam.vertical_aperture_offset)) / f)
    d = np.stack([X, Y, -np.ones_like(X)], axis=-1)
    d = d @ np.asarray(cam.rotation, dtype=np.float64).T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def pixel_pitch(cam, width, height):
    """Angle (radians) between each pixel centre and its right / lower neighbour, the
    smaller of the two, (H, W): the local angular size of a pixel."""
    i = np.arange(width + 1, dtype=np.float64) + 0.5
    j = np.arange(height + 1, dtype=np.float64) + 0.5
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    f = float(cam.focal_length)
    X, Y = np.meshgrid(((2.0 * i / width - 1.0) * h_ap / 2 + float(cam.horizontal_aperture_offset)) / f,
                       ((1.0 - 2.0 * j / height) * v_ap / 2 + float(cam.vertical_aperture_offset)) / f)
    d = np.stack([X, Y, -np.ones_like(X)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)

    def angle(a, b):
        return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))

    return np.minimum(angle(d[:-1, :-1], d[:-1, 1:]), angle(d[:-1, :-1], d[1:, :-1]))


def _warp():
    from warp_st.rendering.renderer import _warp as w

    return w()


def time_render(r, frame, runs: int, threads=None):
    """(image, kernel seconds summary, full frame seconds summary, mean BVH visits/ray);
    one warm-up render first."""
    r.render(frame, threads=threads)
    kern, full = [], []
    img = None
    for _ in range(max(1, runs)):
        img = r.render(frame, threads=threads)
        kern.append(r.stats.last_kernel_seconds)
        full.append(r.stats.last_frame_seconds)
    return img, summarize(kern), summarize(full), r.stats.last_mean_visits


def _build(scene, **kw):
    """A Renderer of the 4D extrusion (what these suites measure; issue 17's two-level
    path is examples/benchmarks/bench_two_level.py's) and the seconds its constructor took."""
    from warp_st.rendering.renderer import Renderer

    t0 = time.perf_counter()
    r = Renderer(scene, **{"primitive": "prism", **kw})
    return r, time.perf_counter() - t0


@contextlib.contextmanager
def _cut_windows(early: float, late: float):
    """Renderers built inside drop the earliest ``early`` and the latest ``late``
    fraction of the span of every moving body's visibility window (to measure how much
    of the bound an image needs; the renderer never does this)."""
    from warp_st.rendering import renderer
    from warp_st.spacetime.visibility import intersection, span

    real = renderer.visibility_windows

    def cut(scene, cameras, **kw):
        out = []
        for body, window in zip(scene.bodies, real(scene, cameras, **kw)):
            if window is not None and body.speed > 0.0:
                lo, hi = span(window)
                window = intersection(window, (lo + early * (hi - lo), hi - late * (hi - lo)))
            out.append(window)
        return out

    renderer.visibility_windows = cut
    try:
        yield
    finally:
        renderer.visibility_windows = real


# =========================================================================== analytic sphere


@dataclasses.dataclass(frozen=True)
class SphereView:
    """One sphere seen at its centre (on the camera's past lightcone) at ``distance``
    along -Z from a camera at rest at ``shift_x``, at camera time ``cam_time + shift_t``.

    segments: fixed UV longitudes, or None for the renderer's adaptive choice (the
        surface then carries its analytic ``sphere``, as the USD reader sets it).
    """

    name: str = "sphere"
    radius: float = 1.0
    distance: float = 6.0
    velocity: tuple = (0.0, 0.0, 0.0)
    decoupled: bool = False
    cam_time: float = 6.0
    shift_t: float = 0.0
    shift_x: tuple = (0.0, 0.0, 0.0)
    hfov_deg: float = 48.0
    width: int = 160
    height: int = 120
    segments: int | None = 64
    precision: str = "float32"

    @property
    def centre(self):
        return np.asarray(self.shift_x, dtype=np.float64) + np.array([0.0, 0.0, -self.distance])

    @property
    def t_c(self):
        return float(self.cam_time + self.shift_t)

    @property
    def t_ref(self):
        return self.t_c - self.distance

    def camera(self):
        from warp_st.core.scene import CameraState

        h_ap = 20.955
        focal = 0.5 * h_ap / math.tan(0.5 * math.radians(self.hfov_deg))
        return CameraState("/Camera", self.t_c, np.asarray(self.shift_x, dtype=np.float64), np.eye(3),
                           focal_length=focal, horizontal_aperture=h_ap,
                           vertical_aperture=h_ap * self.height / self.width)


def sphere_view_scene(view: SphereView):
    from warp_st.core import tessellate
    from warp_st.core.scene import Body, Surface

    centre = view.centre
    pts, tris, nrm = tessellate.sphere(view.radius, view.segments or tessellate.DEFAULT_SPHERE_SEGMENTS)
    sphere = None
    if view.segments is None:
        m = np.eye(4)
        m[3, :3] = centre
        sphere = (float(view.radius), m)
    surf = Surface("/Sphere", pts + centre, tris, normals=nrm, sphere=sphere)
    body = Body("/Sphere", (surf,), centre, np.asarray(view.velocity, dtype=np.float64), view.t_ref,
                (-math.inf, math.inf), bool(view.decoupled))
    return synthetic_scene(view.name, [body], [], view.camera())


def uv_sphere_gap(radius: float, segments: int) -> float:
    """g = R - (smallest distance from the centre to a triangle's plane) of the UV sphere."""
    from warp_st.core import tessellate

    pts, tris, _ = tessellate.sphere(radius, segments)
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    nrm = np.cross(b - a, c - a)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    return float(radius - np.abs(np.sum(nrm * a, axis=-1)).min())


def _oracle(view: SphereView, dirs, radius=None):
    from warp_st.core import lorentz

    return lorentz.sphere_hit(view.t_c, np.asarray(view.shift_x, dtype=np.float64), dirs, view.centre,
                              view.radius if radius is None else radius, np.asarray(view.velocity, dtype=np.float64),
                              view.t_ref, decoupled=view.decoupled)


def _boundary_points(mask: np.ndarray, sub: int) -> np.ndarray:
    """Pixel-unit coordinates (x, y) of the midpoints between 4-neighbour samples of a
    sub-sampled mask that disagree (the outline, to 1 / (2 sub) pixel)."""
    pts = []
    ys, xs = np.nonzero(mask[:, 1:] != mask[:, :-1])
    pts.append(np.stack([(xs + 1.0) / sub, (ys + 0.5) / sub], axis=1))
    ys, xs = np.nonzero(mask[1:, :] != mask[:-1, :])
    pts.append(np.stack([(xs + 0.5) / sub, (ys + 1.0) / sub], axis=1))
    return np.concatenate(pts)


def _sample_dirs(cam, width, height, p):
    """Unit lab directions through image positions ``p`` (N, 2) = (x, y) in pixels."""
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    f = float(cam.focal_length)
    x = ((2.0 * p[..., 0] / width - 1.0) * h_ap / 2 + float(cam.horizontal_aperture_offset)) / f
    y = ((1.0 - 2.0 * p[..., 1] / height) * v_ap / 2 + float(cam.vertical_aperture_offset)) / f
    d = np.stack([x, y, -np.ones_like(x)], axis=-1) @ np.asarray(cam.rotation, dtype=np.float64).T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _dilate(mask, k):
    for _ in range(k):
        p = np.pad(mask, 1)
        mask = (p[1:-1, 1:-1] | p[:-2, 1:-1] | p[2:, 1:-1] | p[1:-1, :-2] | p[1:-1, 2:]
                | p[:-2, :-2] | p[:-2, 2:] | p[2:, :-2] | p[2:, 2:])
    return mask


def _fine_mask(view, cam, hit_o, differ, sub):
    """The exact hit mask on a sub x sub grid of samples per pixel, (H sub, W sub): the
    oracle is evaluated only within 2 px of the outline (elsewhere a pixel's samples all
    equal its centre)."""
    p = np.pad(hit_o, 1, mode="edge")
    edge = (p[1:-1, 1:-1] != p[:-2, 1:-1]) | (p[1:-1, 1:-1] != p[2:, 1:-1]) | \
           (p[1:-1, 1:-1] != p[1:-1, :-2]) | (p[1:-1, 1:-1] != p[1:-1, 2:])
    near = _dilate(edge | differ, 2)
    fine = np.repeat(np.repeat(hit_o, sub, axis=0), sub, axis=1)
    ys, xs = np.nonzero(near)
    off = (np.arange(sub) + 0.5) / sub
    sx = xs[:, None, None] + off[None, None, :]
    sy = ys[:, None, None] + off[None, :, None]
    pts = np.stack(np.broadcast_arrays(sx, sy), axis=-1)  # (N, sub, sub, 2)
    hit = np.isfinite(_oracle(view, _sample_dirs(cam, view.width, view.height, pts.reshape(-1, 2))).s)
    hit = hit.reshape(len(ys), sub, sub)
    fy = ys[:, None, None] * sub + np.arange(sub)[None, :, None]
    fx = xs[:, None, None] * sub + np.arange(sub)[None, None, :]
    fine[fy, fx] = hit
    return fine


def _outline_distance(view, cam, centres, outline, inside):
    """Distance (pixels) from each pixel centre to the exact outline: towards the nearest
    point of the sampled ``outline``, the crossing of the exact hit/miss boundary located by
    bisection on the oracle (an upper bound of the true distance, tight where the outline
    is smooth). ``inside``: whether each centre's ray hits the exact sphere."""
    if len(centres) == 0:
        return np.zeros(0)
    if len(outline) == 0:
        return np.full(len(centres), np.inf)
    near = np.empty_like(centres)
    for a in range(0, len(centres), 512):
        p = centres[a:a + 512]
        d2 = ((p[:, None, :] - outline[None, :, :]) ** 2).sum(axis=-1)
        near[a:a + 512] = outline[np.argmin(d2, axis=1)]
    far = centres + 2.0 * (near - centres)  # past the outline: the crossing is in between
    def hits(p):
        return np.isfinite(_oracle(view, _sample_dirs(cam, view.width, view.height, p)).s)

    lo, hi = centres.copy(), far
    crossed = hits(hi) != inside
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        same = hits(mid) == inside
        lo = np.where(same[:, None], mid, lo)
        hi = np.where(same[:, None], hi, mid)
    exact = np.linalg.norm(0.5 * (lo + hi) - centres, axis=1)
    coarse = np.linalg.norm(near - centres, axis=1)
    return np.where(crossed, exact, coarse)


def sphere_errors(img, view: SphereView, *, segments: int | None = None, sub: int = 8) -> dict:
    """Measured errors of a render of ``view`` against the closed-form sphere.

    silhouette_px: the largest image-plane distance (pixels) from a pixel centre whose
        hit/miss differs from the exact sphere's to the exact outline (located on a
        ``sub`` x ``sub`` supersampled oracle, to 1 / (2 sub) px); 0 when none differ.
        A measured lower bound of the outline's displacement that approaches it as the
        outline crosses many pixels.
    depth_px: over every pixel the render hits, how far the rendered hit event (at depth
        Z along the pixel's ray) lies off the exact sphere, |R - |x'||, x' its body-frame
        position relative to the centre (rest frame for a coupled body, co-moving for a
        decoupled one), in pixel footprints Z x (local pixel angle). The polyhedron lies
        between the balls R - g and R, so this is at most g / (Z x pixel angle) plus
        rounding.
    segments: the UV longitudes rendered (needed for the tessellation bound).
    z_abs / t_abs: the largest |Z - Z_exact| and |eventTime - t_exact| (scene units)
        over pixels where the ball of radius R - g is hit too (g the mesh's gap);
    z_num / t_num: the part of those errors outside the tessellation's own bound
        (the first hit of the polyhedron lies between the hits of the balls R and R - g):
        the numerical error.
    """
    cam = view.camera()
    w, h = view.width, view.height
    dirs = pixel_directions(cam, w, h)
    exact = _oracle(view, dirs)
    hit_o = np.isfinite(exact.s)
    hit_r = img.object_id > 0
    out = {"pixels_hit": int(hit_r.sum()), "pixels_exact": int(hit_o.sum())}
    differ = hit_o != hit_r
    out["pixels_differ"] = int(differ.sum())
    if differ.any():
        fine = _fine_mask(view, cam, hit_o, differ, sub)
        outline = _boundary_points(fine, sub)
        ys, xs = np.nonzero(differ)
        centres = np.stack([xs + 0.5, ys + 0.5], axis=1)
        dist = _outline_distance(view, cam, centres, outline, hit_o[ys, xs])
        out["silhouette_px"] = float(dist.max())
        out["silhouette_px_mean"] = float(dist.mean())
    else:
        out["silhouette_px"] = 0.0
        out["silhouette_px_mean"] = 0.0
    z = img.depth.astype(np.float64)
    # body-frame position of each rendered hit event relative to the centre: A + Z B
    from warp_st.core.lorentz import _body_frame_ray

    A, B = _body_frame_ray(view.t_c, np.asarray(view.shift_x, dtype=np.float64), dirs, view.centre,
                           np.asarray(view.velocity, dtype=np.float64), view.t_ref, decoupled=view.decoupled,
                           light_speed="finite")
    with np.errstate(invalid="ignore"):
        off = np.abs(view.radius - np.linalg.norm(A + z[..., None] * B, axis=-1))
        dpx = off / (z * pixel_pitch(cam, w, h))
    out["depth_px"] = float(dpx[hit_r].max()) if hit_r.any() else 0.0
    if segments:
        g = uv_sphere_gap(view.radius, segments)
        inner = _oracle(view, dirs, view.radius - g)
        ok = hit_o & hit_r & np.isfinite(inner.s)
        et = img.event_time
        out["gap"] = g
        out["z_abs"] = float(np.abs(z - exact.s)[ok].max()) if ok.any() else 0.0
        out["t_abs"] = float(np.abs(et - exact.event_time)[ok].max()) if ok.any() else 0.0
        z_lo, z_hi = exact.s, inner.s
        t_hi, t_lo = view.t_c - exact.s, view.t_c - inner.s
        z_num = np.maximum(np.maximum(z_lo - z, z - z_hi), 0.0)
        t_num = np.maximum(np.maximum(t_lo - et, et - t_hi), 0.0)
        out["z_num"] = float(z_num[ok].max()) if ok.any() else 0.0
        out["t_num"] = float(t_num[ok].max()) if ok.any() else 0.0
    return out


def polyhedron_hit(view: SphereView, segments: int, dirs: np.ndarray) -> np.ndarray:
    """Lookback s of the first hit of each pixel ray with the TESSELLATED sphere, float64
    on the host (NaN on a miss): the reference for the renderer's numerical error.

    The extruded world-tube of a body is exactly the set of events whose body-frame
    position (rest frame for a coupled body, co-moving for a decoupled one) lies on its
    rest-shape mesh, and along a past null ray that position is affine in s, A + s B
    (``lorentz._body_frame_ray``); so this is a ray/triangle test (Moller-Trumbore) in
    the body frame against ``tessellate.sphere(R, segments)``.
    """
    from warp_st.core import tessellate
    from warp_st.core.lorentz import _body_frame_ray

    pts, tris, _ = tessellate.sphere(view.radius, segments)
    v0, v1, v2 = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    e1, e2 = v1 - v0, v2 - v0
    A, B = _body_frame_ray(view.t_c, np.asarray(view.shift_x, dtype=np.float64), dirs, view.centre,
                           np.asarray(view.velocity, dtype=np.float64), view.t_ref, decoupled=view.decoupled,
                           light_speed="finite")
    shape = dirs.shape[:-1]
    A, B = A.reshape(-1, 3), B.reshape(-1, 3)
    out = np.full(len(A), np.nan)
    # only rays that reach the ball R can hit the polyhedron inside it
    qa, qb, qc = (B * B).sum(-1), 2.0 * (A * B).sum(-1), (A * A).sum(-1) - view.radius ** 2
    cand = np.nonzero(qb * qb - 4.0 * qa * qc >= 0.0)[0]
    for a in range(0, len(cand), 64):
        idx = cand[a:a + 64]
        o, d = A[idx][:, None, :], B[idx][:, None, :]
        p = np.cross(d, e2[None])
        det = (e1[None] * p).sum(-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = o - v0[None]
            u = (tv * p).sum(-1) * inv
            q = np.cross(tv, e1[None])
            w = (d * q).sum(-1) * inv
            sv = (e2[None] * q).sum(-1) * inv
        ok = (det != 0.0) & (u >= 0.0) & (w >= 0.0) & (u + w <= 1.0) & (sv >= 0.0)
        sv = np.where(ok, sv, np.inf)
        best = sv.min(axis=1)
        out[idx] = np.where(np.isfinite(best), best, np.nan)
    return out.reshape(shape)


def numerical_errors(img, view: SphereView, segments: int) -> dict:
    """The renderer against :func:`polyhedron_hit` (same mesh, exact arithmetic):
    z_poly / t_poly: largest |Z - s| and |eventTime - (t_c - s)| over pixels both hit;
    z_poly_rel: largest |Z - s| / s; hit_differs: pixels whose hit/miss differs (rays
    grazing an edge within rounding)."""
    dirs = pixel_directions(view.camera(), view.width, view.height)
    s = polyhedron_hit(view, segments, dirs)
    hit_p, hit_r = np.isfinite(s), img.object_id > 0
    both = hit_p & hit_r
    z = img.depth.astype(np.float64)
    dz = np.abs(z - s)[both]
    dt = np.abs(img.event_time - (view.t_c - s))[both]
    return {"z_poly": float(dz.max()) if both.any() else 0.0,
            "z_poly_rel": float((dz / s[both]).max()) if both.any() else 0.0,
            "t_poly": float(dt.max()) if both.any() else 0.0,
            "hit_differs": int((hit_p != hit_r).sum())}


def render_view(view: SphereView, runs: int = 1):
    """(Renderer, image, kernel seconds summary, constructor seconds) for ``view``."""
    scene = sphere_view_scene(view)
    r, ctor = _build(scene, frames=[view.t_c], width=view.width, height=view.height, precision=view.precision)
    img, kern, _full, _vis = time_render(r, view.t_c, runs)
    return r, img, kern, ctor


# =========================================================================== suites


def _t(x: float) -> str:
    """A time for a label: 1e6 rather than 1e+06."""
    return f"{x:.0e}".replace("e+0", "e").replace("e+", "e") if abs(x) >= 1e5 else f"{x:g}"


class Bench:
    def __init__(self, args, log):
        self.args = args
        self.log = log
        self.quick = args.quick
        self.runs = args.runs

    # ------------------------------------------------------------------ scaling
    def scaling(self):
        a = self.args
        w, h = a.width, a.height
        if self.quick:
            grids, cubes, segments = [1, 3], [8, 27], [8, 16]
        else:
            grids, cubes, segments = [1, 2, 3, 6, 11, 20], [3, 27, 125, 343, 1000], [8, 16, 32, 64, 80, 128, 256]
        rows = []
        for n in grids:
            scene = sphere_grid_scene(24, n)
            rows.append(self._scale_row("sphere grid", f"{n}x{n} spheres, 24 seg.", scene, w, h))
        for seg in segments:  # the same image, finer and finer tessellation
            scene = sphere_grid_scene(seg, 3)
            rows.append(self._scale_row("tessellated 3x3 grid", f"{seg} seg.", scene, w, h))
        for n in cubes:
            scene = cube_cloud_scene(n)
            rows.append(self._scale_row("moving cubes", f"{n} cubes", scene, w, h))
        return {"width": w, "height": h, "rows": rows}

    def _scale_row(self, family, label, scene, w, h):
        r, ctor = _build(scene, frames=[0.0], width=w, height=h)
        _img, kern, full, visits = time_render(r, 0.0, self.runs)
        st = r.stats
        row = {"family": family, "label": label, "bodies": len(scene.bodies), "tetrahedra": st.tetrahedra,
               "bvh_nodes": st.bvh_nodes, "extrude_s": st.extrude_seconds, "bvh_s": st.bvh_seconds,
               "upload_s": st.upload_seconds, "constructor_s": ctor, "kernel_s": kern, "frame_s": full,
               "visits": visits}
        self.log(f"  [scaling] {label}: {st.tetrahedra:,} tets, BVH {st.bvh_seconds:.3f} s, "
                 f"render {1e3 * kern['median']:.1f} ms")
        return row

    # ------------------------------------------------------------------ sequence
    def sequence(self):
        import warp_st

        scene = load_parade()
        n = 3 if self.quick else 8
        step = 4.0
        frames = [i * step for i in range(n)]
        w, h = (96, 54) if self.quick else (320, 180)
        # warm: kernels loaded once, so neither side pays the compile
        warp_st.render(scene, frame=frames[0], width=w, height=h)
        t0 = time.perf_counter()
        from warp_st.rendering.renderer import Renderer

        r = Renderer(scene, frames=frames, width=w, height=h, primitive="prism")
        build = time.perf_counter() - t0
        per = []
        for f in frames:
            t1 = time.perf_counter()
            r.render(f)
            per.append(time.perf_counter() - t1)
        reuse_total = time.perf_counter() - t0
        shared_tets = r.stats.tetrahedra
        rebuild, single_tets = [], []
        for f in frames:
            t1 = time.perf_counter()
            rr = Renderer(scene, frames=[f], width=w, height=h, primitive="prism")
            rr.render(f)
            rebuild.append(time.perf_counter() - t1)
            single_tets.append(rr.stats.tetrahedra)
        res = {
            "scene": "relativistic_parade.usda", "frames": frames, "width": w, "height": h,
            "reuse_build_s": build, "reuse_render_s": summarize(per), "reuse_total_s": reuse_total,
            "reuse_per_frame_s": reuse_total / n, "rebuild_s": summarize(rebuild),
            "rebuild_total_s": sum(rebuild), "rebuild_per_frame_s": sum(rebuild) / n,
            "shared_tetrahedra": shared_tets, "single_tetrahedra": summarize(single_tets),
        }
        self.log(f"  [sequence] {n} frames: reuse {res['reuse_per_frame_s']:.3f} s/frame, "
                 f"rebuild {res['rebuild_per_frame_s']:.3f} s/frame")
        return res

    # ------------------------------------------------------------------ precision
    def precision(self):
        w, h = (64, 48) if self.quick else (160, 120)
        diag = np.array([1.0, 0.5, -1.0]) / np.linalg.norm([1.0, 0.5, -1.0])
        cases = [
            ("rest, t=0", dict()),
            ("0.9c coupled, t=0", dict(velocity=tuple(0.9 * diag))),
            ("0.9c coupled, t=1e6, x+1e4", dict(velocity=tuple(0.9 * diag), shift_t=1.0e6, shift_x=(1.0e4, 1.0e4, 1.0e4))),
        ]
        segments = 64 if self.quick else 128
        rows = []
        for prec in ("float32", "float64"):
            for label, kw in cases:
                view = SphereView(name=label, width=w, height=h, segments=segments, precision=prec, **kw)
                r, img, kern, _ = render_view(view, self.runs)
                err = sphere_errors(img, view, segments=segments)
                err.update(numerical_errors(img, view, segments))
                rows.append({"precision": prec, "case": label, "segments": segments, "kernel_s": kern,
                             "tetrahedra": r.stats.tetrahedra, "visits": r.stats.last_mean_visits, **err})
                self.log(f"  [precision] {prec} {label}: {1e3 * kern['median']:.1f} ms, {r.stats.tetrahedra:,} tets, "
                         f"Z err vs mesh {err['z_poly']:.2e}, t {err['t_poly']:.2e}; vs sphere {err['z_abs']:.2e}")
        return {"width": w, "height": h, "rows": rows}

    # ------------------------------------------------------------------ tessellation
    def tessellation(self):
        w, h = (96, 72) if self.quick else (320, 240)
        segs = [16, 32, 64] if self.quick else [16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512]
        series = [("rest", dict())]
        if not self.quick:
            series.append(("0.9c coupled", dict(velocity=(0.9, 0.0, 0.0))))
        rows = []
        for name, kw in series:
            for n in segs + [None]:
                view = SphereView(name=name, width=w, height=h, segments=n, **kw)
                r, img, kern, ctor = render_view(view, self.runs)
                chosen = n if n is not None else r.sphere_segments.get("/Sphere")
                err = sphere_errors(img, view, segments=chosen)
                rows.append({"series": name, "segments": chosen, "adaptive": n is None, "kernel_s": kern,
                             "constructor_s": ctor, "tetrahedra": r.stats.tetrahedra,
                             "bvh_s": r.stats.bvh_seconds, **err})
                self.log(f"  [tessellation] {name} {'adaptive ' if n is None else ''}{chosen} seg: "
                         f"silhouette {err['silhouette_px']:.3f} px, depth {err['depth_px']:.3f} px, "
                         f"{1e3 * kern['median']:.1f} ms")
        return {"width": w, "height": h, "rows": rows}

    # ------------------------------------------------------------------ slices
    def slices(self):
        import warp_st.spacetime.extrude as ex

        w, h = (96, 54) if self.quick else (320, 180)
        n = 4 if self.quick else 5
        frames = [0.0, 20.0] if self.quick else [float(f) for f in range(0, 101, 10)]
        mid = frames[len(frames) // 2]
        series = [
            (f"{n}x{n} sphere grid (16 seg.), frames {frames[0]:g}–{frames[-1]:g}, frame {mid:g} rendered",
             sphere_grid_scene(16, n), frames, mid,
             [0.5, 1.0, 4.0] if self.quick else [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]),
        ]
        one = SphereView(width=w, height=h, segments=32 if self.quick else 64, velocity=(0.9, 0.0, 0.0))
        series.append((f"one sphere at 0.9c ({one.segments} seg.), single frame", sphere_view_scene(one), [one.t_c],
                       one.t_c, [0.125, 1.0] if self.quick else [1 / 32, 1 / 16, 0.125, 0.25, 0.5, 1.0]))
        rows = []
        for label, scene, fr, render_at, factors in series:
            for fac in [*factors, None]:  # None: the default rule (extrude.segment_sweep)
                with sweep_factor(fac):
                    r, ctor = _build(scene, frames=fr, width=w, height=h)
                _img, kern, _full, visits = time_render(r, render_at, self.runs)
                box = _box_stats(r.mesh)
                rows.append({"series": label, "factor": fac, "tetrahedra": r.stats.tetrahedra,
                             "extrude_s": r.stats.extrude_seconds, "bvh_s": r.stats.bvh_seconds, "constructor_s": ctor,
                             "kernel_s": kern, "visits": visits, **box})
                self.log(f"  [slices] {label.split(',')[0]} {_factor(fac)}: {r.stats.tetrahedra:,} tets, "
                         f"box/size {box['box_over_size']:.2f}, {visits:.1f} visits/ray, {1e3 * kern['median']:.1f} ms")
        assert ex.body_slices is _ORIGINAL_BODY_SLICES[0]
        return {"width": w, "height": h, "rows": rows}

    # ------------------------------------------------------------------ needs
    def needs(self):
        w, h = (96, 54) if self.quick else (320, 180)
        n = 4 if self.quick else 10
        res = {"width": w, "height": h}
        # (a) lights: shadow rays only when the scene has lights
        rows = []
        for label, lights in (("no light", ()), ("1 distant light", (sun(),)), ("distant + sphere light", (sun(), lamp()))):
            scene = sphere_grid_scene(24, n, lights=lights)
            r, ctor = _build(scene, frames=[0.0], width=w, height=h)
            _img, kern, _full, visits = time_render(r, 0.0, self.runs)
            row = {"case": label, "lights": len(lights), "tetrahedra": r.stats.tetrahedra, "constructor_s": ctor,
                   "kernel_s": kern, "visits": visits}
            if lights:  # the same database traced without its lights: isolates the shadow rays
                r.scene = dataclasses.replace(scene, lights=())
                _img, kern0, _f, _v = time_render(r, 0.0, self.runs)
                row["kernel_s_same_db_unlit"] = kern0
            rows.append(row)
            self.log(f"  [needs] {label}: {r.stats.tetrahedra:,} tets, {1e3 * kern['median']:.1f} ms")
        res["lights"] = rows
        # (b) mirrors: reflection rays only where a surface is metallic
        rows = []
        for label, mirror in (("no mirror", False), ("one mirror sphere", True)):
            scene = sphere_grid_scene(24, n, mirror_centre=mirror)
            images = {}
            for depth in ((0, 4) if self.quick else (0, 1, 4)):
                try:
                    r, ctor = _build(scene, frames=[0.0], width=w, height=h, max_depth=depth)
                except SceneError as exc:  # the memory guard: report the size it refused
                    count = re.search(r"\(([\d,]+) tetrahedra", str(exc))
                    rows.append({"case": label, "max_depth": depth, "refused": str(exc),
                                 "tetrahedra": int(count.group(1).replace(",", "")) if count else None})
                    self.log(f"  [needs] {label}, max depth {depth}: refused ({rows[-1]['tetrahedra']} tets)")
                    continue
                img, kern, _full, visits = time_render(r, 0.0, self.runs)
                images[depth] = img
                rows.append({"case": label, "max_depth": depth, "tetrahedra": r.stats.tetrahedra,
                             "kernel_s": kern, "visits": visits,
                             "bounced_pixels": int((img.bounces > 0).sum())})
                if depth > 0 and 0 in images:
                    rows[-1]["identical_to_depth0"] = bool(np.array_equal(images[0].rgba, img.rgba))
                self.log(f"  [needs] {label}, max depth {depth}: {r.stats.tetrahedra:,} tets, {visits:.2f} visits/ray, "
                         f"{1e3 * kern['median']:.1f} ms")
        res["mirrors"] = rows
        # (c) clipping: tetrahedra against the length of the sequence (the reader's fixed
        # sphere tessellation, so only the windows change)
        clip_segments = 16 if self.quick else None
        scene = fixed_tessellation(load_parade(), clip_segments)
        parade_camera = scene.camera_state  # the stage holds its camera time after frame 48: use t_c = frame

        def camera_at(path, frame):
            return dataclasses.replace(parade_camera(path, 0.0), time=float(frame))

        scene = dataclasses.replace(scene, camera_state=camera_at)
        res["clipping_sphere_segments"] = clip_segments or 64
        unlit = dataclasses.replace(scene, lights=())
        spans = [100.0] if self.quick else [10.0, 100.0, 1000.0]
        cases = [("lit", scene, [0.0])] + [("lit", scene, list(np.linspace(0.0, t, 11))) for t in spans]
        if not self.quick:
            cases += [("lit", scene, [1000.0]), ("lit", scene, [1.0e6])]
        cases += [("unlit", unlit, [0.0])]
        if not self.quick:
            cases += [("unlit", unlit, list(np.linspace(0.0, 1000.0, 11)))]
        cases += [("unlit", unlit, [1.0e6])]
        rows = []
        for lights, sc, frames in cases:
            frames = [float(f) for f in frames]
            label = f"frame {_t(frames[0])}" if len(frames) == 1 else f"{_t(frames[0])}–{_t(frames[-1])} ({len(frames)} frames)"
            row = {"span": label, "lights": lights, "frames": len(frames)}
            fine = True
            try:
                r, ctor = _build(sc, frames=frames, width=16, height=9)
            except SceneError as exc:  # the memory guard refused: report the count it computed
                count = re.search(r"\(([\d,]+) tetrahedra", str(exc))
                row.update(tetrahedra=int(count.group(1).replace(",", "")) if count else None, refused=str(exc),
                           constructor_s=None, per_body={})
            else:
                fine = r.fine_segments
                row.update(tetrahedra=r.stats.tetrahedra, constructor_s=ctor, per_body=_tets_per_body(r),
                           time_segments="per triangle" if fine else "per body (memory)")
            if len(frames) > 1:  # the same windows filled in between (one interval per body)
                from warp_st.rendering.budget import count_database
                from warp_st.rendering.renderer import DEFAULT_MAX_DEPTH
                from warp_st.spacetime.visibility import span, visibility_windows

                cams = [sc.camera_state(sc.default_camera, f) for f in frames]
                wins = visibility_windows(sc, cams, infinite=False, max_depth=DEFAULT_MAX_DEPTH)
                row["span_tetrahedra"] = count_database(sc, [span(w) for w in wins], fine=fine)[0]
            rows.append(row)
            self.log(f"  [needs] parade {lights} {label}: {row['tetrahedra']:,} tets"
                     + (" (refused)" if "refused" in row else ""))
        res["clipping"] = rows
        res["parade_bodies"] = [b.prim_path for b in scene.bodies]
        # (d) slack: how much of the lit windows frame 0's image needs. Every moving
        # body's window is cut from one end; the pixels that change show where the
        # bound is already tight.
        ref, _ctor = _build(scene, frames=[0.0], width=w, height=h)
        ref_img = ref.render(0.0)
        rows = []
        for early, late in ((0.25, 0.0), (0.35, 0.0), (0.5, 0.0), (0.0, 0.1), (0.0, 0.25)):
            with _cut_windows(early, late):
                r, _ctor = _build(scene, frames=[0.0], width=w, height=h)
            img = r.render(0.0)
            changed = (np.abs(img.rgba - ref_img.rgba).max(axis=-1) > 1e-3) | (img.object_id != ref_img.object_id)
            rows.append({"earliest": early, "latest": late, "tetrahedra": r.stats.tetrahedra,
                         "changed_pixels": int(changed.sum())})
            self.log(f"  [needs] lit parade frame 0, windows cut {early:.0%} early / {late:.0%} late: "
                     f"{r.stats.tetrahedra:,} tets, {int(changed.sum())} pixels changed")
        res["slack"] = {"tetrahedra": ref.stats.tetrahedra, "rows": rows}
        return res

    # ------------------------------------------------------------------ adaptive
    def adaptive(self):
        scene = load_parade()
        fixed = fixed_tessellation(scene)
        sizes = [(96, 54)] if self.quick else [(160, 90), (640, 360), (1280, 720)]
        ref_segments = 96 if self.quick else 128
        reference = fixed_tessellation(scene, ref_segments)
        rows = []
        for w, h in sizes:
            row = {"width": w, "height": h}
            ref_img = None
            if w * h <= 640 * 360:
                rr, _ = _build(reference, frames=[0.0], width=w, height=h)
                ref_img = rr.render(0.0)
            for label, sc in (("adaptive", scene), ("fixed 64", fixed)):
                r, ctor = _build(sc, frames=[0.0], width=w, height=h)
                img, kern, _full, _vis = time_render(r, 0.0, self.runs)
                row[label] = {"segments": dict(r.sphere_segments) if label == "adaptive" else 64,
                              "tetrahedra": r.stats.tetrahedra, "constructor_s": ctor, "kernel_s": kern}
                if ref_img is not None:
                    row[label]["vs_reference"] = _image_difference(img, ref_img, r)
            rows.append(row)
            self.log(f"  [adaptive] {w}x{h}: segments {row['adaptive']['segments']}, "
                     f"{row['adaptive']['tetrahedra']:,} vs {row['fixed 64']['tetrahedra']:,} tets")
        return {"reference_segments": ref_segments, "rows": rows}


_ORIGINAL_BODY_SLICES = []


def _factor(fac) -> str:
    return "default rule" if fac is None else f"x{fac:g}"


@contextlib.contextmanager
def sweep_factor(factor: float | None):
    """Temporarily make ``warp_st.spacetime.extrude.body_slices`` cut segments in which a body sweeps
    ``factor`` x its own size (None: the default rule, ``extrude.segment_sweep``)."""
    import warp_st.spacetime.extrude as ex

    if factor is None:
        yield
        return
    if not _ORIGINAL_BODY_SLICES:
        _ORIGINAL_BODY_SLICES.append(ex.body_slices)
    original = _ORIGINAL_BODY_SLICES[0]

    def body_slices(body, window, *, max_segments=4096, fraction=None, fine=True):
        return original(body, window, max_segments=max_segments, fraction=factor)

    ex.body_slices = body_slices
    try:
        yield
    finally:
        ex.body_slices = original


def _box_stats(mesh, sample: int = 200_000) -> dict:
    """Mean spatial extent (largest xyz side) and time extent of the primitives' 4D boxes
    (prisms or tetrahedra, as the BVH holds them), relative to their triangle's size
    (1 = a box as small as the triangle)."""
    n = mesh.prim_count
    if n == 0:
        return {"box_over_size": float("nan"), "box_dt": float("nan")}
    idx = np.random.default_rng(0).choice(n, size=min(n, sample), replace=False)
    lo, hi = mesh.prim_boxes()
    ext = hi[idx] - lo[idx]
    prim_tri = mesh.prism_tri if mesh.primitive == "prism" else mesh.tet_tri
    size = np.maximum(mesh.tri_size[prim_tri[idx]], 1e-12)
    return {"box_over_size": float((ext[:, 1:].max(axis=1) / size).mean()), "box_dt": float(ext[:, 0].mean())}


def _tets_per_body(r) -> dict:
    tri_body = r.mesh.tri_body[r.mesh.tet_tri]  # every mesh keeps its tetrahedra
    counts = np.bincount(tri_body, minlength=len(r.scene.bodies))
    return {b.prim_path: int(c) for b, c in zip(r.scene.bodies, counts)}


def _image_difference(img, ref, r) -> dict:
    """Against a finer reference render: pixels whose object differs, and the largest depth
    difference on pixels both hit with the same object, in pixel footprints (|dZ| / (Z x
    pixel angle at the image centre))."""
    cam = r._cameras[r.frames[0]]
    alpha = float(cam.horizontal_aperture) / r.width / float(cam.focal_length)
    same = (img.object_id == ref.object_id) & (img.object_id > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        dz = np.abs(img.depth.astype(np.float64) - ref.depth.astype(np.float64))
        px = dz / (ref.depth.astype(np.float64) * alpha)
    return {"object_differs": int((img.object_id != ref.object_id).sum()),
            "depth_px_p99": float(np.percentile(px[same], 99)) if same.any() else 0.0,
            "depth_px_max": float(px[same].max()) if same.any() else 0.0}


# =========================================================================== report


def _ms(s):
    return f"{1e3 * s['median']:.1f}"


def _ms_range(s):
    return f"{1e3 * s['median']:.1f} ({1e3 * s['min']:.1f}–{1e3 * s['max']:.1f})"


def _table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


ADAPTIVE_DOC = """## How the adaptive sphere tessellation works

A `UsdGeom.Sphere` is exact in USD but a UV polyhedron in the 4D database. The reader keeps the
analytic shape on the surface (`Surface.sphere = (radius, world_from_local)`, next to a default
64-segment tessellation); the `Renderer`, which knows the resolution, the lens and the camera
event of every frame it will render, re-tessellates each sphere before extrusion with the
fewest longitudes n whose error stays under **half a pixel** in every frame
(`warp_st.spacetime.adaptive.adapt_sphere_tessellation`; `Renderer.sphere_segments` reports the choice):

    g(n) < 2 r (1 - cos(pi / n))  <=  0.5 px x d_min x alpha_min / m

- g(n): the gap between the sphere and the polyhedron (every vertex lies on the sphere, so the
  polyhedron lies between the balls r - g and r). The widest triangle spans a quad diagonal, so
  g = r (1 - cos(sqrt(2) pi / n)), just under twice the great-circle sagitta; n is even (the
  latitude step then equals the longitude step), between 8 and 512. r is the world radius
  (radius x the largest singular value of the transform).
- alpha_min: the smallest angle between neighbouring pixel centres (an image corner for a pinhole).
- d_min: over every frame (and shutter sample), the nearest the sphere's surface comes to that
  frame's camera over the lab times that frame can see (`visibility.frame_window` on the
  sphere's own ball), and with finite light speed at least t_c minus the window's end (an
  event's lookback is t_c - t): a lower bound of the distance of every event the frame shows.
- m, the magnification of the image: 1 for bodies at rest and for coupled (physical) bodies at
  any speed: g is a rest-frame length seen at rest-frame distance L', and aberration scales the
  angle by w'/w while the distance scales by w/w' (w, w' the photon's frequency in the two
  frames), so the camera sees g / Z with Z its own distance to the event. Decoupled
  (Galilean) bodies: along a ray the co-moving position is A + s (n + v), so the retarded image
  stretches angles by |n + v| / (1 + n.v) (1 looking along or against v, at most
  gamma = 1/sqrt(1 - beta^2)), taken over the directions the sphere covers in the window; at
  beta >= 1 there is no bound and the reader's 64 segments are kept. A moving camera multiplies
  m by sqrt((1 + beta_c)/(1 - beta_c)) (Galilean camera: (1 + beta_c)/(1 - beta_c)).
- Not covered: reflections in curved mirrors and shadow edges on grazing receivers can magnify
  the error. Metallic spheres, and every sphere of a scene with mirrors and max depth > 0, are
  therefore never tessellated coarser than the default 64 segments; shadows follow the same
  rule as primary visibility.
- A frame's tessellation depends on the frames that share its database (the nearest one sets
  it): rendering a frame alone or within a sequence can differ by up to the half-pixel bound.
  Cubes and meshes are exact and never touched.

The measured errors (tables above, `tests/spacetime/test_adaptive_tessellation.py`) stay under half a pixel
for spheres at rest and at 0.9c, at several resolutions: silhouette = the largest image-plane
distance from a pixel whose hit/miss differs from the exact sphere's to the exact outline; depth =
how far the rendered hit event lies off the exact sphere in the body frame, in pixel footprints.
"""


def report_sections(results, images_rel):
    """Markdown sections, one per suite that ran."""
    L = []
    if "scaling" in results:
        s = results["scaling"]
        L += [f"## Scaling: time against tetrahedra ({s['width']}x{s['height']})", "",
              "Extrusion, 4D SAH BVH build and render time (kernel, median of the runs) against the database size. "
              "Sphere grid: n x n UV spheres of 24 segments covering the same part of the image, mixed velocities up "
              "to 0.9c, unlit (more, smaller bodies: the image itself changes). Tessellated 3x3 grid: the same 3 x 3 "
              "spheres at 8 to 256 segments (the same image, more triangles). Moving cubes: N cubes up to 0.95c in random directions, one distant light (shadow "
              "rays, and windows widened for them).", ""]
        L += _table(["scene", "tetrahedra", "BVH nodes", "extrude s", "BVH build s", "render ms", "visits/ray"],
                    [[f"{r['family']}: {r['label']}", f"{r['tetrahedra']:,}", f"{r['bvh_nodes']:,}",
                      f"{r['extrude_s']:.3f}", f"{r['bvh_s']:.3f}", _ms_range(r["kernel_s"]), f"{r['visits']:.1f}"]
                     for r in s["rows"]])
        L += ["", f"![scaling]({images_rel}/perf_scaling.png)", ""]
    if "sequence" in results:
        s = results["sequence"]
        n = len(s["frames"])
        L += [f"## Sequences: one database for many frames ({s['width']}x{s['height']}, {s['scene']}, "
              f"{n} frames {s['frames'][0]:g}–{s['frames'][-1]:g})", ""]
        L += _table(["", "seconds per frame", "total s", "tetrahedra"],
                    [["one database (`Renderer(scene, frames=...)`, `render(f)`)", f"{s['reuse_per_frame_s']:.3f}",
                      f"{s['reuse_total_s']:.2f}", f"{s['shared_tetrahedra']:,} (shared)"],
                     ["  of which: build once", f"{s['reuse_build_s'] / n:.3f}", f"{s['reuse_build_s']:.2f}", ""],
                     ["  of which: render", f"{s['reuse_render_s']['median']:.3f} (median)",
                      f"{sum(s['reuse_render_s']['runs']):.2f}", ""],
                     ["rebuild per frame (`warp_st.render(scene, frame=f)`)", f"{s['rebuild_per_frame_s']:.3f}",
                      f"{s['rebuild_total_s']:.2f}", f"{int(s['single_tetrahedra']['median']):,} (median per frame)"]])
        L += [""]
    if "precision" in results:
        s = results["precision"]
        L += [f"## Precision: float32 against float64 kernels ({s['width']}x{s['height']}, analytic sphere)", "",
              "Numerical error: the rendered Z and eventTime against the exact float64 first hit of the same "
              "tessellated sphere (`bench.polyhedron_hit`: a ray/triangle test in the body frame, where the extruded "
              "world-tube is exactly the rest mesh), largest over the pixels. Tessellation error: against the "
              "closed-form sphere (`warp_st.core.lorentz.sphere_hit`), over pixels where the inner ball R - g is hit too. "
              f"{s['rows'][0]['segments']} segments. The t = 10^6 case shifts every time by 10^6 and every position "
              "by 10^4 (coordinates are recentred on the camera event in float64 before rounding). Z and eventTime "
              "are stored as float32 either way (docs/spec.md §4): about 2.4e-7 at Z ~ 5 is the storage floor.", ""]
        L += _table(["precision", "case", "tetrahedra", "visits/ray", "render ms", "Z err (numerical)",
                     "eventTime err (numerical)", "Z err vs sphere (tessellation)"],
                    [[r["precision"], r["case"], f"{r['tetrahedra']:,}", f"{r['visits']:.1f}", _ms_range(r["kernel_s"]),
                      f"{r['z_poly']:.1e}", f"{r['t_poly']:.1e}", f"{r['z_abs']:.1e}"] for r in s["rows"]])
        L += [""]
    if "tessellation" in results:
        s = results["tessellation"]
        L += [f"## Sphere tessellation: segments against error ({s['width']}x{s['height']})", "",
              "A unit sphere seen at distance 6 (19° across in a 48° field of view). Silhouette: the largest "
              "distance from a pixel whose hit/miss differs from the exact sphere's to the exact outline (pixels). "
              "Depth: the largest distance of a rendered hit event from the exact sphere (in the body frame), in pixel "
              "footprints Z x pixel angle. "
              "\"adaptive\" is the renderer's choice for this view (target: 0.5 px).", ""]
        L += _table(["series", "segments", "tetrahedra", "silhouette px", "depth px", "render ms", "build s"],
                    [[r["series"], f"{r['segments']}{' (adaptive)' if r['adaptive'] else ''}", f"{r['tetrahedra']:,}",
                      f"{r['silhouette_px']:.3f}", f"{r['depth_px']:.3f}", _ms_range(r["kernel_s"]),
                      f"{r['constructor_s']:.3f}"] for r in s["rows"]])
        L += ["", f"![speed against error]({images_rel}/perf_error.png)", ""]
    if "slices" in results:
        s = results["slices"]
        L += [f"## Time-segment length of extrusions ({s['width']}x{s['height']})", "",
              "Factor f cuts segments in which a body sweeps f x its size; \"default rule\" is what the renderer "
              f"does (`extrude.segment_sweep`: {SWEEP_FRACTION:g} x its size, shortened for finely tessellated "
              f"bodies to {TRIANGLE_SWEEP:g} x the median triangle size, but not below {MIN_SWEEP_FRACTION:g} x its "
              "size). box/size: mean largest spatial side of a primitive's 4D box over its triangle's size; box "
              "Δt: mean time extent.", ""]
        L += _table(["scene", "factor", "tetrahedra", "box/size", "box Δt", "extrude s", "BVH s", "render ms",
                     "visits/ray"],
                    [[r["series"], _factor(r["factor"]), f"{r['tetrahedra']:,}", f"{r['box_over_size']:.2f}",
                      f"{r['box_dt']:.2f}", f"{r['extrude_s']:.3f}", f"{r['bvh_s']:.3f}", _ms_range(r["kernel_s"]),
                      f"{r['visits']:.1f}"] for r in s["rows"]])
        L += [""]
    if "needs" in results:
        s = results["needs"]
        L += [f"## Model only what a scene needs ({s['width']}x{s['height']})", "",
              "Lights: the shading loop runs once per light, so an unlit scene traces no shadow rays; with lights "
              "the windows also widen for shadow rays. \"same database, unlit\" renders the lit scene's database "
              "with its lights removed, isolating the shadow rays' cost.", ""]
        L += _table(["scene", "tetrahedra", "render ms", "same database, unlit ms", "visits/ray (primary)"],
                    [[r["case"], f"{r['tetrahedra']:,}", _ms_range(r["kernel_s"]),
                      _ms_range(r["kernel_s_same_db_unlit"]) if "kernel_s_same_db_unlit" in r else "–",
                      f"{r['visits']:.1f}"] for r in s["lights"]])
        L += ["", "Mirrors: reflection rays are traced only from metallic surfaces (visits/ray counts every BVH node "
              "visited along the camera path, reflections included).", ""]
        L += _table(["scene", "max depth", "tetrahedra", "render ms", "visits/ray", "pixels with a reflection",
                     "image = depth 0"],
                    [[r["case"], r["max_depth"], f"{r['tetrahedra']:,}" if r["tetrahedra"] else "?",
                      _ms_range(r["kernel_s"]), f"{r['visits']:.2f}", r["bounced_pixels"],
                      {True: "yes", False: "no"}.get(r.get("identical_to_depth0"), "")] if "refused" not in r else
                     [r["case"], r["max_depth"], f"{r['tetrahedra']:,}" if r["tetrahedra"] else "?",
                      "refused by the memory guard", "–", "–", ""] for r in s["mirrors"]])
        L += ["", "Clipping: the shipped parade scene's bodies (unbounded lifetimes, bodies at 0.9c, two lights; "
              f"spheres at a fixed {s['clipping_sphere_segments']} segments so only the windows change) with camera "
              "time = frame number; the database covers only what the requested frames' past lightcones (and, lit, "
              "what shadow rays from any hit event can reach) can see. \"unlit\": the same bodies with the lights "
              "removed. Per-body columns: tetrahedra (the floor and posts are at rest: one segment each). "
              "\"one interval\": what the same windows would extrude with the gaps between groups of frames "
              "filled in (one interval per body, as before 0.2.0), with the same time-segment rule; \"segments\": "
              "per triangle (extrude.segment_sweep) or per body (the coarser rule the renderer falls back to when the "
              "finer one would exceed the memory limit).", ""]
        bodies = s["parade_bodies"]
        shown = [b for b in bodies if "Posts" not in b]
        L += _table(["frames", "lights", "tetrahedra", "one interval", "segments", "build s"]
                    + [b.rsplit("/", 2)[-2] + "/" + b.rsplit("/", 1)[-1] for b in shown],
                    [[r["span"], r["lights"], f"{r['tetrahedra']:,}" if r["tetrahedra"] else "?",
                      f"{r['span_tetrahedra']:,}" if "span_tetrahedra" in r else "", r.get("time_segments", "–"),
                      f"{r['constructor_s']:.2f}" if r["constructor_s"] is not None else "refused by the memory guard"]
                     + [f"{r['per_body'].get(b, 0):,}" if r["per_body"] else "–" for b in shown]
                     for r in s["clipping"]])
        if "slack" in s:
            L += ["", f"Slack of the lit bound: frame 0 of the lit parade (same bodies, {s['width']}x{s['height']}, "
                  f"{s['slack']['tetrahedra']:,} tetrahedra) rendered again with every moving body's window cut "
                  "from one end by a fraction of its span (`bench._cut_windows`); pixels whose colour changes by "
                  "more than 1e-3 or whose objectId changes. Where none change, that part of the bound was more "
                  "than the image needs.", ""]
            L += _table(["window cut", "tetrahedra", "pixels changed"],
                        [[(f"earliest {r['earliest']:.0%}" if r["earliest"] else f"latest {r['latest']:.0%}"),
                          f"{r['tetrahedra']:,}", r["changed_pixels"]] for r in s["slack"]["rows"]])
        L += [""]
    if "adaptive" in results:
        s = results["adaptive"]
        L += ["## Adaptive sphere tessellation on the parade scene", "",
              f"Adaptive (the default) against the reader's fixed 64 segments; \"vs ref\": against a "
              f"{s['reference_segments']}-segment render of the same frame: pixels whose objectId differs (the "
              "outlines move by under half a pixel, so pixels on them flip), and the 99th percentile / max |ΔZ| on "
              "pixels showing the same object, in pixel footprints Z x pixel angle (the max sits on grazing pixels "
              "next to an outline, where a sub-pixel shift of the surface moves Z a lot).", ""]
        rows = []
        for r in s["rows"]:
            for label in ("adaptive", "fixed 64"):
                x = r[label]
                seg = x["segments"] if isinstance(x["segments"], int) else ", ".join(
                    f"{k.rsplit('/', 2)[-2]}: {v}" for k, v in x["segments"].items())
                ref = x.get("vs_reference")
                rows.append([f"{r['width']}x{r['height']}", label, seg, f"{x['tetrahedra']:,}",
                             f"{x['constructor_s']:.2f}", _ms_range(x["kernel_s"]),
                             f"{ref['object_differs']} / {ref['depth_px_p99']:.2f} / {ref['depth_px_max']:.2f}"
                             if ref else "–"])
        L += _table(["resolution", "tessellation", "sphere segments", "tetrahedra", "build s", "render ms",
                     "vs ref: id px / depth p99 / max"], rows)
        L += [""]
    return L


def summary_rows(results):
    """The one table printed on stdout: the headline number of each suite."""
    rows = []
    if "scaling" in results:
        for fam in ("sphere grid", "tessellated 3x3 grid", "moving cubes"):
            rs = [r for r in results["scaling"]["rows"] if r["family"] == fam]
            if rs:
                a, b = rs[0], rs[-1]
                text = (f"BVH {a['bvh_s']:.3f} → {b['bvh_s']:.3f} s; render {_ms(a['kernel_s'])} → "
                        f"{_ms(b['kernel_s'])} ms")
                if fam == "tessellated 3x3 grid":
                    # Render-time growth at a fixed image, to the row nearest 10^6 tets (the
                    # other families change the image itself as they grow).
                    m = min(rs, key=lambda r: abs(np.log10(max(r["tetrahedra"], 1)) - 6.0))
                    growth = m["kernel_s"]["median"] / a["kernel_s"]["median"]
                    text += f"; {growth:.2f}x at {m['tetrahedra']:,} tets"
                rows.append([f"scaling ({fam})", f"{a['tetrahedra']:,} → {b['tetrahedra']:,} tets", text])
    if "sequence" in results:
        s = results["sequence"]
        rows.append(["sequence reuse", f"{len(s['frames'])} parade frames",
                     f"{s['reuse_per_frame_s']:.3f} s/frame (one database) vs {s['rebuild_per_frame_s']:.3f} "
                     f"s/frame (rebuilt)"])
    if "precision" in results:
        for prec in ("float32", "float64"):
            rs = [r for r in results["precision"]["rows"] if r["precision"] == prec]
            if rs:
                rows.append([f"precision {prec}", "analytic sphere, t = 0 and 1e6",
                             f"render {', '.join(_ms(r['kernel_s']) for r in rs)} ms; numerical Z err ≤ "
                             f"{max(r['z_poly'] for r in rs):.1e}, eventTime err ≤ {max(r['t_poly'] for r in rs):.1e}"])
    if "tessellation" in results:
        for r in results["tessellation"]["rows"]:
            if r["adaptive"]:
                rows.append([f"tessellation ({r['series']})", f"adaptive: {r['segments']} segments",
                             f"silhouette {r['silhouette_px']:.2f} px, depth {r['depth_px']:.2f} px, "
                             f"{_ms(r['kernel_s'])} ms"])
    if "slices" in results:
        for series in dict.fromkeys(r["series"] for r in results["slices"]["rows"]):
            rs = [r for r in results["slices"]["rows"] if r["series"] == series]
            best = min(rs, key=lambda r: r["kernel_s"]["median"])
            default = next(r for r in rs if r["factor"] is None)
            fixed = [r["factor"] for r in rs if r["factor"] is not None]
            rows.append([f"time segments: {series.split(',')[0]}", f"factors {fixed[0]:g}–{fixed[-1]:g} and the default rule",
                         f"fastest render at {_factor(best['factor'])} ({_ms(best['kernel_s'])} ms, {best['tetrahedra']:,} "
                         f"tets); default rule {_ms(default['kernel_s'])} ms, {default['tetrahedra']:,} tets"])
    if "needs" in results:
        s = results["needs"]
        lit = [r for r in s["lights"] if "kernel_s_same_db_unlit" in r]
        if lit:
            r = lit[0]
            rows.append(["needs: lights", r["case"],
                         f"{_ms(r['kernel_s'])} ms lit vs {_ms(r['kernel_s_same_db_unlit'])} ms same database unlit"])
        nm = [r for r in s["mirrors"] if r["case"] == "no mirror" and "refused" not in r]
        if nm:
            rows.append(["needs: mirrors", "no mirror, max depth 0 / 4",
                         f"{nm[0]['visits']:.2f} / {nm[-1]['visits']:.2f} visits/ray, "
                         f"{_ms(nm[0]['kernel_s'])} / {_ms(nm[-1]['kernel_s'])} ms"])
        for lights in ("lit", "unlit"):
            cl = [r for r in s["clipping"] if r["lights"] == lights]
            if cl:
                rows.append([f"needs: clipping ({lights})", "parade bodies, " + " / ".join(r["span"] for r in cl),
                             " / ".join(f"{r['tetrahedra']:,}" + (" (refused)" if "refused" in r else "")
                                        for r in cl) + " tets"])
        if "slack" in s:
            rows.append(["needs: slack of the lit bound", "parade frame 0, moving bodies' windows cut "
                         + " / ".join(f"{r['earliest']:.0%} early" if r["earliest"] else f"{r['latest']:.0%} late"
                                      for r in s["slack"]["rows"]),
                         " / ".join(str(r["changed_pixels"]) for r in s["slack"]["rows"]) + " pixels changed"])
    if "adaptive" in results:
        for r in results["adaptive"]["rows"]:
            a, f = r["adaptive"], r["fixed 64"]
            rows.append([f"adaptive parade {r['width']}x{r['height']}",
                         ", ".join(str(v) for v in a["segments"].values()) + " segments",
                         f"{a['tetrahedra']:,} vs {f['tetrahedra']:,} tets (fixed 64); render {_ms(a['kernel_s'])} vs "
                         f"{_ms(f['kernel_s'])} ms"])
    return rows


def make_plots(results, images: Path, log) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    written = []
    images.mkdir(parents=True, exist_ok=True)
    if "scaling" in results:
        s = results["scaling"]
        fig, ax = plt.subplots(figsize=(7, 4.8))
        for fam, marker, ls in (("sphere grid", "o", "-"), ("tessellated 3x3 grid", "^", ":"), ("moving cubes", "s", "--")):
            rs = sorted((r for r in s["rows"] if r["family"] == fam), key=lambda r: r["tetrahedra"])
            if not rs:
                continue
            x = [r["tetrahedra"] for r in rs]
            ax.loglog(x, [r["bvh_s"] for r in rs], marker=marker, ls=ls, color="C0", label=f"{fam}: BVH build")
            ax.loglog(x, [r["extrude_s"] for r in rs], marker=marker, ls=ls, color="C1", label=f"{fam}: extrusion")
            ax.loglog(x, [r["kernel_s"]["median"] for r in rs], marker=marker, ls=ls, color="C2",
                      label=f"{fam}: render (kernel)")
        ax.set_xlabel("tetrahedra")
        ax.set_ylabel("seconds")
        ax.set_title(f"warp_st scaling, {s['width']}x{s['height']} render")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        p = images / "perf_scaling.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
    panels = [k for k in ("precision", "tessellation", "slices") if k in results]
    if panels:
        fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.4), squeeze=False)
        for ax, key in zip(axes[0], panels):
            s = results[key]
            if key == "precision":
                for prec, marker in (("float32", "o"), ("float64", "s")):
                    rs = [r for r in s["rows"] if r["precision"] == prec]
                    for r in rs:
                        ax.scatter(max(r["z_poly"], 1e-12), 1e3 * r["kernel_s"]["median"], marker=marker,
                                   label=f"{prec}: {r['case']}")
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.set_xlabel("numerical Z error (vs exact hit of the same mesh)")
                ax.set_ylabel("render ms")
                ax.set_title("float32 vs float64 (analytic sphere)")
                ax.legend(fontsize=6)
            elif key == "tessellation":
                for series in dict.fromkeys(r["series"] for r in s["rows"]):
                    rs = sorted((r for r in s["rows"] if r["series"] == series and not r["adaptive"]),
                                key=lambda r: r["segments"])
                    ax.loglog([max(r["silhouette_px"], 1e-3) for r in rs], [1e3 * r["kernel_s"]["median"] for r in rs],
                              "o-", label=f"{series}: silhouette")
                    ax.loglog([max(r["depth_px"], 1e-3) for r in rs], [1e3 * r["kernel_s"]["median"] for r in rs],
                              "^:", label=f"{series}: depth")
                    for r in rs:
                        ax.annotate(str(r["segments"]), (max(r["silhouette_px"], 1e-3), 1e3 * r["kernel_s"]["median"]),
                                    fontsize=6)
                    ad = [r for r in s["rows"] if r["series"] == series and r["adaptive"]]
                    for r in ad:
                        ax.scatter([max(r["silhouette_px"], 1e-3)], [1e3 * r["kernel_s"]["median"]], marker="*", s=120,
                                   zorder=5, label=f"{series}: adaptive ({r['segments']})")
                ax.axvline(0.5, color="grey", lw=0.8, ls="--")
                ax.set_xlabel("measured error (pixels; 0 drawn at 1e-3); dashed: 0.5 px")
                ax.set_ylabel("render ms")
                ax.set_title(f"sphere segments ({s['width']}x{s['height']})")
                ax.legend(fontsize=6)
            else:
                for k, series in enumerate(dict.fromkeys(r["series"] for r in s["rows"])):
                    rs = [r for r in s["rows"] if r["series"] == series and r["factor"] is not None]
                    x = [r["factor"] for r in rs]
                    short = series.split(",")[0].split(" (")[0]
                    ax.loglog(x, [1e3 * r["kernel_s"]["median"] for r in rs], "o-", color=f"C{k}",
                              label=f"{short}: render ms")
                    ax.loglog(x, [r["tetrahedra"] / 1e3 for r in rs], "s:", color=f"C{k}",
                              label=f"{short}: k tetrahedra")
                    default = next((r for r in s["rows"] if r["series"] == series and r["factor"] is None), None)
                    if default is not None:  # the default rule, drawn at no factor: a horizontal mark
                        ax.axhline(1e3 * default["kernel_s"]["median"], color=f"C{k}", lw=0.8, ls="-.",
                                   label=f"{short}: default rule, render ms")
                ax.set_xlabel("sweep per time segment (x body size)")
                ax.set_ylabel("render ms / thousand tetrahedra")
                ax.set_title("time-segment length")
                ax.legend(fontsize=6)
            ax.grid(True, which="both", alpha=0.3)
            for a in fig.axes:
                a.xaxis.set_minor_formatter(NullFormatter())
                a.yaxis.set_minor_formatter(NullFormatter())
        fig.tight_layout()
        p = images / "perf_error.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
    for p in written:
        log(f"wrote {p}")
    return written


# =========================================================================== main


def build_parser(prog="warp-st bench"):
    p = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p)
    return p


def add_arguments(p):
    p.add_argument("--quick", action="store_true", help="tiny sizes for a smoke run (< 30 s with a warm kernel cache)")
    p.add_argument("--suites", default=",".join(SUITES), help=f"comma-separated subset of {','.join(SUITES)}")
    p.add_argument("--runs", type=int, default=None, help="timed renders per measurement, median (default 5; --quick 1)")
    p.add_argument("--width", type=int, default=None, help="image width of the scaling suite (default 320; --quick 64)")
    p.add_argument("--height", type=int, default=None, help="image height of the scaling suite (default 180; --quick 36)")
    p.add_argument("--out", metavar="FILE.md", default="docs/performance.md",
                   help="markdown report (default docs/performance.md)")
    p.add_argument("--images", metavar="DIR", default=None, help="plot directory (default: images/ next to --out)")
    p.add_argument("--json", metavar="FILE.json", help="also write the raw numbers")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")


def _finish_args(args, error):
    if args.runs is None:
        args.runs = 1 if args.quick else 5
    if args.runs < 1:
        error("--runs must be >= 1")
    args.width = args.width or (64 if args.quick else 320)
    args.height = args.height or (36 if args.quick else 180)
    suites = [s.strip() for s in args.suites.split(",") if s.strip()]
    bad = [s for s in suites if s not in SUITES]
    if bad:
        error(f"unknown suite(s) {bad}; choose from {list(SUITES)}")
    args.suites = suites
    return args


def run(args, log=None) -> int:
    """Run the suites of parsed ``args``; print the summary table; write the report."""
    if log is None:
        def log(msg):
            print(msg, file=sys.stderr, flush=True)

    t_start = time.perf_counter()
    wp = _warp()
    machine = machine_info()
    log(f"warp-st bench: suites {args.suites}, runs {args.runs}{', quick' if args.quick else ''}; "
        f"kernel cache {wp.config.kernel_cache_dir}")
    bench = Bench(args, log)
    results, seconds = {}, {}
    for name in args.suites:
        t0 = time.perf_counter()
        log(f"[{name}]")
        results[name] = getattr(bench, name)()
        seconds[name] = time.perf_counter() - t0
    try:
        machine["loadavg_end"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        machine["loadavg_end"] = [float("nan")] * 3

    out = Path(args.out)
    images = Path(args.images) if args.images else out.parent / "images"
    try:
        images_rel = os.path.relpath(images, out.parent)
    except ValueError:
        images_rel = str(images)
    if not args.no_plots:
        make_plots(results, images, log)

    m = machine
    summary = summary_rows(results)
    header = [
        "# Performance: speed against error",
        "",
        "Generated by `warp-st bench" + (" --quick" if args.quick else "") + "` (warp_st/bench.py; "
        "`examples/benchmarks/bench_performance.py` is the same script). Every number below is measured by it; "
        "rerun it to reproduce them.",
        "",
        f"Machine: {m['cpu']}, {m['cpu_count']} logical cores ({m['usable_cores']} usable), warp {m['warp']}, "
        f"numpy {m['numpy']}, Python {m['python']}, {m['platform']}; {m['date']}. 1-min load average "
        f"{m['loadavg'][0]:.2f} at start, {m['loadavg_end'][0]:.2f} at end (a load above the core count means "
        f"other processes shared the cores: timings are then noisy). Renders use every core; times are medians "
        f"of {args.runs} run(s) (min–max in brackets); kernels were compiled before timing.",
        "",
        "## Summary",
        "",
    ]
    table = _table(["suite", "case", "result"], summary)
    lines = header + table + [""] + report_sections(results, images_rel.replace(os.sep, "/"))
    lines += [ADAPTIVE_DOC, "## Notes", "",
              "- render ms = `Renderer.stats.last_kernel_seconds` (the megakernel over all row tiles: primary rays, "
              "shadow rays, reflections, every AOV); build = the `Renderer` constructor (visibility windows, "
              "adaptive tessellation, extrusion, BVH, upload).",
              "- Suite wall times: " + ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items()) + ".", ""]
    text = "\n".join(lines)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print("\n".join(table))
    log(f"wrote {out} in {time.perf_counter() - t_start:.1f} s")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps({"machine": machine, "options": {k: v for k, v in vars(args).items()},
                                               "seconds": seconds, "results": results}, indent=2, default=str))
    return 0


def main(argv=None) -> int:
    parser = build_parser()
    args = _finish_args(parser.parse_args(argv), parser.error)
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
