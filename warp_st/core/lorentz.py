"""Float64 NumPy special-relativistic kinematics: the physics oracle.

Everything here is plain NumPy in float64, vectorised over leading axes, and is the
reference the Warp kernels and the analytic render tests are checked against.

Conventions (docs/spec.md §1, ``conventions.py``):

- c = 1; events and 4-vectors are ordered (t, x, y, z), shape (..., 4).
- Minkowski signature (-, +, +, +): ``a·b = -a_t b_t + a_x b_x + a_y b_y + a_z b_z``.
- 3-vectors (positions, velocities, directions) have shape (..., 3) and broadcast
  against each other by the usual NumPy rules.
- The lab frame is USD world space. A primary ray from the camera event (t_c, c)
  looking along the unit direction n is the past null line
  E(s) = (t_c - s, c + s n), s >= 0 (``finite`` light speed), or
  E(s) = (t_c, c + s n) (``infinite``, no light delay).
- The photon that arrives at a camera looking along n travels along -n: its
  4-momentum (frequency-normalised) is k = (1, -n).

Thesis references are to Black (2005), "Spacetime ray tracing", chapters 2 and 4.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = [
    "minkowski_dot",
    "contraction_matrix",
    "gamma",
    "four_velocity",
    "boost",
    "rest_from_lab",
    "lab_from_rest",
    "aberrate",
    "doppler",
    "proper_time",
    "worldline_point",
    "contract",
    "uncontract",
    "SphereHit",
    "sphere_crossings",
    "sphere_hit",
    "retarded_time",
    "solve_quadratic",
]


def _vec3(v) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    if a.shape[-1:] != (3,):
        raise ValueError(f"expected a 3-vector array of shape (..., 3), got {a.shape}")
    return a


def _dot3(a, b) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def _unit(a) -> np.ndarray:
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def minkowski_dot(a, b) -> np.ndarray:
    """Minkowski product of 4-vectors, signature (-, +, +, +).

    ``a·b = -a_t b_t + a_x b_x + a_y b_y + a_z b_z`` (docs/spec.md §1).
    a, b: (..., 4) in (t, x, y, z) order, broadcast; returns shape (...).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return -a[..., 0] * b[..., 0] + np.sum(a[..., 1:] * b[..., 1:], axis=-1)


def gamma(v) -> np.ndarray:
    """Lorentz factor gamma = 1 / sqrt(1 - |v|^2) (thesis Eq. 2.2, c = 1).

    v: lab velocities (..., 3) with |v| < 1; returns shape (...). |v| >= 1 gives
    inf / NaN (no rest frame exists).
    """
    v = _vec3(v)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 1.0 / np.sqrt(1.0 - _dot3(v, v))


def four_velocity(v) -> np.ndarray:
    """4-velocity u = gamma (1, v), normalised so that u·u = -1.

    It is the unit tangent of the worldline and the time axis of the body's rest
    frame (thesis §2.1). v: (..., 3), |v| < 1; returns (..., 4).
    """
    v = _vec3(v)
    g = gamma(v)[..., None]
    return np.concatenate([g, g * v], axis=-1)


def boost(v) -> np.ndarray:
    """Pure Lorentz boost ``rest_from_lab``: lab 4-vectors -> the frame moving with v.

    For a general direction (thesis §4.3 item 2c gives the x-only case with
    cosh/sinh of the rapidity arctanh(beta)):

        t' = gamma (t - v·x)
        x' = x + ((gamma - 1) / |v|^2 (v·x) - gamma t) v

    The coefficient (gamma - 1)/|v|^2 is evaluated as gamma^2 / (1 + gamma), which is
    the same number and finite at v = 0 (the identity).

    v: lab velocity of the moving frame, (..., 3), |v| < 1.
    Returns the matrices Λ of shape (..., 4, 4) acting on column 4-vectors (t, x, y, z):
    ``x_rest = Λ @ x_lab``. Applied to event coordinates it maps a lab event to the
    moving frame's coordinates with the same origin event.
    """
    v = _vec3(v)
    g = gamma(v)
    k = g * g / (1.0 + g)  # (gamma - 1) / |v|^2
    shape = v.shape[:-1] + (4, 4)
    m = np.zeros(shape, dtype=np.float64)
    m[..., 0, 0] = g
    m[..., 0, 1:] = -g[..., None] * v
    m[..., 1:, 0] = -g[..., None] * v
    m[..., 1:, 1:] = np.eye(3) + k[..., None, None] * v[..., :, None] * v[..., None, :]
    return m


