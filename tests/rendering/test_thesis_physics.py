"""The thesis's optical laws, measured on rendered images (Black 2005, §2.3 and §4.4).

(a) Aberration (Eqs. 2.1, 2.3): a small sphere at rest, 1000 units away at angle alpha
    from the velocity of a moving camera, is seen in the camera's rest frame at
    cos a' = (cos a + b)/(1 + b cos a) (relativistic, Lorentz boost) or at
    tan t' = sin t/(cos t + b) (classical, a Lorentz-decoupled camera: Galilean
    addition). The formulas are written out here from the thesis, independently of
    ``lorentz.aberrate`` and of the kernel.
(b) Retarded position (§2.3.1): a small sphere moving past a camera at rest is seen
    where its centre was at the retarded time (``lorentz.retarded_time``), for beta from
    the thesis's 0.00866 to 0.99, across, towards and away from the camera.
(c) Doppler: the doppler AOV is (k·u_cam)/(k·u_body) per pixel (``lorentz.doppler``)
    for coupled and decoupled bodies and cameras, at rest and moving.

Measurement for (a) and (b): the solid-angle-weighted mean direction of the sphere's
pixels (pixel-centre directions of the docs/spec.md §3 pinhole, written out here), compared
with the expected direction projected to pixel coordinates. Tolerance: half a pixel.
Each image is framed so that the sphere's image is about 10 pixels in radius, so half
a pixel is 1/20 of its apparent radius, while the two aberration formulas (and the
retarded against the instantaneous position) differ by up to thousands of pixels:
the test discriminates. What a centroid cannot resolve is second order in the
sphere's angular radius rho (0.25 degrees): the centre of a circle's image under
aberration moves by about rho x (d ln scale / d alpha) x its radius, at most 0.15
pixel here, and the pinhole projection of a disc 2 radii off-axis by far less. The
tessellated outline (64 longitudes) is symmetric about the centre and moves nothing.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from analytic_scenes import EPS32, lab_pixel_directions, look_at

import warp_st
from warp_st.core import lorentz, tessellate
from warp_st.core.conventions import LightSpeed
from warp_st.core.scene import Body, CameraState, Material, RenderSettings, Scene, Surface

SIZE = 64  # pixels; the sphere's image is framed at RADIUS_PX
RADIUS_PX = 10.0
RHO = math.radians(0.25)  # the sphere's angular radius seen at rest
APERTURE = 20.955


# --------------------------------------------------------------------------- helpers


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def pixel_dirs(cam: CameraState, px, py) -> np.ndarray:
    """Rest-frame look directions (lab axes) at continuous pixel coordinates (docs/spec.md §3)."""
    px, py = np.broadcast_arrays(np.asarray(px, float), np.asarray(py, float))
    ap = float(cam.horizontal_aperture)
    x = (2.0 * px / SIZE - 1.0) * 0.5 * ap
    y = (1.0 - 2.0 * py / SIZE) * 0.5 * ap  # square image: vAp = hAp
    d = np.stack([x, y, np.full_like(x, -float(cam.focal_length))], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d @ np.asarray(cam.rotation).T


def pixel_of(cam: CameraState, d) -> np.ndarray:
    """Continuous pixel coordinates of a rest-frame direction (inverse of pixel_dirs)."""
    c = np.asarray(d, float) @ np.asarray(cam.rotation)
    f, ap = float(cam.focal_length), float(cam.horizontal_aperture)
    return np.array([(-f * c[0] / c[2] / (0.5 * ap) + 1.0) * SIZE / 2, (1.0 + f * c[1] / c[2] / (0.5 * ap)) * SIZE / 2])


def centroid_pixel(img, cam) -> np.ndarray:
    """Pixel coordinates of the solid-angle-weighted mean direction of the hit pixels."""
    j, i = np.nonzero(img.object_id > 0)
    assert len(i) > 50, f"the sphere covers only {len(i)} pixels"
    assert i.min() > 0 and j.min() > 0 and i.max() < SIZE - 1 and j.max() < SIZE - 1, "the sphere is cut by the frame"
    d = pixel_dirs(cam, i + 0.5, j + 0.5)
    axis = np.asarray(cam.rotation) @ np.array([0.0, 0.0, -1.0])
    w = (d @ axis) ** 3  # a pinhole pixel's solid angle ∝ cos^3 of its angle off the axis
    return pixel_of(cam, _unit((d * w[:, None]).sum(axis=0)))


def sphere_body(centre, radius, velocity=(0.0, 0.0, 0.0), t_ref=0.0, decoupled=False, path="/Sphere"):
    pts, tris, nrm = tessellate.sphere(radius)
    c = np.asarray(centre, np.float64)
    return Body(path, (Surface(path, pts + c, tris, Material((0.8, 0.8, 0.8)), nrm),), c,
                np.asarray(velocity, np.float64), float(t_ref), (-math.inf, math.inf), decoupled)


def camera(aim, half_angle, *, t_c=0.0, position=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0), decoupled=False,
           offset=(1.5, -1.0), light_speed="finite") -> CameraState:
    """A square pinhole camera whose image of the sphere (angular radius ``half_angle``
    around ``aim``, rest frame) is RADIUS_PX pixels in radius, the sphere placed
    ``offset`` radii off the image centre (so the pixel mapping is exercised)."""
    pix = half_angle / RADIUS_PX  # radians per pixel near the centre
    focal = 0.5 * APERTURE / math.tan(0.5 * SIZE * pix)
    rot0 = look_at(aim)
    # turn the view so that ``aim`` lands offset radii from the centre
    x, y = offset
    look = rot0 @ _unit([-x * half_angle, -y * half_angle, -1.0])
    rot = look_at(look, up=rot0[:, 1])
    return CameraState("/Camera", float(t_c), np.asarray(position, float), rot, focal, APERTURE, APERTURE,
                       light_speed=LightSpeed(light_speed), velocity=np.asarray(velocity, float), decoupled=decoupled)


def render(bodies, cam, size=SIZE) -> warp_st.Image:
    def state(path, frame):
        return cam

    scene = Scene("<thesis physics>", tuple(bodies), (), ("/Camera",), RenderSettings(), state, default_camera="/Camera")
    return warp_st.render(scene, frame=cam.time, width=size, height=size)


# --------------------------------------------------------------------------- (a) aberration


def apparent(n_lab, v, classical: bool) -> np.ndarray:
    """Thesis Eq. 2.3 (relativistic) / Eq. 2.1 (classical): the rest-frame direction of a
    source seen along the lab direction n_lab by an observer moving with velocity v. The
    apparent direction stays in the plane of v and n_lab, at angle a' from v."""
    n = _unit(n_lab)
    b = float(np.linalg.norm(v))
    vh = np.asarray(v, float) / b
    ca = float(n @ vh)
    sa = math.sqrt(max(0.0, 1.0 - ca * ca))
    a2 = math.atan2(sa, ca + b) if classical else math.acos((ca + b) / (1.0 + b * ca))
    e = _unit(n - ca * vh)
    return math.cos(a2) * vh + math.sin(a2) * e


