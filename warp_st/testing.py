"""Oracles and host scenes shared by the tests and the benchmarks (examples/benchmarks/).

Nothing in the library imports this module; it may import anything in warp_st. Every
reference here is float64 NumPy, independent of the kernels:

- host scenes without USD: :func:`synthetic_scene` around :func:`rest_camera`, the
  :func:`sphere_grid_scene` of moving UV spheres, and :class:`SphereView`, one sphere seen
  at its centre (:func:`sphere_view_scene`, :func:`render_view`);
- the closed-form moving sphere (``warp_st.core.lorentz.sphere_hit``) against a render:
  :func:`sphere_errors` (silhouette and depth error in pixels) and, against the exact hit
  of the same tessellated mesh, :func:`numerical_errors` (:func:`polyhedron_hit`);
- :func:`fit_cone`, the best circle on the sky through a set of directions (outlines).

Pixel directions come from :func:`warp_st.rendering.camera.ray_directions`, the NumPy twin
of the kernel camera.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from warp_st.core import lorentz, tessellate
from warp_st.core.scene import Body, CameraState, Material, RenderSettings, Scene, Surface
from warp_st.rendering.camera import pixel_directions, ray_directions

__all__ = [
    "rest_camera",
    "synthetic_scene",
    "SPHERE_MOTIONS",
    "sphere_grid_scene",
    "SphereView",
    "sphere_view_scene",
    "render_view",
    "uv_sphere_gap",
    "pixel_pitch",
    "dilate",
    "sphere_errors",
    "polyhedron_hit",
    "numerical_errors",
    "fit_cone",
]


# --------------------------------------------------------------------------- host scenes


def rest_camera(focal: float = 27.0) -> CameraState:
    """At rest at the origin at t_c = 0, looking down -Z, +Y up; 36 mm aperture."""
    return CameraState("/Camera", 0.0, np.zeros(3), np.eye(3), focal_length=focal, horizontal_aperture=36.0,
                       vertical_aperture=20.25)


def synthetic_scene(name: str, bodies, lights, cam_state: CameraState) -> Scene:
    """A host Scene (no USD) with one camera whose time is the frame (docs/spec.md §3)."""

    def camera_state(path, frame):
        return dataclasses.replace(cam_state, time=float(frame) if frame is not None else float(cam_state.time))

    return Scene(
        source=f"<synthetic:{name}>",
        bodies=tuple(bodies),
        lights=tuple(lights),
        cameras=(cam_state.prim_path,),
        settings=RenderSettings(),
        camera_state=camera_state,
        default_camera=cam_state.prim_path,
    )


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
                      lights=(), mirror_centre: bool = False) -> Scene:
    """n x n tessellated spheres at z = -30 (the 10 x 10 grid of radius 1, spacing 4 x 2.25
    shrunk by ``scale``, default 10 / n, so any n covers the same part of the image),
    mixed velocities (``SPHERE_MOTIONS``) unless ``moving`` is False, unlit by default.

    Each body's reference time is chosen so its centre is seen (on the camera's past
    lightcone) at its grid position: t_ref = t_c - |centre - camera|.
    ``mirror_centre`` makes the sphere nearest the image centre a perfect mirror.
    """
    cam = rest_camera()
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


# --------------------------------------------------------------------------- one analytic sphere


@dataclasses.dataclass(frozen=True)
class SphereView:
    """One sphere seen at its centre (on the camera's past lightcone) at ``distance``
    along -Z from a camera at rest at ``shift_x``, at camera time ``cam_time + shift_t``.

    segments: fixed UV longitudes, or None for the renderer's adaptive choice (the
        surface then carries its analytic ``sphere``, as the USD reader sets it).
    quadrics: the renderer's ``quadrics`` option ("exact" or "tessellated"; None: its
        default, exact on the rigid path) for an analytic sphere.
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
    quadrics: str | None = None

    @property
    def centre(self) -> np.ndarray:
        return np.asarray(self.shift_x, dtype=np.float64) + np.array([0.0, 0.0, -self.distance])

    @property
    def t_c(self) -> float:
        return float(self.cam_time + self.shift_t)

    @property
    def t_ref(self) -> float:
        return self.t_c - self.distance

    def camera(self) -> CameraState:
        h_ap = 20.955
        focal = 0.5 * h_ap / math.tan(0.5 * math.radians(self.hfov_deg))
        return CameraState("/Camera", self.t_c, np.asarray(self.shift_x, dtype=np.float64), np.eye(3),
                           focal_length=focal, horizontal_aperture=h_ap,
                           vertical_aperture=h_ap * self.height / self.width)

    def render_options(self) -> dict:
        """The ``Renderer`` keywords of this view: its frame, size and precision."""
        kw = dict(frames=[self.t_c], width=self.width, height=self.height, precision=self.precision)
        return kw if self.quadrics is None else {**kw, "quadrics": self.quadrics}


