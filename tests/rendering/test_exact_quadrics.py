"""Exact quadrics: a lone UsdGeom.Sphere traced as its ellipsoid on the rigid path (issue 19).

Law: in a body's rest coordinates the past null ray is a straight line and a coupled
moving sphere is its rest sphere (docs/spec.md §2), so a hit is a root of one quadratic
(``kernels/trace_rigid.ellipsoid_roots``). Checked against oracles that share none of the
kernel's code:

- GeoViS's own scene (a unit sphere at 0.9c, observer at t = 10 at (0, -10, -1), 40° field
  of view, 512²), against the closed form ``warp_st.core.lorentz.sphere_hit``: every pixel's
  hit or miss, event time, proper time and Doppler factor;
- an ellipsoid (a Sphere prim under a rotation and a non-uniform scale) moving at 0.8c,
  against USD's own ``ComputeLocalToWorldTransform``: every hit event, carried into the
  body's rest frame (float64 NumPy, ``core.lorentz``), lies on the authored surface;
- shading normals: a sphere lit by one distant light shows Lambert's cosine of the
  closed-form normal;
- mirrors: a mirror sphere's reflections reach an emitting wall where the closed-form
  normal's reflection does (the source time of each pixel).

Tolerances. The kernel solves for the lookback s in float64 and stores the event time
in float32, relative to the camera event (t_c - s ~ 8 here: one ulp is 9.5e-7). It traces
each pixel's direction as computed in float64 and rounded once to float32
(``render_kernel.camera_direction``), so the oracle takes those rays: event and proper
times within 1e-6 of the closed form. (Against the float64 pixel-centre rays, the 6e-8
rounding of the direction moves a hit a ray's width from tangency by up to 4e-5: two
pixels of 15,788 at 512² on GeoViS's scene, none farther than a pixel from the
silhouette.) Tessellated spheres (the reader's 64 segments) miss by up to 4e-2 and on 38
silhouette pixels on the GeoViS scene, so each check fails for them.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import warp_st
from warp_st.core import lorentz, tessellate
from warp_st.core.scene import Body, CameraState, Light, Material, Surface
from warp_st.rendering.renderer import Renderer
from warp_st.testing import pixel_directions, synthetic_scene

#: Event- and proper-time tolerance: one float32 ulp of values below 16 (module docstring).
TIME_TOL = 1e-6
#: Proper time: computed in float32 from the hit event (a few roundings of values ~8).
TAU_TOL = 4e-6


def geovis_camera(width=512, height=512, hfov_deg=40.0) -> CameraState:
    """GeoViS's observer: at rest at (0, -10, -1) at t = 10, looking along +Y, +Z up."""
    rotation = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # columns: camera x, y, z in the lab
    h_ap = 20.955
    focal = 0.5 * h_ap / math.tan(0.5 * math.radians(hfov_deg))
    return CameraState("/Camera", 10.0, np.array([0.0, -10.0, -1.0]), rotation, focal_length=focal,
                       horizontal_aperture=h_ap, vertical_aperture=h_ap * height / width)


def sphere_body(path, centre, radius, velocity, t_ref=0.0, material=Material(), decoupled=False) -> Body:
    """A UsdGeom.Sphere as the reader makes it: its default tessellation and its analytic shape."""
    pts, tris, nrm = tessellate.sphere(radius)
    m = np.eye(4)
    m[3, :3] = centre
    surf = Surface(path, pts + centre, tris, material, nrm, sphere=(float(radius), m))
    return Body(path, (surf,), np.asarray(centre, float), np.asarray(velocity, float), t_ref,
                (-math.inf, math.inf), decoupled)


def traced_directions(cam, width, height) -> np.ndarray:
    """The rays the kernel traces: the float64 pinhole rounded to float32, (H * W, 3)."""
    return pixel_directions(cam, width, height).reshape(-1, 3).astype(np.float32).astype(np.float64)


def render(scene, cam, width, height, **kw):
    return Renderer(scene, frames=[cam.time], width=width, height=height, **kw).render(cam.time)


@pytest.mark.parametrize("velocity, decoupled", [((0.9, 0.0, 0.0), False), ((0.5, 0.4, -0.6), False),
                                                  ((2.0, 0.0, 0.0), True)],
                         ids=["geovis_0.9c", "coupled_oblique", "decoupled_2c"])