def apparent_radius(n_lab, v, classical, rho) -> float:
    """Angular radius of a small disc after aberration (the larger of its two axes),
    from the formula applied to four points of its rim: for framing only."""
    n = _unit(n_lab)
    c = apparent(n, v, classical)
    e1 = _unit(np.cross(n, [0.0, 0.0, 1.0]))
    e2 = np.cross(n, e1)
    rim = [math.cos(rho) * n + math.sin(rho) * e for e in (e1, -e1, e2, -e2)]
    return max(math.acos(np.clip(apparent(r, v, classical) @ c, -1, 1)) for r in rim)


AB_CASES = [(beta, alpha, classical) for beta in (0.1, 0.5, 0.866, 0.99) for alpha in (30.0, 90.0, 150.0)
            for classical in (False, True)]


@pytest.mark.parametrize("beta,alpha,classical", AB_CASES,
                         ids=[f"{'classical' if c else 'relativistic'}-b{b}-a{a:.0f}" for b, a, c in AB_CASES])
def test_aberration_of_a_distant_sphere_matches_the_thesis_equations(beta, alpha, classical):
    """A sphere at rest at lab angle alpha from the camera's velocity is seen where Eq. 2.3
    (relativistic camera) or Eq. 2.1 (Lorentz-decoupled camera) puts it, to half a pixel."""
    vh = _unit([1.0, 0.2, 0.0])  # not along an axis
    v = beta * vh
    w = np.array([0.3, -0.2, -1.0])
    e = _unit(w - (w @ vh) * vh)  # perpendicular to v
    a = math.radians(alpha)
    n_lab = math.cos(a) * vh + math.sin(a) * e
    D = 1000.0
    body = sphere_body(D * n_lab, D * math.sin(RHO))
    want = apparent(n_lab, v, classical)
    rho2 = apparent_radius(n_lab, v, classical, RHO)
    cam = camera(want, rho2, t_c=0.0, velocity=v, decoupled=classical)
    img = render([body], cam)
    got = centroid_pixel(img, cam)
    expect = pixel_of(cam, want)
    other = pixel_of(cam, apparent(n_lab, v, not classical))
    assert np.linalg.norm(got - expect) < 0.5, (got, expect)
    # the other formula is far away (or behind the camera) wherever the two differ by more than 3 pixels
    if math.degrees(math.acos(np.clip(apparent(n_lab, v, True) @ apparent(n_lab, v, False), -1, 1))) > 3 * math.degrees(rho2 / RADIUS_PX):
        assert np.linalg.norm(got - other) > 2.0