#: Alias with the ``a_from_b`` naming (DESIGN.md style 1).
rest_from_lab = boost


def lab_from_rest(v) -> np.ndarray:
    """Inverse boost: 4-vectors in the frame moving with v -> lab, ``boost(-v)``.

    v: lab velocity of the moving frame (..., 3); returns (..., 4, 4).
    """
    return boost(-_vec3(v))


def _apply(m, x) -> np.ndarray:
    """Matrix (..., 4, 4) times 4-vector (..., 4), broadcast."""
    return np.einsum("...ij,...j->...i", m, x)


def aberrate(n_rest, v, *, classical: bool = False) -> np.ndarray:
    """Aberration: a moving camera's look direction in its rest frame -> lab look direction.

    n_rest: unit directions the camera LOOKS along, in the camera's rest frame, (..., 3).
    v: the camera's lab velocity (..., 3). Returns unit lab look directions (..., 3).

    Relativistic (default, docs/spec.md §3): the arriving photon has 4-momentum
    k' = (1, -n_rest) in the camera frame; k = lab_from_rest(v) k' and the lab look
    direction is -k_spatial / k_t. In terms of the angle alpha between the lab
    direction and v, and alpha' between n_rest and v, this is thesis Eq. 2.3/2.9
    (the camera sees a lab source at alpha at the apparent angle alpha'):

        cos alpha' = (cos alpha + beta) / (1 + beta cos alpha),
        tan(alpha'/2) = sqrt((1 - beta)/(1 + beta)) tan(alpha/2).

    Classical (``classical=True``, Galilean velocity addition, docs/spec.md §3 "apparent
    direction ∝ n + v", thesis Eq. 2.1 tan theta' = sin theta / (cos theta + beta)):
    the lab look direction n_lab (unit) satisfies n_lab + v ∥ n_rest, i.e.
    n_lab = lam n_rest - v with |n_lab| = 1 and lam the larger (positive) root of
    lam^2 - 2 lam (n_rest·v) + |v|^2 - 1 = 0. Directions with no such root (only
    possible for |v| >= 1) are NaN.
    """
    n_rest = _vec3(n_rest)
    v = _vec3(v)
    if classical:
        nv = _dot3(n_rest, v)
        disc = nv * nv - _dot3(v, v) + 1.0
        with np.errstate(invalid="ignore"):
            lam = nv + np.sqrt(disc)
        lam = np.where((disc >= 0.0) & (lam > 0.0), lam, np.nan)
        return lam[..., None] * n_rest - v
    k_rest = np.concatenate([np.ones(n_rest.shape[:-1] + (1,)), -n_rest], axis=-1)
    k_lab = _apply(lab_from_rest(v), k_rest)
    return -k_lab[..., 1:] / k_lab[..., :1]