def test_moving_ball_matches_the_closed_form_at_every_pixel(velocity, decoupled):
    w = h = 512
    cam = geovis_camera(w, h)
    body = sphere_body("/Ball", np.zeros(3), 1.0, velocity, decoupled=decoupled)
    img = render(synthetic_scene("geovis", [body], [], cam), cam, w, h)
    dirs = traced_directions(cam, w, h)
    exact = lorentz.sphere_hit(cam.time, cam.position, dirs, np.zeros(3), 1.0, np.asarray(velocity, float), 0.0,
                               decoupled=decoupled)
    hit = np.isfinite(exact.event_time).reshape(h, w)
    assert hit.sum() > 2000  # the ball covers a fair part of the image
    assert np.array_equal(img.object_id > 0, hit), int(((img.object_id > 0) != hit).sum())
    err = np.abs(img.event_time[hit] - exact.event_time.reshape(h, w)[hit])
    assert err.max() < TIME_TOL, float(err.max())
    tau = np.abs(img.proper_time[hit] - exact.proper_time.reshape(h, w)[hit])
    assert tau.max() < TAU_TOL, float(tau.max())
    dop = np.abs(img.doppler[hit] / exact.doppler.reshape(h, w)[hit] - 1.0)
    assert dop.max() < 1e-5, float(dop.max())  # D in float32 from the ray and the velocity (~1e-7)


ELLIPSOID = """#usda 1.0
(
    upAxis = "Y"
)
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 9)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 30
    float horizontalAperture = 36
    float verticalAperture = 27
}
def Xform "Body" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{
    double4 spacetime:fourVelocity = (1.6666666666666667, 0.8, 0.8, 0.0)
    double spacetime:referenceTime = -9
    double3 xformOp:translate = (-1, 0.5, 0)
    float3 xformOp:rotateXYZ = (20, 35, -10)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    def Sphere "Egg"
    {
        double radius = 1.25
        float3 xformOp:scale = (1.6, 0.7, 1.0)
        double3 xformOp:translate = (0.3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
    }
}
"""


