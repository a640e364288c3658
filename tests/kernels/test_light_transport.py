"""Light transport: mirrors at rest and in motion, retarded shadows, 4D sampling, depth bound.

Every scene is built from the host dataclasses (no USD) so each law is isolated, and every
expectation comes from an oracle written here, independent of the kernels: unfolded
straight-line geometry for mirrors at rest, Einstein's 1905 moving-mirror law and a float64
boost -> reflect -> boost-back twin (``warp_st.core.lorentz.boost`` / ``lab_from_rest``) for
moving mirrors, closed-form retarded shadow geometry, and the docs/spec.md §3 pinhole directions
of ``analytic_scenes.pixel_directions``.

Sign conventions used throughout. The camera looks along the unit lab direction n; its
past null ray is E(s) = (t_c - s, c + s n), the photon that arrives moved along d = -n.
A reflection therefore maps the camera-side ray n to the past ray n_out = -d_in, where
d_in is the direction the photon had before it met the mirror: the kernel runs the
physical reflection backwards in time.
"""

import functools
import importlib.util
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import warp as wp
from analytic_scenes import look_at, pixel_directions

from warp_st.core import lorentz, tessellate
from warp_st.core.scene import Body, CameraState, Light, Material, RenderSettings, Scene, Surface
from warp_st.rendering.renderer import Renderer, init_warp

ROOT = Path(__file__).resolve().parents[2]
EPS32 = float(np.finfo(np.float32).eps)
EPS64 = float(np.finfo(np.float64).eps)

MIRROR = Material((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), 1.0)


# --------------------------------------------------------------------------- scene helpers


def _plane(path, corners, material, velocity=(0.0, 0.0, 0.0), *, n=1, t_ref=0.0):
    """A bilinear quad (4 corners, counter-clockwise) tessellated into an n x n grid of
    quads (2 n^2 triangles sharing edges), pivot at the corners' mean."""
    c = np.asarray(corners, dtype=np.float64)
    u = np.linspace(0.0, 1.0, n + 1)
    pts = np.array([(1 - a) * (1 - b) * c[0] + a * (1 - b) * c[1] + a * b * c[2] + (1 - a) * b * c[3] for b in u for a in u])
    tris = []
    for j in range(n):
        for i in range(n):
            q0, q1, q2, q3 = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [[q0, q1, q2], [q0, q2, q3]]
    return Body(path, (Surface(path, pts, np.array(tris, dtype=np.int64), material),), pts.mean(axis=0),
                np.asarray(velocity, dtype=np.float64), t_ref)


def _cube(path, centre, size, material, velocity=(0.0, 0.0, 0.0)):
    pts, tris = tessellate.cube(size)
    c = np.asarray(centre, dtype=np.float64)
    return Body(path, (Surface(path, pts + c, tris, material),), c, np.asarray(velocity, dtype=np.float64))


def _sphere(path, centre, radius, material, velocity=(0.0, 0.0, 0.0), *, segments=64):
    pts, tris, nrm = tessellate.sphere(radius, segments)
    c = np.asarray(centre, dtype=np.float64)
    return Body(path, (Surface(path, pts + c, tris, material, nrm),), c, np.asarray(velocity, dtype=np.float64))


def _scene(*bodies, lights=(), light_speed="finite", position=(0.0, 0.0, 0.0), rotation=None, focal=50.0,
           aperture=20.0, background=None):
    rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)

    def camera_state(path, frame):
        return CameraState("/Camera", float(frame), np.asarray(position, dtype=np.float64), rot, focal, aperture,
                           aperture, light_speed=light_speed)

    return Scene("<test>", tuple(bodies), tuple(lights), ("/Camera",), RenderSettings(background=background),
                 camera_state, default_camera="/Camera")


def _directions(scene, frame, width, height):
    """Pixel-centre lab look directions (H, W, 3), float64, docs/spec.md §3 pinhole (camera at rest)."""
    return pixel_directions(scene.camera_state("/Camera", frame), width, height)


# --------------------------------------------------------------------------- reflection oracles