def test_aberration_thesis_numbers():
    """The thesis's quoted shifts of a source perpendicular to the motion (§4.4.3-4.4.4):
    26.565 deg classical and 30.0 deg relativistic at 0.5c, from Eqs. 2.1 and 2.3."""
    n = np.array([0.0, 0.0, -1.0])
    v = np.array([-0.5, 0.0, 0.0])
    shift = lambda d: math.degrees(math.acos(-d[2]))  # noqa: E731
    assert abs(shift(apparent(n, v, True)) - 26.565) < 1e-3
    assert abs(shift(apparent(n, v, False)) - 30.0) < 1e-9


# --------------------------------------------------------------------------- (b) retarded position

RET_CASES = []
for _beta in (0.00866, 0.1, 0.5, 0.866, 0.99):
    for _name, _dir in (("across", (1.0, 0.0, 0.0)), ("towards", (0.6, 0.0, 0.8)), ("away", (0.6, 0.3, -0.74))):
        RET_CASES.append((_beta, _name, _dir, False))
RET_CASES += [(0.5, "across-decoupled", (1.0, 0.0, 0.0), True), (0.5, "towards-decoupled", (0.6, 0.0, 0.8), True)]


def oracle_half_angle(body: Body, aim) -> float:
    """Largest angle from ``aim`` of a ray that hits the closed-form sphere
    (``lorentz.sphere_hit``) seen from the origin at t = 0: for framing only."""
    aim = _unit(aim)
    e1 = _unit(np.cross(aim, [0.0, 1.0, 0.0]))
    e2 = np.cross(aim, e1)
    k = np.arange(6000) + 0.5
    for cap in (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4, 0.8):
        r = cap * np.sqrt(k / len(k))
        phi = k * math.pi * (3.0 - math.sqrt(5.0))
        dirs = (np.cos(r)[:, None] * aim + np.sin(r)[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2))
        h = lorentz.sphere_hit(0.0, np.zeros(3), dirs, body.origin, body_radius(body), body.velocity,
                               body.reference_time, decoupled=body.decoupled)
        hit = np.isfinite(h.s)
        if hit.any() and r[hit].max() < 0.8 * cap:
            return float(r[hit].max())
    raise AssertionError("the sphere is not near its expected direction")


def body_radius(body: Body) -> float:
    return float(np.linalg.norm(body.surfaces[0].points[0] - body.origin))


@pytest.mark.parametrize("beta,name,direction,decoupled", RET_CASES,
                         ids=[f"{n}-b{b}" for b, n, _, _ in RET_CASES])
def test_moving_point_is_seen_at_its_retarded_position(beta, name, direction, decoupled):
    """A small sphere moving at beta past a camera at rest at the origin (t_c = 0) is seen
    at its centre's retarded position p + v (t_ret - t_ref), t_ret = lorentz.retarded_time,
    to half a pixel, and not at its position at t_c."""
    D = 100.0
    v = beta * _unit(direction)
    # the centre is at (3, 1, -D) at lab time -D: seen roughly there, but only roughly
    p_ref, t_ref = np.array([3.0, 1.0, -D]), -D
    R = D * math.sin(RHO)
    body = sphere_body(p_ref, R, v, t_ref, decoupled)
    t_ret = float(lorentz.retarded_time(p_ref, v, t_ref, 0.0, np.zeros(3)))
    seen = p_ref + v * (t_ret - t_ref)
    now = p_ref + v * (0.0 - t_ref)
    want = _unit(seen)
    cam = camera(want, oracle_half_angle(body, want))
    img = render([body], cam)
    got = centroid_pixel(img, cam)
    expect = pixel_of(cam, want)
    assert np.linalg.norm(got - expect) < 0.5, (got, expect, name)
    # where it is "now" (at t_c) is at least 0.3 degrees = 12 pixels away, even at 0.00866c
    d_now = _unit(now)
    if d_now @ (np.asarray(cam.rotation) @ [0, 0, -1.0]) > 0.2:  # else it is not even in front
        assert np.linalg.norm(got - pixel_of(cam, d_now)) > 5.0


# --------------------------------------------------------------------------- (c) Doppler