def test_ellipsoid_hit_events_lie_on_the_authored_surface(tmp_path):
    """The four-velocity (gamma, gamma v) with gamma = 5/3 is v = (0.48, 0.48, 0): 0.68c;
    the body is at its authored place at t = -9, when the camera at t = 0 sees it."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "egg.usda"
    path.write_text(ELLIPSOID)
    scene = warp_st.load(str(path))
    (body,) = scene.bodies
    w, h = 160, 120
    cam = scene.camera_state(scene.default_camera, 0.0)
    img = render(scene, cam, w, h)
    hit = img.object_id > 0
    assert hit.sum() > 800
    # The hit events, from the rendered event times along each pixel's past null ray.
    dirs = pixel_directions(cam, w, h)
    s = cam.time - img.event_time[hit]
    x = cam.position + s[:, None] * dirs[hit]
    t = img.event_time[hit]
    # Into the body's rest frame about its pivot (docs/spec.md §2): r = A^-1 (x - o - v (t - t_ref)).
    v = np.asarray(body.velocity)
    rest = (x - body.origin - v * (t - body.reference_time)[:, None]) @ np.linalg.inv(
        lorentz.contraction_matrix(v, False)).T
    # The authored ellipsoid from USD: unit-sphere points u go to radius * u under the
    # Sphere's local-to-world matrix (row vectors), as authored (the rest shape).
    stage = Usd.Stage.Open(str(path))
    m = np.array(UsdGeom.Xformable(stage.GetPrimAtPath("/Body/Egg")).ComputeLocalToWorldTransform(0.0))
    u = ((rest + body.origin - m[3, :3]) @ np.linalg.inv(m[:3, :3])) / 1.25
    off = np.abs(np.linalg.norm(u, axis=1) - 1.0)
    assert off.max() < 2e-5, float(off.max())  # float32 event times of ~9 (1e-6) over a radius ~1
    # Coverage against the float64 root of the same quadric per pixel.
    a = (np.zeros((h, w, 3)) + cam.position - body.origin + v * body.reference_time)  # x - o - v(t - t_ref) at s = 0
    a = a - v * cam.time
    b = dirs + v  # d/ds of x - o - v (t - t_ref) along E(s) = (t_c - s, c + s n)
    inv_a = np.linalg.inv(lorentz.contraction_matrix(v, False)).T
    q_inv = np.linalg.inv(m[:3, :3]) / 1.25
    p0 = (a @ inv_a + body.origin - m[3, :3]) @ q_inv
    p1 = (b @ inv_a) @ q_inv
    qa, qb, qc = (p1 * p1).sum(-1), (p0 * p1).sum(-1), (p0 * p0).sum(-1) - 1.0
    disc = qb * qb - qa * qc
    expected = (disc >= 0) & ((-qb + np.sqrt(np.maximum(disc, 0))) >= 0)
    margin = np.abs(disc) < 1e-6 * qb * qb  # rays tangent to within float32 direction rounding
    assert np.array_equal(hit[~margin], expected[~margin]), int((hit != expected)[~margin].sum())


def test_lit_sphere_follows_lamberts_cosine_of_the_exact_normal():
    cam = geovis_camera(256, 256)
    l_dir = np.array([0.3, -0.8, 0.52])
    l_dir /= np.linalg.norm(l_dir)
    body = sphere_body("/Ball", np.zeros(3), 1.0, (0.0, 0.0, 0.0), material=Material(diffuse=(0.5, 0.5, 0.5)))
    scene = synthetic_scene("lit", [body], [Light("distant", (1.0, 1.0, 1.0), direction=tuple(l_dir))], cam)
    img = render(scene, cam, 256, 256)
    dirs = traced_directions(cam, 256, 256)
    exact = lorentz.sphere_hit(cam.time, cam.position, dirs, np.zeros(3), 1.0, np.zeros(3), 0.0)
    hit = np.isfinite(exact.event_time)
    assert np.array_equal(img.object_id.reshape(-1) > 0, hit)
    cos = np.maximum(exact.normal[hit] @ l_dir, 0.0)
    beauty = img.rgba.reshape(-1, 4)[hit, 0].astype(np.float64)
    k = float(beauty @ cos / (cos @ cos))  # the light's scale, whatever its units
    assert k > 0
    resid = np.abs(beauty - k * cos) / k
    # float32 normal and beauty (~1e-7); the 64-segment sphere's interpolated normals miss by ~1e-3.
    assert resid.max() < 2e-5, float(resid.max())


def test_mirror_sphere_reflects_about_the_exact_normal():
    """A static mirror ball in front of an emitting wall behind the camera: each pixel's
    source time is t_c minus the path to the ball and on, reflected about the exact
    normal, to the wall plane y = -20."""
    cam = geovis_camera(200, 200, hfov_deg=16.0)
    ball = sphere_body("/Ball", np.zeros(3), 1.0, (0.0, 0.0, 0.0), material=Material(diffuse=(1, 1, 1), metallic=1.0))
    wall_pts = np.array([[-400.0, -20.0, -400.0], [400.0, -20.0, -400.0], [400.0, -20.0, 400.0],
                         [-400.0, -20.0, 400.0]])
    wall = Surface("/Wall", wall_pts, np.array([[0, 1, 2], [0, 2, 3]]), Material(emissive=(1.0, 1.0, 1.0)))
    wall_body = Body("/Wall", (wall,), np.zeros(3), np.zeros(3), 0.0, (-math.inf, math.inf))
    scene = synthetic_scene("mirror", [ball, wall_body], [], cam)
    img = render(scene, cam, 200, 200, max_depth=2)
    dirs = traced_directions(cam, 200, 200)
    exact = lorentz.sphere_hit(cam.time, cam.position, dirs, np.zeros(3), 1.0, np.zeros(3), 0.0)
    on_ball = np.isfinite(exact.event_time)
    n, d = exact.normal[on_ball], dirs[on_ball]
    out = d - 2.0 * (d * n).sum(-1, keepdims=True) * n
    p = exact.position[on_ball]
    to_wall = (-20.0 - p[:, 1]) / out[:, 1]
    at_wall = p + to_wall[:, None] * out
    reaches = (to_wall > 0) & (np.abs(at_wall[:, 0]) < 400.0) & (np.abs(at_wall[:, 2]) < 400.0)
    expected = cam.time - exact.s[on_ball] - to_wall
    got = img.source_time.reshape(-1)[on_ball]
    assert reaches.sum() > 1000  # most of the ball reflects the wall behind the camera
    assert np.array_equal(np.isfinite(got), reaches)
    # Reflections meeting the wall within 100 (the farther ones meet it ever more obliquely,
    # where the distance's sensitivity to the direction grows without bound). Float32
    # event, normal and reflected direction (~1e-7 of the path ~30-100) give a median of
    # 4e-6; rays grazing the ball (whose hit point along the ray is ill-conditioned) up to
    # 1e-4. The 64-segment tessellation misses by up to 1.5 here (median 3e-2).
    near = reaches & (to_wall < 100.0)
    err = np.abs(got[near] - expected[near])
    assert np.median(err) < 1e-5 and err.max() < 3e-4, (float(np.median(err)), float(err.max()))


@pytest.mark.parametrize("velocity, decoupled", [((0.9, 0.0, 0.0), False), ((2.0, 0.0, 0.0), True)],
                         ids=["geovis_0.9c", "decoupled_2c"])
def test_float64_moving_ball_is_exact_to_1e9(velocity, decoupled, tmp_path):
    """With ``precision="float64"`` a scene of exact quadrics is traced on the rigid path in
    float64 (rays, roots, storage): event times within 1e-9 of the closed form at the
    float64 pixel-centre rays (issue 19's target; GeoViS: 1.4e-11). Roundings of a few
    1e-16 of values ~10 leave room; near tangency the root's sensitivity to the direction
    (1e-16 here) grows by the 1/sqrt of the discriminant, so the bound is loose by orders."""
    w = h = 512
    cam = geovis_camera(w, h)
    body = sphere_body("/Ball", np.zeros(3), 1.0, velocity, decoupled=decoupled)
    r = Renderer(synthetic_scene("geovis", [body], [], cam), frames=[cam.time], width=w, height=h,
                 precision="float64")
    assert r.primitive == "rigid" and r.describe()["quadrics"] == "exact"
    img = r.render(cam.time)
    dirs = pixel_directions(cam, w, h).reshape(-1, 3)
    exact = lorentz.sphere_hit(cam.time, cam.position, dirs, np.zeros(3), 1.0, np.asarray(velocity, float), 0.0,
                               decoupled=decoupled)
    hit = np.isfinite(exact.event_time).reshape(h, w)
    assert np.array_equal(img.object_id > 0, hit)
    err = np.abs(img.event_time[hit] - exact.event_time.reshape(h, w)[hit])
    assert err.max() < 1e-9, float(err.max())
    # The EXR keeps it: float32 eventTime plus its float32 residual, read back bit for bit.
    path = tmp_path / "ball.exr"
    img.write_exr(path)
    back = warp_st.read_exr(path)
    assert "spacetime.eventTimeLow" in back.extra and "spacetime.sourceTimeLow" in back.extra
    assert np.array_equal(back.event_time, img.event_time, equal_nan=True)
    assert np.array_equal(back.source_time, img.source_time, equal_nan=True)


def test_float64_scene_with_meshes_keeps_the_prism_path():
    """The rigid path's meshes are float32: a float64 render with any mesh body takes the
    prism path (tessellating its spheres), and asking for rigid or exact there is refused."""
    cam = geovis_camera(32, 32)
    cube_pts, cube_tris = tessellate.cube(1.0)
    cube = Body("/Cube", (Surface("/Cube", cube_pts + [3.0, 0.0, 0.0], cube_tris),), np.array([3.0, 0.0, 0.0]),
                np.zeros(3), 0.0, (-math.inf, math.inf))
    scene = synthetic_scene("mixed", [sphere_body("/Ball", np.zeros(3), 1.0, (0.5, 0.0, 0.0)), cube], [], cam)
    kw = dict(frames=[10.0], width=32, height=32, precision="float64")
    r = Renderer(scene, **kw)
    assert r.primitive == "prism" and r.describe()["quadrics"] == "tessellated"
    # float32 renders carry no residual channels
    assert not any(name.endswith("Low") for name in Renderer(scene, frames=[10.0], width=32, height=32)
                   .render(10.0).extra)
    with pytest.raises(warp_st.SceneError, match="primitive"):
        Renderer(scene, primitive="rigid", **kw)
    with pytest.raises(warp_st.SceneError, match="quadrics"):
        Renderer(scene, quadrics="exact", **kw)
    # Tessellated spheres alone in float64 stay on the prism path too.
    alone = synthetic_scene("alone", [sphere_body("/Ball", np.zeros(3), 1.0, (0.5, 0.0, 0.0))], [], cam)
    assert Renderer(alone, quadrics="tessellated", **kw).primitive == "prism"


def test_exact_is_the_rigid_default_and_refused_elsewhere():
    cam = geovis_camera(32, 32)
    scene = synthetic_scene("one", [sphere_body("/Ball", np.zeros(3), 1.0, (0.5, 0.0, 0.0))], [], cam)
    assert Renderer(scene, frames=[10.0], width=32, height=32).describe()["quadrics"] == "exact"
    prism = Renderer(scene, frames=[10.0], width=32, height=32, primitive="prism")
    assert prism.describe()["quadrics"] == "tessellated"
    with pytest.raises(warp_st.SceneError, match="quadrics"):
        Renderer(scene, frames=[10.0], width=32, height=32, primitive="tet", quadrics="exact")