def sphere_view_scene(view: SphereView) -> Scene:
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


def render_view(view: SphereView):
    """(Renderer, Image) of ``view``'s frame."""
    from warp_st.rendering.renderer import Renderer

    r = Renderer(sphere_view_scene(view), **view.render_options())
    return r, r.render(view.t_c)


def uv_sphere_gap(radius: float, segments: int) -> float:
    """g = R - (smallest distance from the centre to a triangle's plane) of the UV sphere.

    Every vertex lies on the sphere, so the convex polyhedron P satisfies
    ball(R - g) ⊆ P ⊆ ball(R); g ≈ R (1 - cos(√2 π / n)), about twice the great-circle
    sagitta (the widest triangle spans a quad's diagonal), computed from the mesh.
    """
    pts, tris, _ = tessellate.sphere(radius, segments)
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    nrm = np.cross(b - a, c - a)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    return float(radius - np.abs(np.sum(nrm * a, axis=-1)).min())


def pixel_pitch(cam: CameraState, width: int, height: int) -> np.ndarray:
    """Angle (radians) between each pixel centre and its right / lower neighbour, the
    smaller of the two, (H, W): the local angular size of a pixel."""
    j, i = np.mgrid[0:height + 1, 0:width + 1]
    d = ray_directions(cam, width, height, i + 0.5, j + 0.5, frame="camera")

    def angle(a, b):
        return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))

    return np.minimum(angle(d[:-1, :-1], d[:-1, 1:]), angle(d[:-1, :-1], d[1:, :-1]))


def dilate(mask: np.ndarray, k: int = 1) -> np.ndarray:
    """Binary dilation with the 3x3 square, ``k`` times (outside the image counts as empty)."""
    h, w = mask.shape
    for _ in range(k):
        p = np.pad(mask, 1, constant_values=False)
        mask = np.zeros_like(mask)
        for dj in (0, 1, 2):
            for di in (0, 1, 2):
                mask |= p[dj:dj + h, di:di + w]
    return mask


def _oracle(view: SphereView, dirs, radius=None) -> lorentz.SphereHit:
    return lorentz.sphere_hit(view.t_c, np.asarray(view.shift_x, dtype=np.float64), dirs, view.centre,
                              view.radius if radius is None else radius, np.asarray(view.velocity, dtype=np.float64),
                              view.t_ref, decoupled=view.decoupled)


def _body_frame_ray(view: SphereView, dirs):
    """The rays in the body frame, A + s B relative to the centre (``lorentz._body_frame_ray``)."""
    return lorentz._body_frame_ray(view.t_c, np.asarray(view.shift_x, dtype=np.float64), dirs, view.centre,
                                   np.asarray(view.velocity, dtype=np.float64), view.t_ref,
                                   decoupled=view.decoupled, light_speed="finite")


def _hits(view: SphereView, cam: CameraState, p: np.ndarray) -> np.ndarray:
    """Whether the exact sphere is hit through image positions ``p`` (..., 2) = (x, y) in pixels."""
    return np.isfinite(_oracle(view, ray_directions(cam, view.width, view.height, p[..., 0], p[..., 1])).s)


