"""Helpers (not tests) for comparing the real renderer with closed-form moving spheres.

A scene here is one tessellated sphere body built directly from the host dataclasses
(no USD), one pinhole camera, no lights. The float64 oracle is
:func:`warp_st.core.lorentz.sphere_hit`; pixel directions are docs/spec.md §3's pinhole in
float64 NumPy (:func:`warp_st.rendering.camera.pixel_directions`, checked against the
kernel's rays in tests/rendering/test_camera_directions.py), so the two compare per pixel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from warp_st.core import lorentz, tessellate
from warp_st.core.conventions import LightSpeed
from warp_st.core.scene import Body, CameraState, RenderSettings, Scene, Surface
from warp_st.rendering.camera import pixel_directions
from warp_st.testing import dilate, fit_cone, uv_sphere_gap  # noqa: F401  (dilate, fit_cone: for the tests)

EPS32 = float(np.finfo(np.float32).eps)
EPS64 = float(np.finfo(np.float64).eps)


# --------------------------------------------------------------------------- camera


def look_at(forward, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """``lab_from_camera`` rotation whose -Z column is ``forward`` (columns: +X, +Y, +Z).

    +X = forward × up (right), +Y = right × forward (up), +Z = -forward, so the camera
    looks down its local -Z with +Y up (docs/spec.md §3, USD camera convention).
    """
    f = np.asarray(forward, dtype=np.float64)
    f = f / np.linalg.norm(f)
    up = np.asarray(up, dtype=np.float64)
    if abs(np.dot(f, up / np.linalg.norm(up))) > 0.999:
        up = np.array([1.0, 0.0, 0.0]) if abs(f[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, f)
    return np.stack([right, true_up, -f], axis=1)


def pixel_directions_camera(cam: CameraState, width: int, height: int) -> np.ndarray:
    """Unit pixel-centre directions in camera space, (H, W, 3), row 0 at the top."""
    return pixel_directions(cam, width, height, frame="camera")


def lab_pixel_directions(cam: CameraState, width: int, height: int) -> np.ndarray:
    """Lab look directions (H, W, 3): the rest-frame pixel directions aberrated by the
    camera's velocity (relativistic boost, or Galilean for a decoupled camera; docs/spec.md §3)."""
    return pixel_directions(cam, width, height, frame="lab")


def pixel_angle(cam: CameraState, width: int) -> float:
    """Angular size of one pixel at the image centre (radians)."""
    return float(cam.horizontal_aperture) / width / float(cam.focal_length)


def focal_for_fov(hfov_rad: float, horizontal_aperture: float = 20.955) -> float:
    """Focal length giving the full horizontal field of view ``hfov_rad``."""
    return 0.5 * horizontal_aperture / math.tan(0.5 * hfov_rad)


# --------------------------------------------------------------------------- scenes


@dataclass(frozen=True)
class SphereCase:
    """One analytic moving-sphere scene; all lengths in scene units, c = 1."""

    name: str
    velocity: tuple[float, float, float]
    decoupled: bool = False
    radius: float = 1.0
    center: tuple[float, float, float] = (0.0, 0.0, -6.0)  # pivot o at t_ref
    t_ref: float = 0.0
    cam_time: float = 6.0
    cam_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    cam_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    light_speed: str = "finite"
    lifetime: tuple[float, float] = (-math.inf, math.inf)
    segments: int = 64
    precision: str | None = None
    # framing: None = automatic (see frame_case)
    look: tuple[float, float, float] | None = None
    aim: tuple[float, float, float] | None = None  # roughly where the image is; default: towards the pivot
    hfov_deg: float | None = None
    width: int = 96
    height: int = 72

    @property
    def beta(self) -> float:
        return float(np.linalg.norm(self.velocity))