def reflect_oracle(n, normal, v):
    """Float64 twin of ``reflect_null``: boost into the mirror's rest frame, reflect, boost back.

    n: camera-side past-ray directions (..., 3); normal: the mirror's lab-frame unit normal
    (3,); v: the mirror's lab velocity (3,), |v| < 1. The past null vector k = (-1, n) is
    taken to the rest frame by ``lorentz.boost(v)``. The rest-frame normal is found without
    any Minkowski-normal formula: the world-sheet's tangent vectors (0, e1), (0, e2)
    (e_i ⊥ normal, lab-simultaneous) boosted to the rest frame have spatial parts b1, b2
    that span the (static) rest-frame mirror, so N' = b1 × b2. There the reflection is the
    ordinary one, k_x' -> k_x' - 2 (k_x'·N') N' with k_t' unchanged (a mirror at rest keeps
    the frequency); ``lorentz.lab_from_rest(v)`` takes it back. Returns (n_out, k_t): the
    reflected past-ray direction and the time component of the reflected k (its lab
    energy relative to the arriving photon's is -k_t).
    """
    n = np.asarray(n, dtype=np.float64)
    N = np.asarray(normal, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    rest_from_lab = lorentz.boost(v)
    k = np.concatenate([-np.ones(n.shape[:-1] + (1,)), n], axis=-1)
    k_rest = k @ rest_from_lab.T
    helper = np.array([1.0, 0.0, 0.0]) if abs(N[0]) < 0.8 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(N, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(N, e1)
    b1 = (rest_from_lab @ np.r_[0.0, e1])[1:]
    b2 = (rest_from_lab @ np.r_[0.0, e2])[1:]
    n_rest = np.cross(b1, b2)
    n_rest /= np.linalg.norm(n_rest)
    kx = k_rest[..., 1:]
    kx = kx - 2.0 * (kx @ n_rest)[..., None] * n_rest
    k_out = np.concatenate([k_rest[..., :1], kx], axis=-1) @ lorentz.lab_from_rest(v).T
    return k_out[..., 1:] / -k_out[..., :1], k_out[..., 0]


def einstein_reflection(cos_in, beta):
    """Einstein (1905, §7): a mirror moving with speed beta along the x axis (its normal),
    light arriving with direction cosine cos_in to x leaves with

        cos_out = -[(1 + beta^2) cos_in - 2 beta] / (1 - 2 beta cos_in + beta^2),

    and frequency ratio nu_out / nu_in = (1 - 2 beta cos_in + beta^2) / (1 - beta^2).
    (Signed beta: negative moves the mirror towards the incoming light.) The light meets
    the mirror only when cos_in > beta."""
    den = 1.0 - 2.0 * beta * cos_in + beta * beta
    return -((1.0 + beta * beta) * cos_in - 2.0 * beta) / den, den / (1.0 - beta * beta)


@functools.lru_cache(maxsize=None)
def _reflect_kernel(precision):
    """A test kernel around the renderer's own ``reflect_null`` wp.func (one thread per input)."""
    from warp_st.kernels.shade import make_shade
    from warp_st.kernels.trace import make_trace

    init_warp()
    scalar = {"float32": wp.float32, "float64": wp.float64}[precision]
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    geometry, trace = make_trace(scalar)[:2]
    reflect_null = make_shade(scalar, vec3, vec4, geometry, trace)[4]

    @wp.kernel(enable_backward=False, module="unique")
    def reflect_many(n: wp.array(dtype=vec3), normal: wp.array(dtype=vec3), v: wp.array(dtype=vec3), finite: int,
                     ok: wp.array(dtype=wp.int32), out: wp.array(dtype=vec3)):
        i = wp.tid()
        good, d = reflect_null(n[i], normal[i], v[i], finite)
        ok[i] = good
        out[i] = d

    return reflect_many, vec3, np.float32 if precision == "float32" else np.float64


def _kernel_reflect(precision, n, normal, v, finite=True):
    """Run ``reflect_null`` on rows of (n, normal, v); returns (ok, n_out, rounded inputs)."""
    kernel, vec3, np_scalar = _reflect_kernel(precision)
    n, normal, v = (np.ascontiguousarray(np.broadcast_to(a, np.broadcast_shapes(np.shape(n), np.shape(normal), np.shape(v))))
                    .astype(np_scalar) for a in (n, normal, v))
    count = len(n)
    ok = wp.zeros(count, dtype=wp.int32, device="cpu")
    out = wp.zeros(count, dtype=vec3, device="cpu")
    arrays = [wp.array(a, dtype=vec3, device="cpu") for a in (n, normal, v)]
    wp.launch(kernel, dim=count, inputs=[*arrays, int(finite), ok, out], device="cpu")
    return ok.numpy(), out.numpy().astype(np.float64), (n.astype(np.float64), normal.astype(np.float64), v.astype(np.float64))


def _unit_rows(rng, count):
    a = rng.normal(size=(count, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


# =========================================================================== 1. mirror at rest


def test_plane_mirror_at_rest_doubles_the_optical_path():
    """A plane mirror at rest: the image of a body is the body reflected across the plane,
    and the light you see left the body one unfolded path length ago.

    Scene: camera at the origin looking down -z; mirror z = -10 (20 x 20, metallic 1,
    white); an unlit cube (edge 0.5, centre (1.5, 0.3, -4)) outside the field of view, so
    it is seen only in the mirror. Its mirror image is the cube centred at (1.5, 0.3, -16);
    every pixel-centre ray is intersected with that image box in float64 (slab test).

    Checked, per pixel:
    - the pixels showing the cube (bounces == 1, finite sourceTime) are exactly those whose
      ray meets the image box, except rays within 1e-5 (relative) of its silhouette;
    - their centroid lies within 1 px of the projected image centre. The projection of a
      box's centre is not its silhouette's centroid: the visible side face can shift it by
      up to about half a pixel (the face's projected width, 1 px), hence 1 px;
    - sourceTime = t_c - (|camera -> mirror| + |mirror -> cube|) = t_c - s_image, the
      lookback to the image box (the unfolded straight line): within float32 rounding of
      a ~16-unit path accumulated over two legs, 16 eps32 * (path + |t_c|);
    - eventTime is the mirror hit (t_c - 10 / |n_z|), Z its distance, objectId the mirror,
      and the colour is the cube's (mirror white, metallic 1);
    - mirror pixels that reflect only the sky keep the background AOVs (NaN, 0).
    """
    width, height, t_c = 160, 120, 5.0
    cube_c, half = np.array([1.5, 0.3, -4.0]), 0.25
    body = Material((0.8, 0.3, 0.1))
    scene = _scene(
        _plane("/Mirror", [(-10, -10, -10), (10, -10, -10), (10, 10, -10), (-10, 10, -10)], MIRROR),
        _cube("/Cube", cube_c, 2 * half, body),
    )
    img = Renderer(scene, frames=[t_c], width=width, height=height).render(t_c)
    d = _directions(scene, t_c, width, height)

    image_c = cube_c * np.array([1.0, 1.0, -1.0]) + np.array([0.0, 0.0, -20.0])

    def slab(grow):
        lo, hi = image_c - half * (1 + grow), image_c + half * (1 + grow)
        with np.errstate(divide="ignore", invalid="ignore"):
            t0, t1 = lo / d, hi / d
        near = np.minimum(t0, t1).max(axis=-1)
        far = np.maximum(t0, t1).min(axis=-1)
        return near <= far, near

    inside, s_image = slab(-1e-5)
    outside, _ = slab(1e-5)
    seen = (img.bounces == 1) & np.isfinite(img.source_time)
    assert inside.sum() > 30
    assert not (inside & ~seen).any() and not (seen & ~outside).any()

    # Centroid vs the projected geometric mirror image.
    proj = image_c[:2] / -image_c[2] * 50.0 / 10.0  # ndc
    expect_px = np.array([(proj[0] + 1) / 2 * width, (1 - proj[1] / (height / width)) / 2 * height])
    ys, xs = np.nonzero(seen)
    centroid = np.array([xs.mean() + 0.5, ys.mean() + 0.5])
    assert np.all(np.abs(centroid - expect_px) <= 1.0), (centroid, expect_px)

    # Unfolded path length: sourceTime = t_c - s_image.
    tol = 16 * EPS32 * (s_image[seen].max() + abs(t_c))
    assert np.max(np.abs(img.source_time[seen] - (t_c - s_image[seen]))) <= tol
    s_mirror = 10.0 / -d[..., 2]
    assert np.max(np.abs(img.event_time[seen] - (t_c - s_mirror[seen]))) <= 8 * EPS32 * (10 + abs(t_c)) * 2
    assert np.allclose(img.depth[seen], s_mirror[seen], rtol=8 * EPS32)
    assert (img.object_id[seen] == 1).all()
    assert np.allclose(img.rgba[seen], [0.8, 0.3, 0.1, 1.0], atol=1e-6)
    # The body is seen only in the mirror: twice as far back as a direct view would be.
    assert (t_c - img.source_time[seen]).min() > 2 * (np.linalg.norm(cube_c) - half) * 0.99

    sky = (img.object_id == 1) & ~outside
    assert sky.sum() > 1000
    assert np.isnan(img.source_time[sky]).all() and (img.bounces[sky] == 0).all()
    assert np.isfinite(img.event_time[sky]).all()


# =========================================================================== 2. moving mirror law


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_reflect_null_is_the_boost_reflect_boost_twin(precision):
    """``reflect_null`` (the kernel's wp.func, run in a test kernel) equals its float64
    twin on 4000 seeded random inputs: any ray direction n, any mirror normal N, any mirror
    velocity |v| <= 0.95 (normal, tangential and oblique motion alike).

    Laws checked: the twin's reflected direction (boost to the rest frame, ordinary
    reflection, boost back); the change k' - k lies along the world-sheet's Minkowski normal
    only (residual of k' - k = mu nu, nu = (N·v, N)); and the reflected ray is still null
    (unit spatial direction). The frequency ratio implied by the kernel's direction
    through invariance of the mirror-frame frequency, nu_out / nu_in =
    (1 + n_out·v) / (1 + n·v), equals the twin's 1 / (-k_t').

    Tolerance: the inputs are rounded to the kernel precision first and the twin gets the
    rounded values, so only the kernel's arithmetic differs. Its float formula
    f = 2 (n·N + N·v) / (1 - (N·v)^2), k' = (-1 - f N·v, n - f N), n_out = k'_x / -k'_t
    loses (1 + |f|) (1 + 1/(1 - (N·v)^2)) units of rounding in k', relative to |k'_t| after
    the division: 4 eps of that conditioning per sample, plus the twin's own float64
    rounding, 16 eps64 gamma^2 of it (its boosts carry gamma^2 terms). On these inputs a
    reflection that ignored the mirror's motion misses the bound on every sample.
    """
    rng = np.random.default_rng(20261122)
    count = 4000
    n, normal = _unit_rows(rng, count), _unit_rows(rng, count)
    v = _unit_rows(rng, count) * (0.95 * rng.random(count) ** 0.5)[:, None]
    ok, n_out, (n, normal, v) = _kernel_reflect(precision, n, normal, v)
    assert ok.all()
    eps = EPS32 if precision == "float32" else EPS64

    expect = np.empty_like(n_out)
    k_t = np.empty(count)
    for i in range(count):
        expect[i], k_t[i] = reflect_oracle(n[i], normal[i] / np.linalg.norm(normal[i]), v[i])
    nv = np.sum(normal * v, axis=1)
    f = 2.0 * (np.sum(n * normal, axis=1) + nv) / (1.0 - nv * nv)
    cond = (1.0 + np.abs(f)) * (1.0 + 1.0 / (1.0 - nv * nv)) / np.abs(k_t)
    gamma2 = 1.0 / (1.0 - np.sum(v * v, axis=1))
    bound = (4 * eps + 16 * EPS64 * gamma2) * cond
    err = np.linalg.norm(n_out - expect, axis=1)
    assert np.all(err <= bound), float(np.max(err / bound))
    unit_normal = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    static = n - 2.0 * np.sum(n * unit_normal, axis=1, keepdims=True) * unit_normal
    static /= np.linalg.norm(static, axis=1, keepdims=True)
    assert np.all(np.linalg.norm(static - expect, axis=1) > bound)
    assert np.allclose(np.linalg.norm(n_out, axis=1), 1.0, atol=8 * eps)

    # k' - k is parallel to nu = (N.v, N): least squares for (lambda, mu) in
    # lambda (-1, n_out) - (-1, n) = mu nu; lambda is the twin's -k_t'.
    k_in = np.concatenate([-np.ones((count, 1)), n], axis=1)
    nu = np.concatenate([nv[:, None], normal], axis=1)
    for i in range(0, count, 97):
        a = np.stack([np.r_[-1.0, n_out[i]], -nu[i]], axis=1)
        (lam, mu), *_ = np.linalg.lstsq(a, k_in[i], rcond=None)
        resid = np.linalg.norm(a @ np.array([lam, mu]) - k_in[i])
        assert resid <= bound[i] * (1 + abs(lam) + abs(mu)), (i, resid)
        assert abs(lam + k_t[i]) <= bound[i] * (1 + abs(lam)) * 4
    # The implied ratio carries the direction's error times |v| / |1 + n.v| (<= 20 here).
    n_dot_v = 1.0 + np.sum(n * v, axis=1)
    ratio_kernel = (1.0 + np.sum(n_out * v, axis=1)) / n_dot_v
    tol_ratio = 2.0 * bound * np.linalg.norm(v, axis=1) / np.abs(n_dot_v) + 4 * eps / np.abs(n_dot_v)
    assert np.all(np.abs(ratio_kernel - 1.0 / -k_t) <= tol_ratio)


@pytest.mark.parametrize("beta", [0.5, -0.5, 0.9, -0.9])
def test_moving_mirror_obeys_einsteins_reflection_law(beta):
    """A mirror moving with speed beta along its normal x reflects as Einstein (1905) says.

    Einstein's law maps the incoming photon direction to the outgoing one (forward in
    time). The kernel maps the camera ray n = -d_out to the past ray n_out = -d_in, so for
    incidence cosines cos_in = d_in·x > beta (the light must catch the mirror) we build
    d_out from Einstein's closed form (the transverse component keeps its sign, as in an
    ordinary reflection), feed n = -d_out, and require n_out = -d_in. The same inputs go
    through the float64 boost -> reflect -> boost twin, and the frequency ratio
    nu_out / nu_in = (1 - 2 beta cos_in + beta^2) / (1 - beta^2) must equal the twin's
    1 / (-k_t') and the ratio the kernel's direction implies, (1 + n_out·v) / (1 + n·v).
    Both mirror orientations (N = +x and -x) must agree: a two-sided mirror.

    The incidence angles are spread over [0, arccos(beta)), in three planes through x.
    float64 kernel; directions within 256 eps64 times the conditioning (1 + |f|) / |k_t'|
    of the kernel formula (see the twin test), frequency ratios (at most ~20) within
    1e-12 relative for the twin and 1e-11 for the ratio implied by the kernel's direction
    (its error times |v| / |1 + n·v| <= 10).
    """
    x = np.array([1.0, 0.0, 0.0])
    v = beta * x
    lo = math.acos(max(beta, -1.0)) if beta > -1 else math.pi
    phis = np.linspace(0.0, lo, 14)[:-1]  # incidence angles with cos_in > beta
    azim = np.array([0.0, 0.7, 2.1])
    phi, az = (a.ravel() for a in np.meshgrid(phis, azim))
    cos_in = np.cos(phi)
    cos_out, freq = einstein_reflection(cos_in, beta)
    trans = np.stack([np.zeros_like(az), np.cos(az), np.sin(az)], axis=1)
    d_in = cos_in[:, None] * x + np.sin(phi)[:, None] * trans
    d_out = cos_out[:, None] * x + np.sqrt(np.clip(1 - cos_out**2, 0, None))[:, None] * trans
    n = -d_out
    for normal in (x, -x):
        ok, n_out, _ = _kernel_reflect("float64", n, normal, v)
        assert ok.all()
        twin, k_t = reflect_oracle(n, normal, v)
        f = 2.0 * (n @ normal + v @ normal) / (1.0 - beta**2)
        tol = 256 * EPS64 * (1 + np.abs(f)) / np.abs(k_t)
        assert np.all(np.linalg.norm(n_out - (-d_in), axis=1) <= tol)
        assert np.all(np.linalg.norm(twin - (-d_in), axis=1) <= tol)
        assert np.allclose(1.0 / -k_t, freq, rtol=1e-12)
        implied = (1.0 + n_out @ v) / (1.0 + n @ v)
        assert np.allclose(implied, freq, rtol=1e-11)
    # Approaching mirror blue-shifts, receding red-shifts (head-on: ((1 - beta)/(1 + beta))^(+-1)).
    head_on = einstein_reflection(1.0, beta)[1]
    assert math.isclose(head_on, (1 - beta) / (1 + beta), rel_tol=1e-12)


def test_reflect_null_with_infinite_light_speed_is_the_3d_reflection():
    """With infinite light speed the ray stays at constant t: the mirror's motion is
    irrelevant and n_out = n - 2 (n·N) N (float32 kernel, 8 eps32)."""
    rng = np.random.default_rng(7)
    n, normal = _unit_rows(rng, 500), _unit_rows(rng, 500)
    v = _unit_rows(rng, 500) * 0.9
    ok, n_out, (n, normal, v) = _kernel_reflect("float32", n, normal, v, finite=False)
    assert ok.all()
    normal = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    expect = n - 2 * np.sum(n * normal, axis=1, keepdims=True) * normal
    expect /= np.linalg.norm(expect, axis=1, keepdims=True)
    assert np.max(np.abs(n_out - expect)) <= 8 * EPS32


# =========================================================================== 3. retarded shadows


@pytest.mark.parametrize("beta", [0.5, -0.9])
def test_moving_occluder_casts_its_retarded_shadow(beta):
    """The shadow of a moving sphere falls where the retarded geometry puts it.

    Point light at rest at L = (0, 40, 0); floor y = 0; sphere (radius 0.5, coupled,
    velocity beta x) whose centre is m(t) = (beta t, 6, 0). A floor point X seen by the
    camera at t_c is lit at t_X = t_c - |X - c| by light emitted at L at t_e; the shadow's
    centre is where the null line from (t_e, L) through the sphere centre's position when
    the light passes it, m(t_s), meets the floor:

        X*(t_s) = L + (m(t_s) - L) L_y / (L_y - m_y),   t_s + |X* - m(t_s)| + |X* - c| = t_c,

    solved by bisection in float64 (t_e = t_s - |m(t_s) - L|). With t_c = 6 + |c| the
    solution is t_s = 0, X* = 0 for any beta. A shadow cast from where the sphere is at
    t_X (no retardation on the shadow leg) is ~beta 6 L_y / (L_y - 6) away instead.

    Checked:
    - the dark floor pixels (floor hit, rgb = 0) are exactly the pixels whose shadow ray
      meets the exact Lorentz-contracted sphere (``lorentz.sphere_crossings`` from the
      floor event (t_X, X) along the past null ray to L), up to a silhouette band of 1 %;
    - the area centroid of the dark spot (hit events x = c + Z n, each weighted by its
      pixel's floor area) equals the centroid of the exact shadow (the same oracle on a
      600^2 floor grid) within one pixel footprint (0.04 across, 0.11 along the view at
      the spot) plus the sphere's tessellation (sagitta 1.2e-3 r, x 40/34 on the floor);
    - it equals X* within the same plus the shadow's own asymmetry |centroid - X*|
      of the exact shadow: the delay varies across the spot with curvature
      ~1/|X - m| = 1/6, a second-order shift of 0.015 (0.5c) and 0.037 (0.9c), itself
      asserted below 0.05 (a tenth of the spot radius);
    - the shadow cast without retardation on the shadow leg is more than 20 footprints
      away from the rendered one.
    """
    width, height, focal = 160, 120, 35.0
    light = np.array([0.0, 40.0, 0.0])
    m0, radius, v = np.array([0.0, 6.0, 0.0]), 0.5, np.array([beta, 0.0, 0.0])
    cam = np.array([0.0, 4.0, 10.0])
    t_c = 6.0 + float(np.linalg.norm(cam))
    scene = _scene(
        _plane("/Floor", [(-20, 0, 20), (20, 0, 20), (20, 0, -20), (-20, 0, -20)], Material((0.7, 0.7, 0.7))),
        _sphere("/Ball", m0, radius, Material((0.2, 0.4, 0.8)), v),
        lights=(Light("sphere", (1600.0, 1600.0, 1600.0), position=tuple(light)),),
        position=cam, rotation=look_at(-cam), focal=focal,
    )
    img = Renderer(scene, frames=[t_c], width=width, height=height).render(t_c)
    d = _directions(scene, t_c, width, height)
    floor = img.object_id == 1
    dark = floor & np.all(img.rgba[..., :3] == 0.0, axis=-1)
    assert floor.all()  # the sphere itself is above the view
    assert dark.sum() > 100

    def shadowed(x, t_x):
        """Exact shadow test of floor events (t_x, x): the past null ray towards L."""
        to_light = light - x
        dist = np.linalg.norm(to_light, axis=-1)
        s0, s1 = lorentz.sphere_crossings(t_x, x, to_light / dist[..., None], m0, radius, v, 0.0)
        return ~np.isnan(s0) & (s1 >= 0) & (s0 <= dist)

    # Per-pixel oracle from the pixel-centre floor events.
    s_floor = -cam[1] / d[..., 1]
    oracle = shadowed(cam + s_floor[..., None] * d, t_c - s_floor)
    assert (oracle ^ dark).sum() <= 0.01 * oracle.sum() + 2

    # The exact shadow's centroid on a fine floor grid.
    g = np.linspace(-1.5, 1.5, 601)
    gx, gz = np.meshgrid(g, g)
    fine = np.stack([gx, np.zeros_like(gx), gz], axis=-1)
    in_fine = shadowed(fine, t_c - np.linalg.norm(fine - cam, axis=-1))
    exact_centroid = fine[in_fine].mean(axis=0)
    assert not (in_fine[0].any() or in_fine[-1].any() or in_fine[:, 0].any() or in_fine[:, -1].any())

    # Closed form: the null line from the emission event through the retarded centre.
    def bisect(f, lo, hi):
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
        return lo

    def x_star(ts):
        m = m0 + v * ts
        return light + (m - light) * light[1] / (light[1] - m[1]), m

    t_s = bisect(lambda ts: ts + np.linalg.norm(x_star(ts)[0] - x_star(ts)[1]) + np.linalg.norm(x_star(ts)[0] - cam) - t_c,
                 -100.0, t_c)
    xs = x_star(t_s)[0]
    assert abs(t_s) < 1e-9 and np.allclose(xs, 0.0, atol=1e-9)
    asymmetry = np.abs(exact_centroid - xs)
    assert np.all(asymmetry < 0.05)

    # The rendered spot: hit events weighted by their pixels' floor area
    # (solid angle ~ cos^3 off the axis, times s^2 / |n_y|).
    hits = cam + d * img.depth[..., None].astype(np.float64)
    forward = -cam / np.linalg.norm(cam)
    weight = (d @ forward) ** 3 * img.depth.astype(np.float64) ** 2 / np.abs(d[..., 1])
    centroid = (hits[dark] * weight[dark, None]).sum(axis=0) / weight[dark].sum()
    pix = 20.0 / width / focal  # radians per pixel at the centre
    dist_c = float(np.linalg.norm(cam))
    foot = np.array([pix * dist_c, 0.0, pix * dist_c / (cam[1] / dist_c)])
    tess = 1.2e-3 * radius * light[1] / (light[1] - m0[1])
    assert np.all(np.abs(centroid - exact_centroid)[[0, 2]] <= (foot + tess)[[0, 2]]), (centroid, exact_centroid)
    assert np.all(np.abs(centroid - xs)[[0, 2]] <= (foot + tess + asymmetry)[[0, 2]]), (centroid, xs)

    # Without retardation on the shadow leg: the sphere where it is at the floor event's time.
    t_n = bisect(lambda t: t + np.linalg.norm(x_star(t)[0] - cam) - t_c, -100.0, t_c)
    naive = x_star(t_n)[0]
    assert np.linalg.norm(centroid - naive) > 20 * foot[0], (centroid, naive)


# =========================================================================== 4. sampling


def _sampling_scene():
    """A mirror floor, a lit moving cube, an emissive sphere: every AOV is non-trivial."""
    return _scene(
        _plane("/Floor", [(-6, -1, 2), (6, -1, 2), (6, -1, -14), (-6, -1, -14)],
               Material((0.9, 0.9, 0.9), (0.0, 0.0, 0.0), 0.7), n=3),
        _cube("/Cube", (-0.8, 0.0, -6.0), 1.0, Material((0.8, 0.4, 0.1)), (0.3, 0.0, 0.0)),
        _sphere("/Lamp", (1.2, 0.2, -7.0), 0.6, Material((0.1, 0.1, 0.1), (0.6, 0.8, 1.0)), segments=32),
        lights=(Light("distant", (1.0, 1.0, 1.0), direction=(0.3, 0.8, 0.5)),),
        position=(0.0, 1.0, 2.0), rotation=look_at((0.0, -0.25, -1.0)), background=(0.05, 0.05, 0.1),
    )


_AOVS = ("depth", "event_time", "proper_time", "doppler", "object_id", "source_time", "bounces")


def _same(a, b, names):
    for name in names:
        x, y = getattr(a, name), getattr(b, name)
        assert np.array_equal(x, y, equal_nan=True), name


def test_one_sample_is_the_pixel_centre_at_camera_time():
    """samples = 1 traces the pixel centre at the camera time: with shutter 0 it is the
    default render bit for bit, and a shutter changes nothing (one sample is the centre)."""
    scene = _sampling_scene()
    base = Renderer(scene, frames=[4.0], width=96, height=72).render(4.0)
    one = Renderer(scene, frames=[4.0], width=96, height=72, samples=1, shutter=0.0).render(4.0)
    shut = Renderer(scene, frames=[4.0], width=96, height=72, samples=1, shutter=3.0).render(4.0)
    assert (base.bounces > 0).any() and (base.object_id == 2).any()
    _same(base, one, ("rgba",) + _AOVS)
    _same(base, shut, ("rgba",) + _AOVS)


def test_many_samples_keep_centre_aovs_and_reproducible_beauty():
    """samples > 1: the AOVs come from the pixel-centre ray at the camera time, so they
    equal the single-sample render bit for bit (with and without a shutter, whose wider
    database must not change them: clipping never changes an image). The beauty is seeded
    per (pixel, sample): identical run after run, from a new Renderer and with 1 or 2
    threads, and it does differ from the one-sample beauty (anti-aliased edges: some
    alpha strictly between 0 and 1)."""
    scene = _sampling_scene()
    single = Renderer(scene, frames=[4.0], width=96, height=72).render(4.0)
    for shutter in (0.0, 2.0):
        r = Renderer(scene, frames=[4.0], width=96, height=72, samples=9, shutter=shutter)
        a = r.render(4.0, threads=1)
        b = r.render(4.0, threads=2)
        c = Renderer(scene, frames=[4.0], width=96, height=72, samples=9, shutter=shutter).render(4.0)
        _same(single, a, _AOVS)
        _same(a, b, ("rgba",) + _AOVS)
        _same(a, c, ("rgba",) + _AOVS)
        alpha = a.rgba[..., 3]
        assert ((alpha > 0) & (alpha < 1)).any()
        assert not np.array_equal(a.rgba, single.rgba)
        assert np.isfinite(a.rgba).all()


def test_shutter_blur_streak_is_velocity_times_shutter():
    """4D motion blur: samples spread the camera time over [t_c, t_c + shutter], so a slow
    body's image sweeps v x shutter. An emissive bar (2 wide, 3 tall, flat, z = -10) moving
    at v = 0.05 along x with shutter 20 sweeps 1 unit = 40 px (160 px across 4 units at
    distance 10). Along the centre row the alpha profile is a trapezoid whose ramps rise
    over exactly the sweep: a straight-line fit to each ramp (0.1 < alpha < 0.9) gives the
    sweep as 1 / slope, and the rising ramp's ends are the bar's left edge seen at t_c
    and at t_c + shutter. Retardation changes the image speed by v (x / |x|) ~ 0.5 % for
    this transverse motion, 0.2 px; the samples' pixel jitter blurs by < 1 px: +-1 px."""
    width, height, v, shutter = 160, 24, 0.05, 20.0
    bar = _plane("/Bar", [(-1.5, -1.5, -10), (0.5, -1.5, -10), (0.5, 1.5, -10), (-1.5, 1.5, -10)],
                 Material((0.0, 0.0, 0.0), (1.0, 0.6, 0.2)), (v, 0.0, 0.0), t_ref=-10.0)
    scene = _scene(bar, aperture=4.0, focal=10.0)
    img = Renderer(scene, frames=[0.0], width=width, height=height, samples=64, shutter=shutter).render(0.0)
    alpha = img.rgba[height // 2, :, 3].astype(np.float64)
    px = np.arange(width) + 0.5
    ppu = width / (4.0 / 10.0 * 10.0)
    sweep_px = v * shutter * ppu

    def ramp(sel):
        slope, icpt = np.polyfit(px[sel], alpha[sel], 1)
        return slope, icpt

    plateau = np.nonzero(alpha >= 0.999)[0]
    assert len(plateau) >= 0.5 * sweep_px  # full coverage between the ramps (bar wider than the sweep)
    rising = (alpha > 0.1) & (alpha < 0.9) & (px < plateau.min() + 0.5)
    falling = (alpha > 0.1) & (alpha < 0.9) & (px > plateau.max() + 0.5)
    s_up, c_up = ramp(rising)
    s_dn, c_dn = ramp(falling)
    assert abs(1.0 / s_up - sweep_px) <= 1.0, (1.0 / s_up, sweep_px)
    assert abs(-1.0 / s_dn - sweep_px) <= 1.0, (-1.0 / s_dn, sweep_px)
    # Ends of the rising ramp: the left edge x = -1.5 + v (t - t_ref) seen at t = t_c - 10.
    start = (-1.5 + v * (0.0 - 10.0 + 10.0)) * ppu + width / 2
    assert abs(-c_up / s_up - start) <= 1.0
    assert abs((1 - c_up) / s_up - (start + sweep_px)) <= 1.0


# =========================================================================== 5. depth bound


@pytest.mark.parametrize("light_speed", ["finite", "infinite"])
def test_parallel_mirrors_stop_at_max_depth(light_speed):
    """Two parallel mirrors x = +-2 facing each other, the camera between them looking
    obliquely down the corridor at an unlit back wall (z = -40, colour 0.5 red). Unfolding
    the reflections, a ray n reaches the wall after s = 40 / |n_z| with its x unfolded to
    X = n_x s: it makes k = floor((|X| + 2) / 4) reflections (k up to 19 here).

    Per pixel, for max_depth D in {0, 1, 3, 6}: bounces = min(k, D); if k <= D the colour
    is 0.5 x 0.9^k (mirror diffuse 0.9) and sourceTime = t_c - s (t_c with infinite light
    speed); if k > D the path ends on the (D+1)-th mirror hit, colour 0 and sourceTime =
    t_c - (2 + 4 D) / |n_x|. No NaN or inf in the beauty; larger D never removes light
    (each reflection only adds) and strictly adds pixels with more bounces. Pixels whose
    unfolded line passes within 1e-3 of a corridor corner are skipped. Tolerance: float32
    over a path of up to ~90 units and 20 legs, 4 eps32 (k + 2) s.
    """
    width, height, t_c = 96, 72, 0.0
    mirror = Material((0.9, 0.9, 0.9), (0.0, 0.0, 0.0), 1.0)
    yaw = math.radians(35.0)
    scene = _scene(
        _plane("/Left", [(-2, -30, 5), (-2, -30, -40), (-2, 30, -40), (-2, 30, 5)], mirror, n=4),
        _plane("/Right", [(2, -30, -40), (2, -30, 5), (2, 30, 5), (2, 30, -40)], mirror, n=4),
        _plane("/Back", [(-2.5, -30, -40), (2.5, -30, -40), (2.5, 30, -40), (-2.5, 30, -40)],
               Material((0.2, 0.6, 0.3), (0.3, 0.3, 0.3))),
        light_speed=light_speed, rotation=look_at((math.sin(yaw), 0.1, -math.cos(yaw))), focal=20.0,
    )
    d = _directions(scene, t_c, width, height)
    s_wall = 40.0 / -d[..., 2]
    x_unf = np.abs(d[..., 0] * s_wall)
    k = np.floor((x_unf + 2) / 4).astype(int)
    frac = (x_unf + 2) / 4 - k
    good = (np.abs(d[..., 1] * s_wall) < 25) & (frac > 1e-3) & (frac < 1 - 1e-3)
    assert good.sum() > 0.9 * good.size and k[good].max() >= 12

    previous = None
    for depth in (0, 1, 3, 6):
        img = Renderer(scene, frames=[t_c], width=width, height=height, max_depth=depth).render(t_c)
        b = img.bounces.astype(int)
        assert np.isfinite(img.rgba).all()
        assert b.max() <= depth
        assert np.array_equal(b[good], np.minimum(k, depth)[good])
        reached = k <= depth
        colour = np.where(reached, 0.5 * 0.9**k, 0.0)
        assert np.max(np.abs(img.rgba[..., 0] - colour)[good]) <= 16 * EPS32
        lookback = np.where(reached, s_wall, (2.0 + 4.0 * depth) / np.abs(d[..., 0]))
        if light_speed == "infinite":
            lookback = np.zeros_like(lookback)
        tol = 4 * EPS32 * (k + 2) * (s_wall + 1.0)
        assert np.all((np.abs(img.source_time - (t_c - lookback)) <= tol)[good])
        if previous is not None:
            assert np.all(img.rgba >= previous.rgba - 16 * EPS32)
            assert (b > previous.bounces.max()).sum() > 0
            still = previous.bounces.astype(int) < previous_depth
            _equal = np.array_equal(img.rgba[still], previous.rgba[still])
            assert _equal
        previous, previous_depth = img, depth


# =========================================================================== 6. no self-hits


@pytest.mark.parametrize("velocity", [(0.0, 0.0, 0.0), (0.0, 0.0, -0.5), (0.0, 0.0, 0.5),
                                      (0.6, 0.3, 0.0), (0.3, 0.0, -0.6)])
def test_a_reflected_ray_never_rehits_its_mirror(velocity):
    """A mirror (a 40 x 40 plane as a 6 x 6 grid, 72 triangles with shared edges and
    vertices) seen obliquely from the camera reflects onto a backdrop plane behind the
    camera (z = 12). A reflected ray that re-hit the mirror it left would show as
    bounces > 1, a mirror-coloured speckle, or a sourceTime on the mirror.

    Oracle, per pixel: the lab mirror plane (its rest plane Lorentz contracted about the
    pivot: a plane moving obliquely is tilted in the lab) moves with v, so the camera ray
    meets it at s1 = N·(o + v (t_c - t_ref)) / (N·n + N·v); the reflected direction is the
    boost -> reflect -> boost twin; the backdrop is met after s2. Every pixel on the mirror
    must have bounces = 1, eventTime = t_c - s1 and sourceTime = t_c - s1 - s2 (or the
    background AOVs when s2 <= 0 or the backdrop is missed), the backdrop's colour, and
    no pixel anywhere bounces more than once.

    Tolerance: float32. The reflected direction carries the kernel's rounding times the
    conditioning (1 + |f|) / |k_t'| (see the twin test), which the second leg s2
    multiplies; the legs themselves 8 eps32 (s1 + s2 + |t_c|).
    """
    width, height, t_c = 64, 48, 3.0
    v = np.asarray(velocity, dtype=np.float64)
    yaw = math.radians(30.0)
    z_mirror, z_back = -8.0, 12.0
    mirror = _plane("/Mirror", [(-20, -20, z_mirror), (20, -20, z_mirror), (20, 20, z_mirror), (-20, 20, z_mirror)],
                    Material((0.9, 0.9, 0.9), (0.0, 0.0, 0.0), 1.0), v, n=6)
    backdrop = _plane("/Back", [(-400, -400, z_back), (400, -400, z_back), (400, 400, z_back), (-400, 400, z_back)],
                      Material((0.3, 0.5, 0.7)))
    scene = _scene(mirror, backdrop, rotation=look_at((math.sin(yaw), 0.0, -math.cos(yaw))), focal=20.0)
    img = Renderer(scene, frames=[t_c], width=width, height=height, max_depth=3).render(t_c)
    d = _directions(scene, t_c, width, height)

    o = mirror.origin
    pts = mirror.surfaces[0].points
    lab = o + lorentz.contract(pts - o, v) if np.any(v) else pts
    normal = np.cross(lab[1] - lab[0], lab[7] - lab[0])
    normal /= np.linalg.norm(normal)
    s1 = normal @ (o + v * (t_c - mirror.reference_time)) / (d @ normal + normal @ v)
    hit = img.object_id == 1
    assert hit.sum() > 0.3 * hit.size
    assert np.all(s1[hit] > 0)
    assert img.bounces.max() <= 1

    n2, k_t = reflect_oracle(d, normal, v)
    x1 = d * s1[..., None]
    s2 = (z_back - x1[..., 2]) / n2[..., 2]
    x2 = x1 + n2 * s2[..., None]
    reaches = hit & (s2 > 0) & np.all(np.abs(x2[..., :2]) < 399, axis=-1)
    sky = hit & ~reaches
    assert reaches.sum() > 0.25 * hit.sum()

    assert np.all(img.bounces[reaches] == 1)
    assert np.allclose(img.rgba[reaches], [0.27, 0.45, 0.63, 1.0], atol=1e-6)
    tol_1 = 8 * EPS32 * (s1 + abs(t_c))
    assert np.all(np.abs(img.event_time - (t_c - s1))[hit] <= tol_1[hit])
    c = d @ normal
    nv = normal @ v
    f = 2.0 * (c + nv) / (1.0 - nv * nv)
    cond = 4 * EPS32 * (1 + np.abs(f)) * (1 + 1 / (1 - nv * nv)) / np.abs(k_t)
    tol_2 = 8 * EPS32 * (s1 + s2 + abs(t_c)) + cond * s2 / np.abs(n2[..., 2])
    err = np.abs(img.source_time - (t_c - s1 - s2))
    assert np.all(err[reaches] <= tol_2[reaches]), float(np.max((err / tol_2)[reaches]))
    assert np.all(np.isnan(img.source_time[sky])) and np.all(img.bounces[sky] == 0)


def _room():
    """Six unlit walls of distinct colours, a 60-unit box around the origin."""
    walls = [
        ([(-30, -30, -30), (30, -30, -30), (30, 30, -30), (-30, 30, -30)], (0.8, 0.2, 0.2)),
        ([(-30, -30, 20), (-30, 30, 20), (30, 30, 20), (30, -30, 20)], (0.2, 0.8, 0.2)),
        ([(-30, -30, -30), (-30, 30, -30), (-30, 30, 20), (-30, -30, 20)], (0.2, 0.2, 0.8)),
        ([(30, -30, -30), (30, -30, 20), (30, 30, 20), (30, 30, -30)], (0.8, 0.8, 0.2)),
        ([(-30, -30, -30), (-30, -30, 20), (30, -30, 20), (30, -30, -30)], (0.5, 0.5, 0.5)),
        ([(-30, 30, -30), (30, 30, -30), (30, 30, 20), (-30, 30, 20)], (0.9, 0.9, 0.9)),
    ]
    return [_plane(f"/Wall{i}", corners, Material(colour)) for i, (corners, colour) in enumerate(walls)]


@pytest.mark.parametrize("smooth", [False, True])
def test_a_convex_mirror_never_rehits_itself(smooth):
    """A ray reflected by a convex body can never meet that body again: each facet's plane
    has the whole (convex) polyhedron behind it. A mirror ball (radius 1.5, the default 64
    segments, at rest 12 in front of the camera, filling ~40 % of the frame) in a room of
    unlit walls must show bounces = 1 on every pixel it covers, including the grazing
    rim. Flat shading (facet normals) satisfies it; with the sphere's smooth shading
    normals the reflection about the interpolated normal can dip under the facet near the
    silhouette (incidence > ~86 deg with 64 segments) and would hit the ball again from
    inside (8 such pixels here before the fix): the kernel then reflects about the facet."""
    pts, tris, nrm = tessellate.sphere(1.5, 64)
    centre = np.array([0.0, 0.0, -12.0])
    ball = Body("/Ball", (Surface("/Ball", pts + centre, tris, Material((0.9, 0.9, 0.9), (0, 0, 0), 1.0),
                                  nrm if smooth else None),), centre)
    scene = _scene(ball, *_room())
    img = Renderer(scene, frames=[0.0], width=160, height=120, max_depth=4).render(0.0)
    on_ball = img.object_id == 1
    assert on_ball.sum() > 5000
    assert np.all(img.bounces[on_ball] == 1), np.bincount(img.bounces[on_ball].ravel())


# =========================================================================== scenes and example


MODES = ("infinite", "decoupled", "coupled")


def test_fig_4_6_flange_stages_differ_only_by_mode():
    """``usd_scenes/mirrors/`` holds the thesis Fig. 4.6 scene in three modes that share
    one stage: the same four flanges, mirror and camera placement; only the light speed,
    the Lorentz coupling and the camera time (finite-c cameras 18.675 ahead, the light
    delay from the stage centre to the camera) differ."""
    import warp_st

    scenes = {m: warp_st.load(ROOT / "usd_scenes" / "mirrors" / f"flanges_{m}.usda") for m in MODES}
    for mode, scene in scenes.items():
        flanges = [b for b in scene.bodies if "Flange" in b.prim_path]
        assert len(flanges) == 4
        assert all(abs(b.speed - 0.866) < 1e-3 for b in flanges)
        assert all(b.decoupled == (mode != "coupled") for b in flanges)
        assert any(s.material.metallic > 0 for b in scene.bodies for s in b.surfaces)
        cam0 = scene.camera_state(scene.default_camera, 0.0)
        assert cam0.light_speed.value == ("infinite" if mode == "infinite" else "finite")
        delay = float(np.linalg.norm(cam0.position))
        assert abs(delay - 18.675) < 1e-3
    t_inf = scenes["infinite"].camera_state(scenes["infinite"].default_camera, 60.0).time
    for mode in ("decoupled", "coupled"):
        t = scenes[mode].camera_state(scenes[mode].default_camera, 60.0).time
        assert abs(t - t_inf - 18.675) < 1e-9


def test_mirrored_flanges_example_quick(tmp_path, monkeypatch):
    """The example renders its 3 x 5 strip (quick: 64 x 48 tiles) into one PNG: the PNG
    holds the strip unscaled (to 1/255: 8-bit sRGB), each tile is the beauty of its mode's
    stage at its frame rendered on its own (warp_st.render, sRGB-encoded as in the
    example: the strip's one database per mode changes nothing), and the tiles differ
    from row to row (the three modes) and from column to column (the frames)."""
    import matplotlib.image

    import warp_st

    spec = importlib.util.spec_from_file_location("mirrored_flanges", ROOT / "examples" / "mirrored_flanges.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    made = []
    render_strip = module.render_strip
    monkeypatch.setattr(module, "render_strip", lambda *a, **k: made.append(render_strip(*a, **k)) or made[-1])
    out = tmp_path / "strip.png"
    assert module.main(["--quick", "--out", str(out)]) == 0
    strip = made[0][0].astype(int)
    h, w = 48, 64
    assert strip.shape == (3 * h, 5 * w, 3)
    png = (matplotlib.image.imread(out)[..., :3] * 255).round().astype(int)
    where = [(y, x) for y in range(png.shape[0] - strip.shape[0] + 1) for x in range(png.shape[1] - strip.shape[1] + 1)
             if np.abs(png[y, x:x + 8] - strip[0, :8]).max() <= 1
             and np.abs(png[y:y + strip.shape[0], x:x + strip.shape[1]] - strip).max() <= 1]
    assert len(where) == 1, f"the strip is not in the PNG at 1:1 ({len(where)} places)"
    tiles = strip.reshape(3, h, 5, w, 3).transpose(0, 2, 1, 3, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the stages' unsupported material inputs
        scenes = [warp_st.load(ROOT / "usd_scenes" / "mirrors" / f"flanges_{m}.usda") for m, _ in module.MODES]
    for r, scene in enumerate(scenes):
        for c, frame in enumerate(module.FRAMES):
            alone = module.to_srgb(warp_st.render(scene, frame=frame, width=w, height=h).rgba[..., :3]).astype(int)
            assert np.abs(alone - tiles[r, c]).max() <= 1, (r, c)
    step = lambda a, b: np.abs(a - b).mean()  # noqa: E731 - mean 8-bit difference of two tiles
    assert all(step(tiles[r, c], tiles[r, c + 1]) > 5 for r in range(3) for c in range(4)), "frames look alike"
    assert all(step(tiles[r, c], tiles[r + 1, c]) > 5 for r in range(2) for c in range(5)), "modes look alike"