def doppler(
    n_lab, v_body, v_cam=0.0, *, body_decoupled: bool = False, cam_decoupled: bool = False, light_speed: str = "finite"
) -> np.ndarray:
    """Doppler factor D = received / emitted frequency = (k·u_cam) / (k·u_body).

    Light travels from the hit event to the camera; the camera looks along the unit
    lab direction n_lab, so the photon moves along -n_lab and k = (1, -n_lab) (any
    positive scale cancels). u = gamma (1, v) for a coupled (relativistic) body or
    camera; u = (1, v) for a Lorentz-decoupled one, whose proper time is lab time
    (docs/spec.md §2), so its frequency is counted per lab time unit.

    Closed form:  D = [g_cam (1 + n·v_cam)] / [g_body (1 + n·v_body)], with g = gamma or 1.
    Examples (camera at rest): head-on approach (v_body = -beta n) gives
    sqrt((1 + beta)/(1 - beta)); transverse motion (n ⊥ v_body) gives 1/gamma.

    ``light_speed="infinite"`` (docs/spec.md §1, no light delay): the limit of a signal of speed
    w → ∞, k = (1, -n/w) → (1, 0), so D = u_cam,t / u_body,t = g_cam / g_body: only time
    dilation remains (1/gamma for a coupled body seen from a camera at rest, 1 for a
    decoupled one). This is what the proper-time channel implies: with no light delay
    a body's clock is seen to advance by 1/gamma per unit of camera time.

    n_lab: (..., 3) unit; v_body, v_cam: (..., 3) or scalar 0. Returns (...).
    A decoupled superluminal body can make 1 + n·v_body <= 0 (the light left it
    "backwards" in time order); the formula is returned as is (negative or inf).
    """
    n = _vec3(n_lab)
    vb = np.broadcast_to(np.asarray(v_body, dtype=np.float64), n.shape) if np.ndim(v_body) == 0 else _vec3(v_body)
    vc = np.broadcast_to(np.asarray(v_cam, dtype=np.float64), n.shape) if np.ndim(v_cam) == 0 else _vec3(v_cam)
    if light_speed not in ("finite", "infinite"):
        raise ValueError(f"light_speed must be 'finite' or 'infinite', not {light_speed!r}")
    k_space = -n if light_speed == "finite" else np.zeros_like(n)
    k = np.concatenate([np.ones(n.shape[:-1] + (1,)), k_space], axis=-1)

    def u(vel, decoupled):
        if decoupled:
            vel, _ = np.broadcast_arrays(vel, n)
            return np.concatenate([np.ones(vel.shape[:-1] + (1,)), vel], axis=-1)
        return four_velocity(vel)

    with np.errstate(divide="ignore", invalid="ignore"):
        return minkowski_dot(k, u(vc, cam_decoupled)) / minkowski_dot(k, u(vb, body_decoupled))


def proper_time(event, origin, t_ref, v, *, decoupled: bool = False) -> np.ndarray:
    """Proper time of a body at a lab event on it (docs/spec.md §2).

    Coupled: the time coordinate of the event in the body's rest frame whose origin
    is the event (t_ref, o):  tau = gamma ((t - t_ref) - v·(x - o))  (time dilation:
    along the body's own worldline x - o = v (t - t_ref) this is (t - t_ref)/gamma).
    Decoupled: tau = t - t_ref (a classical body's clock is lab time).

    event: lab events (..., 4); origin o: (..., 3); t_ref: scalar or (...);
    v: (..., 3). Returns (...).
    """
    e = np.asarray(event, dtype=np.float64)
    dt = e[..., 0] - np.asarray(t_ref, dtype=np.float64)
    if decoupled:
        return dt
    v = _vec3(v)
    dx = e[..., 1:] - _vec3(origin)
    return gamma(v) * (dt - _dot3(v, dx))


def contract(r, v) -> np.ndarray:
    """Lorentz contraction of rest-frame offsets along v: r - (1 - 1/gamma)(r·v̂)v̂.

    r: offsets from the pivot (..., 3); v: (..., 3), |v| < 1. The parallel part is
    divided by gamma, the perpendicular part unchanged. v = 0 is the identity.
    """
    r = _vec3(r)
    v = _vec3(v)
    g = gamma(v)
    # (1 - 1/g) / |v|^2 = ((g - 1)/|v|^2) / g = (g^2/(1 + g)) / g = g/(1 + g): finite at v = 0.
    k = g / (1.0 + g)
    return r - (k * _dot3(r, v))[..., None] * v