def seen_at_centre(name, velocity, *, distance=6.0, cam_time=6.0, direction=(0.0, 0.0, -1.0), **kw) -> SphereCase:
    """A case whose sphere centre is SEEN (on the camera's past lightcone) at
    ``distance`` along ``direction`` from a camera at the origin: the centre's worldline
    passes that point at lab time cam_time - distance, so t_ref = cam_time - distance and
    the pivot is that point. With infinite light speed the body is seen where it is at
    t_c, so t_ref = cam_time."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    p = tuple(float(x) for x in distance * d)
    t_ref = cam_time if kw.get("light_speed") == "infinite" else cam_time - distance
    return SphereCase(name=name, velocity=tuple(map(float, velocity)), center=p, t_ref=t_ref, cam_time=cam_time, **kw)


def fibonacci_sphere(n: int) -> np.ndarray:
    """n nearly uniform unit vectors on the sphere, (n, 3)."""
    k = np.arange(n, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def oracle_hit(case: SphereCase, dirs_lab: np.ndarray, radius: float | None = None) -> lorentz.SphereHit:
    """:func:`lorentz.sphere_hit` for the case's sphere and camera event."""
    cam_pos = camera_position(case)
    return lorentz.sphere_hit(
        case.cam_time, cam_pos, dirs_lab, np.asarray(case.center), case.radius if radius is None else radius,
        np.asarray(case.velocity), case.t_ref, decoupled=case.decoupled, light_speed=case.light_speed,
        lifetime=case.lifetime, v_cam=np.asarray(case.cam_velocity),
    )


def camera_position(case: SphereCase) -> np.ndarray:
    """The camera event's lab position; a moving camera passes ``cam_pos`` at ``cam_time``."""
    return np.asarray(case.cam_pos, dtype=np.float64)


def frame_case(case: SphereCase, *, fill: float = 1.35, samples: int = 40000) -> tuple[np.ndarray, float]:
    """Automatic framing: (look direction, full horizontal FOV in degrees).

    Casts the oracle over ``samples`` directions on the whole sky (about 1° apart) and
    keeps the hits within 45° of ``case.aim`` (default: the direction of the pivot):
    a superluminal body can show two images, and this picks one. Takes their mean
    direction as the view axis and ``fill`` x the largest angle of such a hit from it
    (widened by the sample spacing) as the half VERTICAL field of view, so the whole
    image is in frame with a margin. Other images that fall in frame are compared too."""
    if case.look is not None and case.hfov_deg is not None:
        return np.asarray(case.look, dtype=np.float64), case.hfov_deg
    aim = np.asarray(case.aim if case.aim is not None else np.subtract(case.center, case.cam_pos), dtype=np.float64)
    aim /= np.linalg.norm(aim)
    v = np.asarray(case.cam_velocity)
    if np.any(v):  # the camera's axes live in its rest frame: aim at the apparent direction
        aim = lorentz.aberrate(aim, -v)
    # the whole sky (spacing ~1°) plus a dense cap of 10° around the aim (spacing ~0.12°)
    sky = fibonacci_sphere(samples)
    cap_cos = math.cos(math.radians(10.0))
    cap = fibonacci_sphere(int(samples * 2.0 / (1.0 - cap_cos)))
    cap = cap[cap[:, 2] > cap_cos]
    cap = -(cap @ look_at(aim).T)  # look_at maps -Z to aim, so the +Z cap goes around -aim: flip
    a = None
    for d, spacing in ((cap, math.sqrt(4.0 * math.pi / (samples * 2.0 / (1.0 - cap_cos)))),
                       (sky, math.sqrt(4.0 * math.pi / samples))):
        d_lab = lorentz.aberrate(d, v) if np.any(v) else d  # d are rest-frame directions
        h = oracle_hit(case, d_lab)
        hit = np.isfinite(h.s) & (d @ aim > math.cos(math.radians(45.0)))
        if not hit.any():
            continue
        a = d[hit].mean(axis=0)
        a /= np.linalg.norm(a)
        half = np.max(np.arccos(np.clip(d[hit] @ a, -1.0, 1.0))) + spacing
        if half < math.radians(9.0) or d is sky:  # whole image inside the dense cap, or use the sky
            break
    if a is None:
        raise AssertionError(f"{case.name}: the sphere is not visible near {aim}")
    look = a if case.look is None else np.asarray(case.look, dtype=np.float64)
    half_v = min(fill * half, math.radians(80.0))
    hfov = 2.0 * math.atan(math.tan(half_v) * case.width / case.height)
    hfov = math.degrees(hfov) if case.hfov_deg is None else case.hfov_deg
    if hfov >= 170.0:
        raise AssertionError(f"{case.name}: the sphere covers too much of the sky to frame ({hfov:.0f} deg)")
    return look, hfov


