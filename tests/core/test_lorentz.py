"""The float64 kinematics oracle (warp_st.core.lorentz) against physics laws and the thesis.

Tolerances: the boost matrices have entries of size gamma, so products of two of them
sum terms of size gamma^2 and round to ~eps * gamma^2; the invariants below allow
64 eps gamma^2 (64 eps ≈ 1.4e-14). Closed-form angle equations are compared to 1e-12
(a few dozen ulps after trigonometric round trips). The thesis's printed numbers are
compared at the precision printed.
"""
from __future__ import annotations

import math

import independent_kinematics as IK
import numpy as np
import pytest

from warp_st.core import lorentz as L

EPS = float(np.finfo(np.float64).eps)


def random_unit(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def random_velocities(rng, n, beta_max=0.999):
    """Random directions with speeds spread over [0, beta_max] (dense near 1)."""
    beta = beta_max * (1.0 - rng.random(n) ** 3)
    return random_unit(rng, n) * beta[:, None]


@pytest.fixture
def rng():
    return np.random.default_rng(20050101)


# --------------------------------------------------------------------------- invariants


def test_boost_inverse_is_boost_of_minus_v(rng):
    """boost(v) @ boost(-v) = I: the inverse of a pure boost is the boost by -v.
    Tolerance 64 eps gamma^2 (entries ~gamma, products ~gamma^2)."""
    v = random_velocities(rng, 500)
    prod = L.boost(v) @ L.boost(-v)
    g2 = L.gamma(v) ** 2
    err = np.max(np.abs(prod - np.eye(4)), axis=(-1, -2))
    assert np.all(err <= 64 * EPS * g2)
    np.testing.assert_array_equal(L.lab_from_rest(v), L.boost(-v))
    assert L.rest_from_lab is L.boost


def test_boost_preserves_metric_and_products(rng):
    """Lorentz boosts are isometries of Minkowski space: Λᵀ η Λ = η and a'·b' = a·b.
    Tolerance 64 eps gamma^2 relative to the Euclidean sizes |a| |b|."""
    v = random_velocities(rng, 500)
    lam = L.boost(v)
    eta = np.diag([-1.0, 1.0, 1.0, 1.0])
    g2 = L.gamma(v) ** 2
    err = np.max(np.abs(np.swapaxes(lam, -1, -2) @ eta @ lam - eta), axis=(-1, -2))
    assert np.all(err <= 64 * EPS * g2)
    a = rng.normal(size=(500, 4))
    b = rng.normal(size=(500, 4))
    a2 = np.einsum("nij,nj->ni", lam, a)
    b2 = np.einsum("nij,nj->ni", lam, b)
    scale = np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1) * g2
    assert np.all(np.abs(L.minkowski_dot(a2, b2) - L.minkowski_dot(a, b)) <= 64 * EPS * scale)


def test_minkowski_dot_signature():
    """Signature (-, +, +, +) (docs/spec.md §1)."""
    assert L.minkowski_dot([1, 0, 0, 0], [1, 0, 0, 0]) == -1.0
    assert L.minkowski_dot([0, 1, 0, 0], [0, 1, 0, 0]) == 1.0
    assert L.minkowski_dot([2, 1, 2, 3], [5, 7, 11, 13]) == -10 + 7 + 22 + 39


def test_null_stays_null(rng):
    """A null vector k = (1, n) stays null under any boost: k'·k' = 0 up to
    64 eps gamma^2 (k'_t)^2 (the cancellation is between terms of size (k'_t)^2)."""
    v = random_velocities(rng, 500)
    n = random_unit(rng, 500)
    k = np.concatenate([np.ones((500, 1)), n], axis=-1)
    k2 = np.einsum("nij,nj->ni", L.boost(v), k)
    assert np.all(np.abs(L.minkowski_dot(k2, k2)) <= 64 * EPS * L.gamma(v) ** 2 * k2[:, 0] ** 2)
    assert np.all(k2[:, 0] > 0.0)  # boosts keep the future light cone (orthochronous)


def test_four_velocity(rng):
    """u = gamma (1, v): u·u = -1 (64 eps gamma^2), and boost(v) u = (1, 0, 0, 0): the
    body is at rest in its rest frame, whose time axis is u (thesis §2.1)."""
    v = random_velocities(rng, 500)
    u = L.four_velocity(v)
    g2 = L.gamma(v) ** 2
    assert np.all(np.abs(L.minkowski_dot(u, u) + 1.0) <= 64 * EPS * g2)
    rest = np.einsum("nij,nj->ni", L.boost(v), u)
    assert np.all(np.abs(rest - [1.0, 0.0, 0.0, 0.0]).max(axis=-1) <= 64 * EPS * g2)


def test_boost_along_x_matches_thesis_matrix():
    """Thesis §4.3 item 2c: along x the boost is [[cosh θ, -sinh θ], [-sinh θ, cosh θ]]
    with rapidity θ = arctanh β. Tolerance 1e-14 (entries ≤ gamma ≈ 7)."""
    for beta in (0.0, 0.3, 0.866, 0.99):
        th = math.atanh(beta)
        ref = np.eye(4)
        ref[0, 0] = ref[1, 1] = math.cosh(th)
        ref[0, 1] = ref[1, 0] = -math.sinh(th)
        np.testing.assert_allclose(L.boost([beta, 0.0, 0.0]), ref, rtol=0, atol=1e-14)