def _boundary_points(mask: np.ndarray, sub: int) -> np.ndarray:
    """Pixel-unit coordinates (x, y) of the midpoints between 4-neighbour samples of a
    sub-sampled mask that disagree (the outline, to 1 / (2 sub) pixel)."""
    pts = []
    ys, xs = np.nonzero(mask[:, 1:] != mask[:, :-1])
    pts.append(np.stack([(xs + 1.0) / sub, (ys + 0.5) / sub], axis=1))
    ys, xs = np.nonzero(mask[1:, :] != mask[:-1, :])
    pts.append(np.stack([(xs + 0.5) / sub, (ys + 1.0) / sub], axis=1))
    return np.concatenate(pts)


def _fine_mask(view, cam, hit_o, differ, sub):
    """The exact hit mask on a sub x sub grid of samples per pixel, (H sub, W sub): the
    oracle is evaluated only within 2 px of the outline (elsewhere a pixel's samples all
    equal its centre)."""
    p = np.pad(hit_o, 1, mode="edge")
    edge = (p[1:-1, 1:-1] != p[:-2, 1:-1]) | (p[1:-1, 1:-1] != p[2:, 1:-1]) | \
           (p[1:-1, 1:-1] != p[1:-1, :-2]) | (p[1:-1, 1:-1] != p[1:-1, 2:])
    near = dilate(edge | differ, 2)
    fine = np.repeat(np.repeat(hit_o, sub, axis=0), sub, axis=1)
    ys, xs = np.nonzero(near)
    off = (np.arange(sub) + 0.5) / sub
    sx = xs[:, None, None] + off[None, None, :]
    sy = ys[:, None, None] + off[None, :, None]
    pts = np.stack(np.broadcast_arrays(sx, sy), axis=-1)  # (N, sub, sub, 2)
    hit = _hits(view, cam, pts.reshape(-1, 2)).reshape(len(ys), sub, sub)
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
    lo, hi = centres.copy(), far
    crossed = _hits(view, cam, hi) != inside
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        same = _hits(view, cam, mid) == inside
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
    A, B = _body_frame_ray(view, dirs)  # body-frame position of each rendered hit event: A + Z B
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
    pts, tris, _ = tessellate.sphere(view.radius, segments)
    v0, v1, v2 = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    e1, e2 = v1 - v0, v2 - v0
    A, B = _body_frame_ray(view, dirs)
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


# --------------------------------------------------------------------------- circles on the sky


def fit_cone(dirs: np.ndarray, iterations: int = 30) -> tuple[np.ndarray, float, np.ndarray]:
    """Fit a circle on the unit sphere (a circular cone) to unit directions (N, 3).

    Returns (axis a, half-angle rho, residual angles angle(a, d_i) - rho). Start: the
    plane fit (a·d_i = cos rho is a plane: a = the smallest principal axis of the
    centred points, oriented towards their mean); then Gauss-Newton on the angular
    residuals over the two tangent-plane rotations of a and rho, until no step exceeds
    1e-14 (after convergence the steps are 1e-18..1e-15 of rounding).

    ``iterations``: measured on outlines of the closed-form sphere, exact circles need 1
    to 4 steps (quadratic convergence) and non-circular ones (decoupled spheres at 0.5c
    to 0.999c, whose residuals do not vanish) 8 to 13 (linear, about x0.1 a step); 30
    leaves more than twice that.
    """
    d = np.asarray(dirs, dtype=np.float64)
    m = d.mean(axis=0)
    _w, vecs = np.linalg.eigh(np.cov((d - m).T))
    a = vecs[:, 0]
    if a @ m < 0:
        a = -a
    rho = float(np.arccos(np.clip(d @ a, -1.0, 1.0)).mean())
    for _ in range(iterations):
        e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        ang = np.arccos(np.clip(d @ a, -1.0, 1.0))
        sin_ang = np.maximum(np.sin(ang), 1e-300)
        # d(angle)/d(a along e_k) = -(d·e_k)/sin(angle); d r/d rho = -1
        J = np.stack([-(d @ e1) / sin_ang, -(d @ e2) / sin_ang, -np.ones_like(ang)], axis=1)
        step, *_ = np.linalg.lstsq(J, rho - ang, rcond=None)
        a = a + step[0] * e1 + step[1] * e2
        a /= np.linalg.norm(a)
        rho += float(step[2])
        if np.max(np.abs(step)) < 1e-14:
            break
    return a, rho, np.arccos(np.clip(d @ a, -1.0, 1.0)) - rho