def uncontract(r_lab, v) -> np.ndarray:
    """Inverse of :func:`contract`: lab-simultaneous offsets -> rest-frame offsets.

    The parallel part along v is multiplied by gamma: r + (gamma - 1)(r·v̂)v̂.
    """
    r = _vec3(r_lab)
    v = _vec3(v)
    g = gamma(v)
    k = g * g / (1.0 + g)  # (gamma - 1)/|v|^2
    return r + (k * _dot3(r, v))[..., None] * v


def worldline_point(p, o, v, t, t_ref, *, decoupled: bool = False) -> np.ndarray:
    """Lab position at lab time t of the authored world-space point p (docs/spec.md §2).

    With r = p - o:
      coupled:   x(t) = o + v (t - t_ref) + r - (1 - 1/gamma)(r·v̂)v̂
                 (the authored shape is the rest shape, Lorentz contracted about o;
                 thesis §4.3 items 2c-d, the V_obj), |v| < 1;
      decoupled: x(t) = o + v (t - t_ref) + r (the H_obj: used as authored).

    p, o, v: (..., 3); t, t_ref: scalars or (...). Returns (..., 3).
    """
    p = _vec3(p)
    o = _vec3(o)
    v = _vec3(v)
    dt = np.asarray(t, dtype=np.float64) - np.asarray(t_ref, dtype=np.float64)
    r = p - o
    if not decoupled:
        r = contract(r, v)
    return o + v * dt[..., None] + r


def solve_quadratic(a, b, c):
    """Real roots of a s^2 + 2 b s + c = 0 (note the half linear coefficient), sorted.

    Numerically stable form (q = -(b + sign(b) sqrt(b^2 - a c)); roots q/a, c/q), so a
    root near zero is not lost to cancellation. a == 0 degrades to the linear root
    -c/(2b) (returned as both roots). No real root: (NaN, NaN). Arrays broadcast.
    """
    a, b, c = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (a, b, c)))
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        q = -(b + np.copysign(sq, b))
        r1 = q / a
        r2 = c / q
        lo = np.fmin(r1, r2)
        hi = np.fmax(r1, r2)
        lin = a == 0.0
        lin_root = -c / (2.0 * b)
        lo = np.where(lin, lin_root, lo)
        hi = np.where(lin, lin_root, hi)
        # q == 0 (b == 0 and disc == 0): double root at 0 when c == 0, else r1 handles it.
        both_nan = np.isnan(r1) & np.isnan(r2) & ~lin
        lo = np.where(both_nan, np.nan, np.where(np.isnan(lo), hi, lo))
        hi = np.where(both_nan, np.nan, np.where(np.isnan(hi), lo, hi))
    return lo, hi


class SphereHit(NamedTuple):
    """The first hit of each past null ray with a moving sphere (all float64, lab frame).

    s: lookback (= lab distance travelled by the light), (...), NaN on a miss.
    event_time: lab time t of the hit event, (...).
    position: lab position of the hit event, (..., 3).
    proper_time: the body's proper time at the event (docs/spec.md §2), (...).
    doppler: received / emitted frequency (see :func:`doppler`), (...).
    normal: unit outward lab-frame surface normal at fixed lab time, (..., 3).
    rest_distance: the light's path length in the body frame (rest frame for a
        coupled body, the co-moving Galilean frame for a decoupled one), (...).
    """

    s: np.ndarray
    event_time: np.ndarray
    position: np.ndarray
    proper_time: np.ndarray
    doppler: np.ndarray
    normal: np.ndarray
    rest_distance: np.ndarray