def test_zero_velocity_is_identity(rng):
    """β → 0: boost is the identity, aberration and Doppler do nothing, contraction is
    the identity, proper time is lab time. Checked at v = 0 exactly (no 0/0) and at
    |v| = 1e-9, where every effect is first order in β, so errors ≤ ~1e-9."""
    n = random_unit(rng, 100)
    np.testing.assert_array_equal(L.boost(np.zeros(3)), np.eye(4))
    np.testing.assert_allclose(L.aberrate(n, np.zeros(3)), n, rtol=0, atol=1e-15)
    np.testing.assert_allclose(L.aberrate(n, np.zeros(3), classical=True), n, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(L.doppler(n, np.zeros(3)), 1.0)
    tiny = 1e-9 * random_unit(rng, 1)[0]
    np.testing.assert_allclose(L.aberrate(n, tiny), n, rtol=0, atol=3e-9)
    np.testing.assert_allclose(L.doppler(n, tiny), 1.0, rtol=0, atol=3e-9)
    r = rng.normal(size=(100, 3))
    np.testing.assert_allclose(L.contract(r, tiny), r, rtol=0, atol=1e-15 * 10)
    assert float(L.gamma(np.zeros(3))) == 1.0


# --------------------------------------------------------------------------- aberration


def _angle(a, b):
    return np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))


def test_aberration_is_the_boost_of_the_photon(rng):
    """Relativistic aberration = boosting the photon's null 4-momentum: k' = (1, -n_rest)
    in the camera frame, and boost(v) applied to the lab photon (k_t, -k_t n_lab) gives
    back a multiple of k'. Also the round trip aberrate(aberrate(n, v), -v) = n.
    Tolerance 1e-12 (gamma up to ~22 amplifies rounding to ~1e-13)."""
    v = random_velocities(rng, 400)
    n_rest = random_unit(rng, 400)
    n_lab = L.aberrate(n_rest, v)
    np.testing.assert_allclose(np.linalg.norm(n_lab, axis=-1), 1.0, rtol=0, atol=1e-13)
    k_lab = np.concatenate([np.ones((400, 1)), -n_lab], axis=-1)
    k_rest = np.einsum("nij,nj->ni", L.boost(v), k_lab)
    np.testing.assert_allclose(-k_rest[:, 1:] / k_rest[:, :1], n_rest, rtol=0, atol=1e-12)
    np.testing.assert_allclose(L.aberrate(n_lab, -v), n_rest, rtol=0, atol=1e-12)
    # the lab direction stays in the plane of n_rest and v
    normal = np.cross(n_rest, v)
    assert np.all(np.abs(np.sum(normal * n_lab, axis=-1)) <= 1e-12 * (1 + np.linalg.norm(normal, axis=-1)))