def camera_state_for(case: SphereCase) -> CameraState:
    look, hfov = frame_case(case)
    return CameraState(
        prim_path="/Camera",
        time=float(case.cam_time),
        position=camera_position(case),
        rotation=look_at(look),
        focal_length=focal_for_fov(math.radians(hfov)),
        horizontal_aperture=20.955,
        vertical_aperture=20.955 * case.height / case.width,
        light_speed=LightSpeed(case.light_speed),
        velocity=np.asarray(case.cam_velocity, dtype=np.float64),
        decoupled=False,
    )


def sphere_mesh(case: SphereCase):
    """Authored world-space tessellated sphere at t_ref: (points, triangles, normals)."""
    pts, tris, nrm = tessellate.sphere(case.radius, case.segments)
    return pts + np.asarray(case.center, dtype=np.float64), tris, nrm


def build_scene(case: SphereCase) -> tuple[Scene, CameraState]:
    """The host Scene for ``case`` (one body, '/Sphere'), and its camera at cam_time.

    The camera callback returns the same camera for any frame except that its time is
    the frame (docs/spec.md §3: t_c = the time code when spacetime:time is not authored) and a
    moving camera is placed at cam_pos + v (frame - cam_time)."""
    pts, tris, nrm = sphere_mesh(case)
    cam = camera_state_for(case)
    body = Body(
        prim_path="/Sphere",
        surfaces=(Surface(prim_path="/Sphere", points=pts, triangles=tris, normals=nrm),),
        origin=np.asarray(case.center, dtype=np.float64),
        velocity=np.asarray(case.velocity, dtype=np.float64),
        reference_time=float(case.t_ref),
        lifetime=tuple(map(float, case.lifetime)),
        decoupled=bool(case.decoupled),
    )

    def camera_state(path, frame):
        dt = float(frame) - float(case.cam_time)
        return CameraState(
            prim_path=cam.prim_path, time=float(frame), position=cam.position + cam.velocity * dt,
            rotation=cam.rotation, focal_length=cam.focal_length, horizontal_aperture=cam.horizontal_aperture,
            vertical_aperture=cam.vertical_aperture, light_speed=cam.light_speed, velocity=cam.velocity,
            decoupled=cam.decoupled,
        )

    scene = Scene(
        source="<analytic>",
        bodies=(body,),
        lights=(),
        cameras=("/Camera",),
        settings=RenderSettings(),
        camera_state=camera_state,
        default_camera="/Camera",
    )
    return scene, cam


# --------------------------------------------------------------------------- oracle image + bounds


def tessellation_gap(case: SphereCase) -> float:
    """g of the case's UV sphere: ball(R - g) ⊆ polyhedron ⊆ ball(R) (``uv_sphere_gap``)."""
    return uv_sphere_gap(case.radius, case.segments)


@dataclass
class OracleImage:
    """Closed-form AOVs for every pixel, float64, (H, W) unless noted.

    s_outer / s_inner: the first hits with the spheres of radius R and R - g (g from
    :func:`tessellation_gap`). In the body frame the ray is a straight line with an
    affine parameter s, and ball(R - g) ⊆ polyhedron ⊆ ball(R), so the first entry into
    the tessellated sphere lies in [s_outer, s_inner] whenever the inner ball is hit.
    """

    case: SphereCase
    cam: CameraState
    dirs_lab: np.ndarray  # (H, W, 3)
    outer: lorentz.SphereHit
    inner: lorentz.SphereHit
    gap: float
    depth_scale: np.ndarray = field(default=None)  # Z / s: camera-rest-frame distance per lab lookback

    @property
    def mask(self) -> np.ndarray:
        return np.isfinite(self.outer.s)

    @property
    def depth_lo(self):
        return self.outer.s * self.depth_scale

    @property
    def depth_hi(self):
        return self.inner.s * self.depth_scale