def cube(path, centre, size, velocity, t_ref=0.0, decoupled=False):
    pts, tris = tessellate.cube(size)
    c = np.asarray(centre, float)
    return Body(path, (Surface(path, pts + c, tris, Material()),), c, np.asarray(velocity, float), t_ref,
                (-math.inf, math.inf), decoupled)


DOPPLER_BODIES = [
    ("rest", lambda: sphere_body((0.0, 0.0, -9.0), 1.0, path="/Rest")),
    ("coupled 0.9 +x", lambda: sphere_body((-3.0, 1.5, -8.0), 1.0, (0.9, 0.0, 0.0), t_ref=-8.0, path="/Fast")),
    ("decoupled 0.5 -y", lambda: cube("/Dec", (2.5, 1.5, -7.0), 1.5, (0.0, -0.5, 0.0), t_ref=-7.0, decoupled=True)),
    ("coupled oblique", lambda: cube("/Obl", (2.5, -2.0, -7.0), 1.5, (0.3, 0.3, 0.6), t_ref=-7.0)),
    ("coupled 0.7 towards", lambda: sphere_body((-2.5, -2.0, -8.0), 1.0, (0.0, 0.0, 0.7), t_ref=-8.0, path="/Tow")),
]
DOPPLER_CAMERAS = [  # name, velocity, decoupled, light speed, focal length (all bodies in view)
    ("camera at rest", (0.0, 0.0, 0.0), False, "finite", 8.0),
    ("camera 0.6 +x", (0.6, 0.0, 0.0), False, "finite", 4.0),
    ("camera 0.8 forward", (0.0, 0.0, -0.8), False, "finite", 20.0),
    ("decoupled camera 0.6 +y", (0.0, 0.6, 0.0), True, "finite", 4.0),
    ("camera 0.5 +x, infinite c", (0.5, 0.0, 0.0), False, "infinite", 5.0),
]
DOPPLER_SIZE = 96


@pytest.mark.parametrize("cam_name,v_cam,cam_dec,light_speed,focal", DOPPLER_CAMERAS, ids=[c[0] for c in DOPPLER_CAMERAS])
def test_doppler_aov_is_k_dot_u_ratio(cam_name, v_cam, cam_dec, light_speed, focal):
    """doppler = (k·u_cam)/(k·u_body), k = (1, -n_lab) towards the camera, u = gamma (1, v)
    (coupled) or (1, v) (decoupled), per pixel, with n_lab the pixel's rest-frame direction
    aberrated to the lab. It depends only on the pixel's direction and the velocities, so it
    must agree to float32 rounding: 64 eps32 relative, amplified by 1/|1 + n·v| for each of
    the camera and the body (the rounding of n·v), plus 2 eps32 for the FLOAT channel."""
    bodies = [make() for _, make in DOPPLER_BODIES]
    v_cam = np.asarray(v_cam, float)
    cam = CameraState("/Camera", 0.0, np.zeros(3), look_at([0.0, 0.0, -1.0]), focal, APERTURE, APERTURE,
                      light_speed=LightSpeed(light_speed), velocity=v_cam, decoupled=cam_dec)
    img = render(bodies, cam, DOPPLER_SIZE)
    n_lab = lab_pixel_directions(cam, DOPPLER_SIZE, DOPPLER_SIZE)
    seen = set(int(k) for k in np.unique(img.object_id)) - {0}
    # with infinite light speed the bodies are where they are at t_c: the oblique cube has left the view
    assert len(seen) >= (4 if light_speed == "finite" else 3), f"bodies in view: {sorted(seen)}"
    worst = 0.0
    for k, b in enumerate(bodies, start=1):
        m = img.object_id == k
        if k not in seen:
            continue
        n = n_lab[m]
        want = lorentz.doppler(n, b.velocity, v_cam, body_decoupled=b.decoupled, cam_decoupled=cam_dec,
                               light_speed=light_speed)
        got = img.doppler[m].astype(np.float64)
        amp = 1.0 + np.abs(n @ b.velocity) / np.abs(1.0 + n @ b.velocity) + np.abs(n @ v_cam) / np.abs(1.0 + n @ v_cam)
        tol = (64.0 * amp + 2.0) * EPS32 * np.abs(want)
        err = np.abs(got - want)
        assert np.all(err <= tol), (DOPPLER_BODIES[k - 1][0], float((err / tol).max()))
        worst = max(worst, float((err / np.abs(want)).max()))
        if light_speed == "infinite":
            g_cam = 1.0 if cam_dec else 1.0 / math.sqrt(1.0 - v_cam @ v_cam)
            g_body = 1.0 if b.decoupled else 1.0 / math.sqrt(1.0 - b.velocity @ b.velocity)
            assert np.allclose(got, g_cam / g_body, rtol=4 * EPS32)
    assert worst < 1e-5