def _body_frame_ray(cam_time, cam_pos, dirs, center, v, t_ref, *, decoupled, light_speed):
    """The ray in the body frame: spatial position A + s B relative to the sphere centre.

    Coupled: the rest frame with origin event (t_ref, o); since the centre is at rest
    there, only the spatial part matters. We start from the lab-simultaneous offset
    d = c - (o + v (t_c - t_ref)) at the event (t_c, c) (its rest-frame time differs,
    but the centre's worldline is the rest-frame time axis, so the spatial part is the
    same as relative to (t_ref, o), and no large t_c - t_ref cancels).
    Decoupled: the Galilean co-moving frame x - v (t - t_ref), same thing classically.
    """
    c = _vec3(cam_pos)
    n = _vec3(dirs)
    o = _vec3(center)
    v = _vec3(v)
    dt_c = np.asarray(cam_time, dtype=np.float64) - np.asarray(t_ref, dtype=np.float64)
    d = c - (o + v * dt_c[..., None])  # lab-simultaneous offset of the camera from the centre
    step_t = -1.0 if light_speed == "finite" else 0.0
    if decoupled:
        A = d
        B = n - v * step_t  # x - v t along E(s): c + s n - v (t_c + step_t s - t_ref)
        return np.broadcast_arrays(A, B)
    lam = boost(v)
    A = _apply(lam, np.concatenate([np.zeros(d.shape[:-1] + (1,)), d], axis=-1))[..., 1:]
    step = np.concatenate([np.full(n.shape[:-1] + (1,), step_t), n], axis=-1)
    B = _apply(lam, step)[..., 1:]
    return np.broadcast_arrays(A, B)


def sphere_crossings(
    cam_time, cam_pos, dirs, center, radius, v, t_ref, *, decoupled: bool = False, light_speed: str = "finite"
):
    """Both crossings (s_enter, s_exit) of each ray's full line with the world-tube's side.

    The lookbacks where the body-frame position A + s B of the ray meets the sphere
    |x| = R (see :func:`sphere_hit`), sorted, with no s >= 0 or lifetime filter; NaN
    where the line misses. Shapes (...).
    """
    if light_speed not in ("finite", "infinite"):
        raise ValueError(f"light_speed must be 'finite' or 'infinite', not {light_speed!r}")
    A, B = _body_frame_ray(cam_time, cam_pos, dirs, center, v, t_ref, decoupled=decoupled, light_speed=light_speed)
    R = np.asarray(radius, dtype=np.float64)
    return solve_quadratic(_dot3(B, B), _dot3(A, B), _dot3(A, A) - R * R)


def sphere_hit(
    cam_time,
    cam_pos,
    dirs,
    center,
    radius,
    v,
    t_ref,
    *,
    decoupled: bool = False,
    light_speed: str = "finite",
    lifetime=(-np.inf, np.inf),
    v_cam=0.0,
    cam_decoupled: bool = False,
) -> SphereHit:
    """Closed-form first hit of past null rays with a moving sphere (docs/spec.md §1-§2).

    Rays: E(s) = (t_c - s, c + s n) (``light_speed="finite"``) or (t_c, c + s n)
    (``"infinite"``), s >= 0, n = ``dirs`` (unit, (..., 3)), c = ``cam_pos``,
    t_c = ``cam_time``.

    Sphere: authored centre ``center`` = pivot o at lab time ``t_ref``, authored
    (proper) radius R, lab velocity v.
      decoupled: the sphere translated, |x - (o + v (t - t_ref))| = R;
      coupled:   the Lorentz-contracted ellipsoid, i.e. the sphere |x'| = R in the
                 body's rest frame, x' = spatial part of rest_from_lab(v) (E - (t_ref, o))
                 (docs/spec.md §2 worldline of the authored sphere points; thesis §4.3).
    Either way the body-frame position along the ray is A + s B (affine in s), so the
    surface condition |A + s B|^2 = R^2 is a quadratic in s; the hit is the smallest
    root s >= 0 whose event time lies in ``lifetime`` = (tBegin, tEnd) (only the side
    of the world-tube is a surface; the caps are not, so a ray can enter through a
    missing cap and see the inside of the far wall). Misses are NaN.

    Normal: gradient of the body-frame sphere equation with respect to lab x at fixed
    lab t. Coupled: ∂x'/∂x = I + (gamma - 1) v̂v̂ᵀ, so n ∝ (I + (gamma - 1) v̂v̂ᵀ) x'
    (the ellipsoid's normal); decoupled: n ∝ x - o(t). Always pointing outwards.

    Doppler: :func:`doppler` with the body at v and the camera at ``v_cam``
    (0: at rest), using each one's decoupled flag and the same ``light_speed``.
    """
    if light_speed not in ("finite", "infinite"):
        raise ValueError(f"light_speed must be 'finite' or 'infinite', not {light_speed!r}")
    n = _vec3(dirs)
    v = _vec3(v)
    o = _vec3(center)
    c = _vec3(cam_pos)
    t_c = np.asarray(cam_time, dtype=np.float64)
    A, B = _body_frame_ray(t_c, c, n, o, v, t_ref, decoupled=decoupled, light_speed=light_speed)
    s0, s1 = sphere_crossings(t_c, c, n, o, radius, v, t_ref, decoupled=decoupled, light_speed=light_speed)
    qa = _dot3(B, B)
    t_lo, t_hi = float(lifetime[0]), float(lifetime[1])
    step_t = -1.0 if light_speed == "finite" else 0.0

    def ok(s):
        te = t_c + step_t * s
        return (s >= 0.0) & (te >= t_lo) & (te <= t_hi)

    s = np.where(ok(s0), s0, np.where(ok(s1), s1, np.nan))
    t_e = t_c + step_t * s
    x_e = c + s[..., None] * n
    event = np.concatenate([t_e[..., None], x_e], axis=-1)
    tau = proper_time(event, o, t_ref, v, decoupled=decoupled)
    D = doppler(n, v, v_cam, body_decoupled=decoupled, cam_decoupled=cam_decoupled, light_speed=light_speed)
    D = np.where(np.isnan(s), np.nan, D)
    xb = A + s[..., None] * B  # body-frame offset from the centre, |xb| = R
    if decoupled:
        grad = xb
    else:
        g = gamma(v)
        k = g * g / (1.0 + g)  # (gamma - 1)/|v|^2
        grad = xb + (k * _dot3(xb, v))[..., None] * v
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = _unit(grad)
    rest_distance = s * np.sqrt(qa)
    return SphereHit(s, t_e, x_e, tau, D, normal, rest_distance)