def oracle_image(case: SphereCase, cam: CameraState | None = None) -> OracleImage:
    cam = camera_state_for(case) if cam is None else cam
    d = lab_pixel_directions(cam, case.width, case.height)
    gap = tessellation_gap(case)
    outer = oracle_hit(case, d)
    inner = oracle_hit(case, d, radius=case.radius - gap)
    v_c = np.asarray(case.cam_velocity, dtype=np.float64)
    # Z: the light's path length in the camera's rest frame = the camera-frame time
    # component of the separation s (1, -n) from the hit to the camera event:
    # gamma_c (s + v_c·(s n)) = s gamma_c (1 + v_c·n)  (just s for a camera at rest).
    scale = lorentz.gamma(v_c) * (1.0 + d @ v_c)
    return OracleImage(case, cam, d, outer, inner, gap, np.broadcast_to(scale, d.shape[:-1]))


# --------------------------------------------------------------------------- image morphology


def erode(mask: np.ndarray, k: int = 1) -> np.ndarray:
    """Binary erosion with the 3x3 square, ``k`` times (outside the image counts as empty)."""
    for _ in range(k):
        mask = ~dilate(~mask)
        mask[0, :] = mask[-1, :] = False
        mask[:, 0] = mask[:, -1] = False
    return mask


def boundary(mask: np.ndarray) -> np.ndarray:
    """Pixels of ``mask`` with at least one 4-neighbour outside it."""
    p = np.pad(mask, 1, constant_values=False)
    inner = p[1:-1, 1:-1] & p[:-2, 1:-1] & p[2:, 1:-1] & p[1:-1, :-2] & p[1:-1, 2:]
    return mask & ~inner


# --------------------------------------------------------------------------- cone on the sky


def predicted_outline_cone(center, radius, v, t_ref, cam_time, cam_pos) -> tuple[np.ndarray, float]:
    """Penrose-Terrell: the lab outline cone of a coupled sphere (axis, half-angle).

    In the body's rest frame the sphere is at rest and the camera event sees it as the
    cone of half-angle arcsin(R/d') about the direction n'_0 to its centre, d' the
    rest-frame distance between the camera event and the centre's worldline. The lab
    view of those directions is the camera's own aberration: in the body frame the
    camera moves with -v, and for a camera moving with u, frame directions =
    aberrate(camera-rest directions, u), whose inverse is aberrate(., -u); so the lab
    (camera rest) directions are aberrate(body-frame directions, +v).
    Aberration maps circles on the sky to circles, so the lab outline is a circle; its
    axis is the bisector of the aberrated extreme rays in the plane of v and n'_0.
    """
    lam = lorentz.boost(np.asarray(v, dtype=np.float64))
    ev = np.concatenate([[cam_time - t_ref], np.asarray(cam_pos, dtype=np.float64) - np.asarray(center)])
    cam_rest = lam @ ev  # camera event in the body's rest frame (centre at the spatial origin)
    to_centre = -cam_rest[1:]
    dist = np.linalg.norm(to_centre)
    n0 = to_centre / dist
    rho_rest = math.asin(radius / dist)
    # extreme rays in the plane of v and n0 (any plane through n0 if v ∥ n0)
    vv = np.asarray(v, dtype=np.float64)
    perp = vv - (vv @ n0) * n0
    if np.linalg.norm(perp) < 1e-12:
        perp = np.cross(n0, [1.0, 0.0, 0.0] if abs(n0[0]) < 0.9 else [0.0, 1.0, 0.0])
    perp /= np.linalg.norm(perp)
    ext = np.stack([math.cos(rho_rest) * n0 + s * math.sin(rho_rest) * perp for s in (1.0, -1.0)])
    # the camera (at rest in the lab) moves with -v in the body frame: invert that aberration
    ext_lab = lorentz.aberrate(ext, vv)
    axis = ext_lab[0] + ext_lab[1]
    axis /= np.linalg.norm(axis)
    half = 0.5 * math.acos(float(np.clip(ext_lab[0] @ ext_lab[1], -1.0, 1.0)))
    return axis, half