def test_relativistic_aberration_thesis_equations(rng):
    """Thesis Eqs. 2.3, 2.4, 2.9 and 2.10, with α the lab angle of the source from the
    direction of motion and α' its apparent angle seen by the moving camera:
      cos α' = (cos α + β)/(1 + β cos α),  sin α' = sin α / (γ (1 + β cos α)),
      tan(α'/2) = sqrt((1-β)/(1+β)) tan(α/2) = tan(α/2) / (γ (1+β)).
    `aberrate` maps the apparent (rest-frame) direction to the lab one, so we feed it
    n_rest at α' and measure α. Tolerance 1e-12 on cosines and tangents."""
    beta = rng.uniform(0.0, 0.995, 300)
    a_rest = rng.uniform(0.01, math.pi - 0.01, 300)
    v = np.stack([beta, 0 * beta, 0 * beta], axis=-1)
    n_rest = np.stack([np.cos(a_rest), np.sin(a_rest), 0 * beta], axis=-1)
    n_lab = L.aberrate(n_rest, v)
    a_lab = np.arctan2(n_lab[:, 1], n_lab[:, 0])
    g = 1.0 / np.sqrt(1.0 - beta**2)
    np.testing.assert_allclose(np.cos(a_rest), (np.cos(a_lab) + beta) / (1 + beta * np.cos(a_lab)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.sin(a_rest), np.sin(a_lab) / (g * (1 + beta * np.cos(a_lab))), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.tan(a_rest / 2), np.sqrt((1 - beta) / (1 + beta)) * np.tan(a_lab / 2), rtol=1e-11)
    np.testing.assert_allclose(np.tan(a_rest / 2), np.tan(a_lab / 2) / (g * (1 + beta)), rtol=1e-11)  # Eq. 2.10
    # monotone: the apparent angle is smaller than the lab angle (sources move forward)
    assert np.all(a_rest <= a_lab + 1e-12)


def test_classical_aberration_thesis_equation(rng):
    """Thesis Eq. 2.1 (Galilean, docs/spec.md §3 "apparent direction ∝ n + v"):
    tan θ' = sin θ/(cos θ + β), θ the lab angle, θ' the apparent angle. Also the
    defining relation n_lab + v ∥ n_rest with |n_lab| = 1, and Eq. 2.8
    tan α' = tan θ' / γ linking it to the relativistic angle. Tolerance 1e-12."""
    beta = rng.uniform(0.0, 0.99, 300)
    th_lab = rng.uniform(0.01, math.pi - 0.01, 300)
    v = np.stack([beta, 0 * beta, 0 * beta], axis=-1)
    n_lab = np.stack([np.cos(th_lab), np.sin(th_lab), 0 * beta], axis=-1)
    n_rest = (n_lab + v) / np.linalg.norm(n_lab + v, axis=-1, keepdims=True)
    np.testing.assert_allclose(L.aberrate(n_rest, v, classical=True), n_lab, rtol=0, atol=1e-12)
    th_app = np.arctan2(n_rest[:, 1], n_rest[:, 0])
    np.testing.assert_allclose(np.tan(th_app), np.sin(th_lab) / (np.cos(th_lab) + beta), rtol=1e-10)
    # Eq. 2.8: the relativistic apparent angle of the same lab source
    a_app = _angle(L.aberrate(n_lab, -v), np.array([1.0, 0.0, 0.0]))
    g = 1.0 / np.sqrt(1.0 - beta**2)
    np.testing.assert_allclose(np.tan(a_app), np.tan(th_app) / g, rtol=1e-9)
    # superluminal classical camera: directions with no forward solution are NaN
    fast = L.aberrate(np.array([[-1.0, 0.0, 0.0]]), np.array([2.0, 0.0, 0.0]), classical=True)
    assert np.all(np.isnan(fast))


def _apparent(n_lab, v, classical):
    """Apparent (camera rest frame) look direction of a lab direction (inverse of aberrate)."""
    if classical:
        w = n_lab + v
        return w / np.linalg.norm(w)
    return L.aberrate(n_lab, -v)


@pytest.mark.parametrize("classical, shift_deg", [(True, 26.565), (False, 30.0)])
def test_thesis_star_shift_at_half_c(classical, shift_deg):
    """Thesis §4.4.3 / §4.4.4 (Figs. 4.11, 4.12): at β = 0.5 a star seen perpendicular
    to the direction of motion in the lab (θ = 90°) migrates towards the front by
    arctan(5/10) = 26.565° classically (Eq. 2.1: tan θ' = 1/β → θ' = 63.435°) and by
    arctan(5.77/10) = 30.0° relativistically (Eq. 2.3: cos α' = β → α' = 60°).
    The thesis prints 3 decimals (classical) and 1 (relativistic); we compare there."""
    v = np.array([0.5, 0.0, 0.0])
    n_lab = np.array([0.0, 1.0, 0.0])
    app = _apparent(n_lab, v, classical)
    shift = 90.0 - math.degrees(_angle(app, v / 0.5))
    digits = 3 if classical else 1
    assert round(shift, digits) == shift_deg
    np.testing.assert_allclose(L.aberrate(app, v, classical=classical), n_lab, rtol=0, atol=1e-15)
    # the thesis's grid reading: the edge moved tan(shift) * 10 grid marks at distance 10
    assert round(10 * math.tan(math.radians(shift)), 2) == (5.00 if classical else 5.77)


def test_thesis_866_edge_numbers_are_the_classical_law():
    """Thesis §4.4.4 (Fig. 4.13) says that at 0.866c the cube's edge moves from 153.4°
    to 93.6° from the direction of motion. Those two numbers satisfy the CLASSICAL
    law Eq. 2.1 (tan θ' = sin θ/(cos θ + β) with θ = 180° - arctan(1/2) = 153.435°
    gives θ' = 93.63°), while the relativistic Eq. 2.3 gives 97.2°. We record both:
    the oracle follows the equations, not the figure caption (0.05° = printed digits)."""
    th = 180.0 - math.degrees(math.atan(0.5))
    assert round(th, 1) == 153.4
    v = np.array([0.866, 0.0, 0.0])
    n_lab = np.array([math.cos(math.radians(th)), math.sin(math.radians(th)), 0.0])
    cl = math.degrees(_angle(_apparent(n_lab, v, True), np.array([1.0, 0.0, 0.0])))
    rel = math.degrees(_angle(_apparent(n_lab, v, False), np.array([1.0, 0.0, 0.0])))
    assert abs(cl - 93.6) < 0.05
    assert abs(rel - 97.2) < 0.05


# --------------------------------------------------------------------------- Doppler


@pytest.mark.parametrize("beta", [0.1, 0.5, 0.9, 0.99])
def test_doppler_textbook_cases(beta):
    """D = (k·u_cam)/(k·u_body), k = (1, -n): head-on approach sqrt((1+β)/(1-β)),
    recession sqrt((1-β)/(1+β)), transverse in the lab frame 1/γ (pure time dilation),
    camera approaching a source at rest = source approaching the camera (only the
    relative velocity matters on the line of sight). Tolerance 1e-13 relative."""
    n = np.array([0.0, 0.0, -1.0])  # camera looks down -z at the body
    g = 1.0 / math.sqrt(1 - beta * beta)
    approach = math.sqrt((1 + beta) / (1 - beta))
    np.testing.assert_allclose(L.doppler(n, -beta * n), approach, rtol=1e-13)
    np.testing.assert_allclose(L.doppler(n, beta * n), 1.0 / approach, rtol=1e-13)
    np.testing.assert_allclose(L.doppler(n, np.array([beta, 0.0, 0.0])), 1.0 / g, rtol=1e-13)
    np.testing.assert_allclose(L.doppler(n, np.zeros(3), beta * n), approach, rtol=1e-13)
    np.testing.assert_allclose(L.doppler(n, -0.3 * n, beta * n), L.doppler(n, -0.3 * n) * approach, rtol=1e-13)
    # decoupled body: classical clock, D = 1/(1 + n·v)
    np.testing.assert_allclose(L.doppler(n, -beta * n, body_decoupled=True), 1.0 / (1 - beta), rtol=1e-13)
    np.testing.assert_allclose(L.doppler(n, np.array([beta, 0, 0]), body_decoupled=True), 1.0, rtol=1e-13)


def test_doppler_infinite_light_speed_is_time_dilation(rng):
    """With no light delay (docs/spec.md §1 ``infinite``) the Doppler factor is the w → ∞ limit
    of a signal of speed w, k = (1, -n/w): D = γ_cam/γ_body for any direction (pure
    time dilation), 1 for a decoupled body seen from a camera at rest. The finite-c
    formula with k = (1, -n/w) approaches it as w grows (checked at w = 1e8: 1e-7)."""
    v = random_velocities(rng, 200, 0.99)
    n = random_unit(rng, 200)
    g = L.gamma(v)
    np.testing.assert_allclose(L.doppler(n, v, light_speed="infinite"), 1.0 / g, rtol=1e-14)
    np.testing.assert_allclose(L.doppler(n, v, body_decoupled=True, light_speed="infinite"), 1.0, rtol=0)
    vc = random_velocities(rng, 200, 0.9)
    np.testing.assert_allclose(L.doppler(n, v, vc, light_speed="infinite"), L.gamma(vc) / g, rtol=1e-14)
    w = 1e8
    k = np.concatenate([np.ones((200, 1)), -n / w], axis=-1)
    lim = L.minkowski_dot(k, L.four_velocity(vc)) / L.minkowski_dot(k, L.four_velocity(v))
    np.testing.assert_allclose(L.doppler(n, v, vc, light_speed="infinite"), lim, rtol=1e-7)
    with pytest.raises(ValueError):
        L.doppler(n, v, light_speed="warp")


def test_doppler_is_frame_independent(rng):
    """D is a ratio of Lorentz scalars: computing it in the camera's rest frame
    (aberrated direction, relativistically subtracted body velocity, camera at rest)
    gives the same number. It also chains through any intermediate observer:
    D(cam←body) = D(cam←lab) D(lab←body). Tolerance 1e-10 relative (γ up to ~22,
    and 1 + n·v can be ~1e-3, amplifying rounding by ~1e3)."""
    N = 300
    vb = random_velocities(rng, N, 0.99)
    vc = random_velocities(rng, N, 0.99)
    n = random_unit(rng, N)
    D = L.doppler(n, vb, vc)
    lam = L.boost(vc)
    ub = np.einsum("nij,nj->ni", lam, L.four_velocity(vb))
    vb_cam = ub[:, 1:] / ub[:, :1]
    n_cam = L.aberrate(n, -vc)
    np.testing.assert_allclose(L.doppler(n_cam, vb_cam), D, rtol=1e-10)
    np.testing.assert_allclose(L.doppler(n, np.zeros(3), vc) * L.doppler(n, vb), D, rtol=1e-12)


# --------------------------------------------------------------------------- proper time, worldlines


def test_proper_time_laws(rng):
    """docs/spec.md §2: tau = γ((t - t_ref) - v·(x - o)) is the rest-frame time of the event
    relative to (t_ref, o): equals boost(v)(E - (t_ref, o))[0]; along the body's own
    worldline it is (t - t_ref)/γ (time dilation); decoupled tau = t - t_ref.
    Tolerance 1e-12 relative to γ (|t|, |x| ≤ ~10)."""
    v = random_velocities(rng, 200)
    o = rng.normal(size=(200, 3))
    t_ref = rng.normal(size=200)
    ev = np.concatenate([rng.normal(size=(200, 1)) * 5, rng.normal(size=(200, 3)) * 5], axis=-1)
    tau = L.proper_time(ev, o, t_ref, v)
    rel = np.concatenate([(ev[:, 0] - t_ref)[:, None], ev[:, 1:] - o], axis=-1)
    ref = np.einsum("nij,nj->ni", L.boost(v), rel)[:, 0]
    g = L.gamma(v)
    assert np.all(np.abs(tau - ref) <= 1e-12 * g * 10)
    t = rng.normal(size=200) * 10
    on_line = np.concatenate([t[:, None], o + v * (t - t_ref)[:, None]], axis=-1)
    np.testing.assert_allclose(L.proper_time(on_line, o, t_ref, v), (t - t_ref) / g, rtol=0, atol=1e-12 * 20)
    np.testing.assert_allclose(L.proper_time(ev, o, t_ref, v, decoupled=True), ev[:, 0] - t_ref, rtol=0, atol=0)


def test_worldline_point_is_rigid_in_the_rest_frame(rng):
    """docs/spec.md §2 coupled worldline: x(t) = o + v(t - t_ref) + r - (1 - 1/γ)(r·v̂)v̂.
    Its rest-frame spatial coordinates (boost(v) of (t, x(t)) - (t_ref, o)) are the
    authored offset r at every t: the authored shape is the proper shape. Decoupled:
    a plain translation. Both move with dx/dt = v. Tolerance 1e-12 γ (|r|, |t| ≤ ~20)."""
    v = random_velocities(rng, 200)
    o = rng.normal(size=(200, 3))
    p = o + rng.normal(size=(200, 3))
    t_ref = rng.normal(size=200)
    t = rng.normal(size=200) * 10
    x = L.worldline_point(p, o, v, t, t_ref)
    ev = np.concatenate([(t - t_ref)[:, None], x - o], axis=-1)
    rest = np.einsum("nij,nj->ni", L.boost(v), ev)
    g = L.gamma(v)
    assert np.all(np.abs(rest[:, 1:] - (p - o)).max(axis=-1) <= 1e-12 * 20 * g)
    # at t_ref the parallel extent is divided by gamma
    x0 = L.worldline_point(p, o, v, t_ref, t_ref)
    vh = v / np.linalg.norm(v, axis=-1, keepdims=True)
    par0 = np.sum((x0 - o) * vh, axis=-1)
    np.testing.assert_allclose(par0 * g, np.sum((p - o) * vh, axis=-1), rtol=0, atol=1e-12 * 20)
    np.testing.assert_allclose(L.uncontract(L.contract(p - o, v), v), p - o, rtol=0, atol=1e-12 * 20)
    xd = L.worldline_point(p, o, v, t, t_ref, decoupled=True)
    np.testing.assert_allclose(xd, p + v * (t - t_ref)[:, None], rtol=0, atol=1e-13 * 20)
    x1 = L.worldline_point(p, o, v, t + 1.0, t_ref)
    np.testing.assert_allclose(x1 - x, v, rtol=0, atol=1e-12 * 20)


def test_retarded_time(rng):
    """Retarded time (thesis §2.3.1): the returned t satisfies t_c - t = |c - x(t)|,
    t ≤ t_c, with x(t) = p + v (t - t_ref); for |v| < 1 the root is unique.
    Superluminal (decoupled) points: the most recent root, or NaN if never seen.
    Tolerance 1e-11 relative to the distances (~10)."""
    v = random_velocities(rng, 300)
    p = rng.normal(size=(300, 3)) * 10
    c = rng.normal(size=(300, 3))
    t_ref = rng.normal(size=300) * 5
    t_c = rng.normal(size=300) * 5
    t = L.retarded_time(p, v, t_ref, t_c, c)
    x = p + v * (t - t_ref)[:, None]
    assert np.all(t <= t_c)
    np.testing.assert_allclose(t_c - t, np.linalg.norm(c - x, axis=-1), rtol=0, atol=1e-11 * 10)
    # superluminal: a point at z = -10 at t = 0 moving at 2c towards a camera at the
    # origin, seen at t_c = 20: its light arrives from t = -10 (z = -30) and from
    # t = 10 (z = +10, it has passed the camera); the most recent is t = 10.
    ts = L.retarded_time(np.array([0.0, 0.0, -10.0]), np.array([0.0, 0.0, 2.0]), 0.0, 20.0, np.zeros(3))
    assert abs(float(ts) - 10.0) < 1e-12
    # at t_c = 0 it has not been seen yet (it outruns its own light): NaN
    assert np.isnan(L.retarded_time(np.array([0.0, 0.0, -10.0]), np.array([0.0, 0.0, 2.0]), 0.0, 0.0, np.zeros(3)))
    # passing at 2c at distance 10 (closest at t = 0): -t = sqrt(4 t^2 + 100) has no root
    never = L.retarded_time(np.array([0.0, 10.0, 0.0]), np.array([2.0, 0.0, 0.0]), 0.0, 0.0, np.zeros(3))
    assert np.isnan(never)


# --------------------------------------------------------------------------- sphere_hit vs brute force


def _implicit(t, x, center, v, t_ref, R, decoupled):
    """docs/spec.md §2 surface test written from the worldline, not from the boost: the lab
    event (t, x) is on the body iff the authored point p = o + r it came from lies on
    the authored sphere. Inverting x = worldline_point(p, o, v, t, t_ref): r is the
    lab-simultaneous offset from o + v(t - t_ref), un-contracted (parallel part × γ)."""
    off = x - (center + v * (t - t_ref)[..., None])
    if not decoupled:
        off = L.uncontract(off, v)
    return np.sum(off * off, axis=-1) - R * R, off


def _brute_force(case, dirs, n_samples=40000, s_max=200.0):
    """First sign change of the implicit function along each ray, refined by bisection
    to full float64 precision; lifetimes drop crossings outside (tBegin, tEnd)."""
    t_c, cam, center, R, v, t_ref, dec, ls, life = case
    step_t = -1.0 if ls == "finite" else 0.0
    s = np.linspace(0.0, s_max, n_samples)
    out = np.full(len(dirs), np.nan)
    ds = s[1] - s[0]
    for k, n in enumerate(dirs):
        x = cam + s[:, None] * n
        t = t_c + step_t * s
        f, _ = _implicit(t, x, center, v, t_ref, R, dec)
        idx = np.nonzero(np.sign(f[:-1]) != np.sign(f[1:]))[0]
        for i in idx:
            lo, hi = s[i], s[i + 1]
            flo = f[i]
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                fm, _ = _implicit(np.array(t_c + step_t * mid), cam + mid * n, center, v, t_ref, R, dec)
                if np.sign(fm) == np.sign(flo):
                    lo, flo = mid, fm
                else:
                    hi = mid
            root = 0.5 * (lo + hi)
            te = t_c + step_t * root
            if life[0] <= te <= life[1]:
                out[k] = root
                break
    return out, ds


CASES = {
    # name: (t_c, cam, centre o, R, v, t_ref, decoupled, light speed, lifetime)
    "rest": (0.0, np.zeros(3), np.array([0.0, 0.0, -5.0]), 1.0, np.zeros(3), 0.0, False, "finite", (-np.inf, np.inf)),
    "coupled_x_0.9": (3.0, np.array([0.1, 0.2, 0.0]), np.array([-2.0, 0.0, -6.0]), 1.5, np.array([0.9, 0, 0]), 0.0, False, "finite", (-np.inf, np.inf)),
    "coupled_diag_0.99": (10.0, np.zeros(3), np.array([-3.0, -2.0, 2.0]), 1.0, 0.99 * np.array([1.0, 0.5, -1.0]) / 1.5, 0.0, False, "finite", (-np.inf, np.inf)),
    "coupled_towards_0.95": (7.0, np.zeros(3), np.array([0.0, 0.0, -12.0]), 1.0, np.array([0, 0, 0.95]), 0.0, False, "finite", (-np.inf, np.inf)),
    "coupled_away_0.95": (9.0, np.zeros(3), np.array([0.0, 0.0, -2.0]), 1.0, np.array([0, 0, -0.95]), 0.0, False, "finite", (-np.inf, np.inf)),
    "coupled_large_time": (1.0e5 + 6.0, np.zeros(3), np.array([0.0, 0.0, -6.0]), 1.0, np.array([0.6, 0.3, 0]), 1.0e5, False, "finite", (-np.inf, np.inf)),
    "coupled_infinite_c": (2.0, np.zeros(3), np.array([-1.0, 0.0, -5.0]), 1.0, np.array([0.9, 0, 0]), 0.0, False, "infinite", (-np.inf, np.inf)),
    "decoupled_0.9": (3.0, np.zeros(3), np.array([-2.0, 0.0, -6.0]), 1.0, np.array([0.9, 0, 0]), 0.0, True, "finite", (-np.inf, np.inf)),
    "decoupled_superluminal_1.5": (8.0, np.zeros(3), np.array([-3.0, 0.5, -6.0]), 1.0, np.array([1.5, 0, 0.3]), 0.0, True, "finite", (-np.inf, np.inf)),
    "decoupled_infinite_c": (2.0, np.zeros(3), np.array([-1.0, 0.0, -5.0]), 1.0, np.array([1.5, 0, 0]), 0.0, True, "infinite", (-np.inf, np.inf)),
    "coupled_lifetime": (3.0, np.zeros(3), np.array([-2.0, 0.0, -6.0]), 1.5, np.array([0.9, 0, 0]), 0.0, False, "finite", (-8.2, -7.75)),
    "camera_inside": (0.0, np.zeros(3), np.array([0.2, 0.0, -0.3]), 2.0, np.array([0.5, 0.0, 0.0]), 0.0, False, "finite", (-np.inf, np.inf)),
}


def _aim_dirs(case, rng, n_hit=100, n_miss=50):
    """Test rays: candidates in a cone around the retarded image of the centre plus the
    whole sky; keep n_hit the closed form calls hits and n_miss it calls misses (nearest
    to the hits first). The brute force then judges every one of them independently."""
    from analytic_scenes import fibonacci_sphere

    t_c, cam, center, R, v, t_ref, dec, ls, life = case
    t_seen = L.retarded_time(center, v, t_ref, t_c, cam) if ls == "finite" else t_c
    if np.isnan(t_seen):
        t_seen = t_c
    aim = center + v * (t_seen - t_ref) - cam
    dist = np.linalg.norm(aim)
    cands = [fibonacci_sphere(20000)]
    if dist > 1e-9:
        d = aim / dist + 2.0 * (R / dist) * rng.normal(size=(4000, 3))
        cands.append(d / np.linalg.norm(d, axis=-1, keepdims=True))
    cand = np.concatenate(cands)
    hit = np.isfinite(L.sphere_hit(t_c, cam, cand, center, R, v, t_ref, decoupled=dec, light_speed=ls, lifetime=life).s)
    hits = cand[hit]
    misses = cand[~hit]
    hits = hits[rng.permutation(len(hits))[:n_hit]]
    if len(hits):
        near = np.max(misses @ hits.T, axis=1)  # cosine to the nearest chosen hit
        misses = misses[np.argsort(-near)[: 4 * n_miss]]
    misses = misses[rng.permutation(len(misses))[:n_miss]]
    return np.concatenate([hits, misses])


@pytest.mark.parametrize("name", list(CASES))
def test_sphere_hit_matches_brute_force(name, rng):
    """sphere_hit (closed-form quadratic in the lookback s, via the boost) agrees with a
    brute-force march along E(s) that tests the docs/spec.md §2 worldline of the authored
    sphere directly (sampling Δs = 0.005 over s in [0, 200], then bisection).
    Law: the first event on the past null ray lying on the world-tube's side, with
    event time in the lifetime. Tolerance: |Δs| ≤ 1e-9 max(s, 1) (bisection is exact to
    an ulp; the quadratic's root loses ≤ ~1e-12 even at γ = 7). Hit/miss must agree
    except for grazing rays whose two crossings lie within 2 samples of each other,
    which a march cannot resolve. Also: event = E(s), the hit satisfies
    worldline_point(p) = x for an authored point p with |p - o| = R, and the normal is
    the lab gradient of the implicit function at fixed t (finite differences, 1e-6)."""
    case = CASES[name]
    t_c, cam, center, R, v, t_ref, dec, ls, life = case
    dirs = _aim_dirs(case, rng)
    h = L.sphere_hit(t_c, cam, dirs, center, R, v, t_ref, decoupled=dec, light_speed=ls, lifetime=life)
    bf, ds = _brute_force(case, dirs)
    # grazing rays: both roots within 2 march samples
    A, B = L._body_frame_ray(t_c, cam, dirs, center, v, t_ref, decoupled=dec, light_speed=ls)
    s0, s1 = L.solve_quadratic(np.sum(B * B, -1), np.sum(A * B, -1), np.sum(A * A, -1) - R * R)
    grazing = np.isfinite(s0) & (np.abs(s1 - s0) < 2 * ds)
    both = np.isfinite(h.s) & np.isfinite(bf)
    assert np.array_equal(np.isfinite(h.s)[~grazing], np.isfinite(bf)[~grazing]), name
    assert both.sum() >= 20, f"{name}: too few hits to test ({both.sum()})"
    assert (~np.isfinite(h.s)).sum() >= 5 or name == "camera_inside", f"{name}: too few misses"
    assert np.all(np.abs(h.s[both] - bf[both]) <= 1e-9 * np.maximum(bf[both], 1.0)), (
        name, np.max(np.abs(h.s[both] - bf[both])))
    # event and fields
    step_t = -1.0 if ls == "finite" else 0.0
    sel = np.isfinite(h.s)
    np.testing.assert_allclose(h.event_time[sel], t_c + step_t * h.s[sel], rtol=0, atol=1e-12 * max(1, abs(t_c)))
    np.testing.assert_allclose(h.position[sel], cam + h.s[sel, None] * dirs[sel], rtol=0, atol=1e-12 * 100)
    f, off = _implicit(h.event_time[sel], h.position[sel], center, v, t_ref, R, dec)
    p = center + off  # the authored point seen at the hit
    np.testing.assert_allclose(np.linalg.norm(off, axis=-1), R, rtol=1e-10)
    np.testing.assert_allclose(L.worldline_point(p, center, v, h.event_time[sel], t_ref, decoupled=dec),
                               h.position[sel], rtol=0, atol=1e-10 * max(1, abs(t_c)))
    # proper time and Doppler derived another way (tests/independent_kinematics.py): the
    # rest-frame time of the hit event under exp(-φK), and k·u products with k read off the
    # light's path from the hit event to the camera event. Tolerances: 64 eps γ² of the
    # sizes involved (|t - t_ref| + |x - o| for τ; for D the condition number
    # (1 + |v|)/|1 + n·v| of k·u_body, whose two terms cancel for fast approaching bodies,
    # times 1 + |t_c|/s: k is a difference of events of size |t_c|, its length is s).
    ev = np.concatenate([h.event_time[sel, None], h.position[sel]], axis=-1)
    g2 = 1.0 if dec else float(L.gamma(v)) ** 2
    size = np.abs(ev[:, 0] - t_ref) + np.linalg.norm(ev[:, 1:] - center, axis=-1)
    tau = IK.proper_time(ev, center, t_ref, v, decoupled=dec)
    assert np.all(np.abs(h.proper_time[sel] - tau) <= 64 * EPS * g2 * size), (name, np.max(np.abs(h.proper_time[sel] - tau)))
    cam_event = np.concatenate([[t_c], cam])
    d = IK.doppler(ev, cam_event, IK.four_velocity(v, decoupled=dec), IK.four_velocity(np.zeros(3)), light_speed=ls)
    cond = (1.0 + np.linalg.norm(v)) / np.abs(1.0 + dirs[sel] @ v) * (1.0 + abs(t_c) / h.s[sel]) if ls == "finite" else 1.0
    assert np.all(np.abs(h.doppler[sel] - d) <= 64 * EPS * g2 * cond * np.abs(d)), (name, np.max(np.abs(h.doppler[sel] / d - 1)))
    assert np.all(np.isnan(h.doppler[~sel])) and np.all(np.isnan(h.event_time[~sel]))
    # normal = lab gradient of the implicit function at fixed lab t (central differences)
    eps = 1e-6
    grad = np.zeros((sel.sum(), 3))
    for k in range(3):
        dx = np.zeros(3)
        dx[k] = eps
        fp, _ = _implicit(h.event_time[sel], h.position[sel] + dx, center, v, t_ref, R, dec)
        fm, _ = _implicit(h.event_time[sel], h.position[sel] - dx, center, v, t_ref, R, dec)
        grad[:, k] = (fp - fm) / (2 * eps)
    grad /= np.linalg.norm(grad, axis=-1, keepdims=True)
    np.testing.assert_allclose(h.normal[sel], grad, rtol=0, atol=1e-6 * max(1.0, abs(t_c) * 1e-4))


def test_sphere_hit_lifetime_sees_inside_through_missing_cap():
    """Caps are not surfaces (docs/spec.md §2 lifetime): a ray whose first crossing of the
    world-tube's side is before tBegin but whose second is inside the lifetime sees the
    far wall from inside. Closed form: a sphere at rest at distance 5 on the axis,
    radius 1, camera at t = 0: crossings at s = 4 (t = -4) and s = 6 (t = -6); with
    lifetime (-7, -5) only the far wall exists → s = 6 exactly."""
    n = np.array([[0.0, 0.0, -1.0]])
    c = np.array([0.0, 0.0, -5.0])
    h = L.sphere_hit(0.0, np.zeros(3), n, c, 1.0, np.zeros(3), 0.0)
    assert h.s[0] == 4.0
    h = L.sphere_hit(0.0, np.zeros(3), n, c, 1.0, np.zeros(3), 0.0, lifetime=(-7.0, -5.0))
    assert h.s[0] == 6.0 and np.allclose(h.normal[0], [0, 0, -1])
    h = L.sphere_hit(0.0, np.zeros(3), n, c, 1.0, np.zeros(3), 0.0, lifetime=(-3.0, 0.0))
    assert np.isnan(h.s[0])


def test_sphere_hit_moving_closed_forms():
    """Hand-solvable cases, tolerance 1e-12 (a few ulps of the distances ~6).
    (a) Coupled sphere approaching head-on at β along the view axis, centre seen at
    distance D (t_ref = t_c - D): the first hit is the nose, the authored point
    o + (0, 0, R), contracted to R/γ ahead of the centre. Its worldline is
    z(t) = -D + R/γ + β (t - t_ref) and it is seen when -z = t_c - t = s:
    D - R/γ - β (D - s) = s  →  s = D - R/(γ (1 - β)).
    (b) Decoupled sphere moving transversally (x) at β, same timing: the centre ray
    (0, 0, -s) is at offset (-β (D - s), 0, D - s) from the centre at t = t_c - s, so
    (D - s) sqrt(1 + β²) = R.
    """
    beta, D, R = 0.8, 6.0, 1.0
    g = 1.0 / math.sqrt(1 - beta * beta)
    t_c = 6.0
    o = np.array([0.0, 0.0, -D])
    v = np.array([0.0, 0.0, beta])  # towards the camera at the origin
    h = L.sphere_hit(t_c, np.zeros(3), np.array([[0.0, 0.0, -1.0]]), o, R, v, t_c - D)
    # nose: authored point o + (0, 0, R); lab position at t: -D + R/g + beta (t - (t_c - D))
    # seen when -z = t_c - t: D - R/g - beta (t - t_c + D) = t_c - t  → with s = t_c - t:
    # D - R/g - beta (D - s) = s → s (1 - beta) = D (1 - beta) - R/g → s = D - R/(g (1 - beta))
    s_nose = D - R / (g * (1 - beta))
    assert abs(h.s[0] - s_nose) < 1e-12
    x_nose = L.worldline_point(o + [0, 0, R], o, v, t_c - s_nose, t_c - D)
    assert abs(x_nose[2] + s_nose) < 1e-12
    # decoupled, transverse: centre ray
    v = np.array([beta, 0.0, 0.0])
    h = L.sphere_hit(t_c, np.zeros(3), np.array([[0.0, 0.0, -1.0]]), o, R, v, t_c - D, decoupled=True)
    # offset from the centre at lookback s: (-beta (D - s)... ) : x = (0, 0, -s), centre = (beta (t - t_ref), 0, -D)
    # with t - t_ref = D - s: |( -beta (D - s), 0, D - s)| = R → (D - s) sqrt(1 + beta^2) = R
    s_ref = D - R / math.sqrt(1 + beta * beta)
    assert abs(h.s[0] - s_ref) < 1e-12


def test_penrose_terrell_outline_is_a_circle_in_the_oracle():
    """Penrose-Terrell (thesis §2.3.4, §3.1.1): the outline of a coupled sphere is a
    circle on the sky for any velocity — the set of outline directions is a circular
    cone, the aberration of the rest-frame tangent cone. We bisect the hit/miss edge
    along 360 azimuths to 1e-15 rad and fit a cone: the spread of angle(axis, d) must
    be at round-off level (≤ 1e-10 rad) and equal the predicted cone; the decoupled
    sphere at the same β is not circular (spread > 0.01 rad ~ 5% of its size)."""
    from analytic_scenes import fit_cone, predicted_outline_cone

    v = np.array([0.9, 0.0, 0.0])
    c = np.array([0.0, 0.0, -5.0])
    R, t_ref = 1.0, -5.0
    spreads = {}
    t_seen = L.retarded_time(c, v, t_ref, 0.0, np.zeros(3))
    m = (c + v * (t_seen - t_ref)) / np.linalg.norm(c + v * (t_seen - t_ref))  # retarded centre
    for dec in (False, True):
        e1 = np.cross(m, [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(m, e1)
        phis = np.linspace(0, 2 * np.pi, 360, endpoint=False)
        lo, hi = np.zeros(360), np.full(360, 1.0)

        def rays(th):
            return (np.cos(th)[:, None] * m
                    + np.sin(th)[:, None] * (np.cos(phis)[:, None] * e1 + np.sin(phis)[:, None] * e2))

        assert np.all(np.isfinite(L.sphere_hit(0.0, np.zeros(3), rays(lo), c, R, v, t_ref, decoupled=dec).s))
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            hit = np.isfinite(L.sphere_hit(0.0, np.zeros(3), rays(mid), c, R, v, t_ref, decoupled=dec).s)
            lo, hi = np.where(hit, mid, lo), np.where(hit, hi, mid)
        a, rho, res = fit_cone(rays(lo))
        spreads[dec] = np.ptp(res)
        if not dec:
            axis, half = predicted_outline_cone(c, R, v, t_ref, 0.0, np.zeros(3))
            assert abs(rho - half) < 1e-10 and np.linalg.norm(a - axis) < 1e-10
    assert spreads[False] < 1e-10
    assert spreads[True] > 0.01