def retarded_time(point_ref, v, t_ref, cam_time, cam_pos) -> np.ndarray:
    """Lab time at which a point moving with v is seen from the camera event.

    The point's worldline is x(t) = p + v (t - t_ref) (p = ``point_ref``, its position
    at ``t_ref``); it is seen at the crossing with the camera's past lightcone,
    t_c - t = |c - x(t)| with t <= t_c (classical retarded time, thesis §2.3.1).
    With s = t_c - t and d = c - p - v (t_c - t_ref) this is
    (1 - |v|^2) s^2 - 2 (d·v) s - |d|^2 = 0; for |v| < 1 exactly one root is >= 0.
    For |v| >= 1 (decoupled, superluminal) the most recent non-negative root is
    returned, NaN when the point is never seen.

    point_ref, v, cam_pos: (..., 3); t_ref, cam_time: scalars or (...). Returns (...).
    """
    p = _vec3(point_ref)
    v = _vec3(v)
    c = _vec3(cam_pos)
    t_c = np.asarray(cam_time, dtype=np.float64)
    d = c - p - v * (t_c - np.asarray(t_ref, dtype=np.float64))[..., None]
    s0, s1 = solve_quadratic(1.0 - _dot3(v, v), -_dot3(d, v), -_dot3(d, d))
    s = np.where(s0 >= 0.0, s0, np.where(s1 >= 0.0, s1, np.nan))
    return t_c - s


def contraction_matrix(velocity: np.ndarray, decoupled: bool) -> np.ndarray:
    """A = I - (1 - 1/gamma) v^ v^T: maps proper (authored) offsets to lab offsets, (3, 3)."""
    v = np.asarray(velocity, dtype=np.float64)
    speed = float(np.linalg.norm(v))
    if decoupled or speed == 0.0:
        return np.eye(3)
    vhat = v / speed
    inv_gamma = np.sqrt(max(1.0 - speed * speed, 0.0))
    return np.eye(3) - (1.0 - inv_gamma) * np.outer(vhat, vhat)