# --------------------------------------------------------------------------- renderer access


def render_case(case: SphereCase, scene: Scene | None = None):
    """Render ``case`` with the real renderer (``warp_st.render``), the Image."""
    import warp_st

    if scene is None:
        scene, _ = build_scene(case)
    kw = dict(frame=case.cam_time, width=case.width, height=case.height)
    if case.precision is not None:
        kw["precision"] = case.precision
    return warp_st.render(scene, **kw)


# --------------------------------------------------------------------------- lifetimes


@dataclass
class LifetimeExpectation:
    """Per-pixel expectation for a body with a finite lifetime (H, W).

    certain: the tessellation/float uncertainty cannot change the answer;
    hit: the first hit exists (on certain pixels);
    s_lo, s_hi: bounds of its lookback; far_wall: the hit is the exit crossing
    (seen from inside the world-tube through a missing cap).
    """

    certain: np.ndarray
    hit: np.ndarray
    s_lo: np.ndarray
    s_hi: np.ndarray
    far_wall: np.ndarray


def lifetime_expectation(case: SphereCase, cam: CameraState, slack) -> LifetimeExpectation:
    """Which crossing of the world-tube's side each pixel sees when the lifetime cuts it.

    In the body frame ball(R - g) ⊆ P ⊆ ball(R), so the polyhedron's entry lies in
    [enter_R, enter_{R-g}] and its exit in [exit_{R-g}, exit_R]. A crossing counts when
    its event time t_c - s is in (tBegin, tEnd) (finite c; with infinite c all events are
    at t_c). A pixel is certain when each interval lies entirely inside or entirely
    outside the lifetime (by more than ``slack(s)``); rays that miss ball(R - g) but hit
    ball(R) are uncertain (the silhouette band).
    """
    d = lab_pixel_directions(cam, case.width, case.height)
    gap = tessellation_gap(case)
    args = (case.cam_time, camera_position(case), d, np.asarray(case.center))
    kw = dict(decoupled=case.decoupled, light_speed=case.light_speed)
    o0, o1 = lorentz.sphere_crossings(*args, case.radius, np.asarray(case.velocity), case.t_ref, **kw)
    i0, i1 = lorentz.sphere_crossings(*args, case.radius - gap, np.asarray(case.velocity), case.t_ref, **kw)
    t_b, t_e = case.lifetime
    step = -1.0 if case.light_speed == "finite" else 0.0

    def status(a, b):
        """+1 surely inside the lifetime, -1 surely outside, 0 uncertain, for s in [a, b]."""
        eps = slack(np.abs(b))
        t_hi = case.cam_time + step * a
        t_lo = case.cam_time + step * b
        inside = (t_lo >= t_b + eps) & (t_hi <= t_e - eps) & (a >= 0.0)
        outside = (t_hi < t_b - eps) | (t_lo > t_e + eps) | (b < 0.0)
        return np.where(inside, 1, np.where(outside, -1, 0))

    outer_hit = np.isfinite(o0)
    inner_hit = np.isfinite(i0)
    enter = status(o0, i0)
    leave = status(i1, o1)
    hit_enter = inner_hit & (enter == 1)
    hit_leave = inner_hit & (enter == -1) & (leave == 1)
    miss = ~outer_hit | (inner_hit & (enter == -1) & (leave == -1))
    certain = hit_enter | hit_leave | miss
    s_lo = np.where(hit_enter, o0, np.where(hit_leave, i1, np.nan))
    s_hi = np.where(hit_enter, i0, np.where(hit_leave, o1, np.nan))
    return LifetimeExpectation(certain, hit_enter | hit_leave, s_lo, s_hi, hit_leave)
