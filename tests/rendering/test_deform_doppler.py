"""A deforming body's points emit with their own velocities (docs/spec.md §2.2, issue 18).

Law: the Doppler factor of a hit on a deforming (Lorentz-decoupled) mesh is D = (k.u_cam) /
(k.u_point) of warp_st.core.lorentz.doppler (the float64 twin, camera at rest), u_point the
velocity of the material point at the hit event: USD moves each point linearly between its
point samples, so u_point is the blend, with the hit's barycentrics on USD's triangle at the
hit's time code, of its corners' displacements over the sample interval holding the hit
divided by its length. The stages apply SpacetimeCameraAPI, so lab time = time code.

- A quad translating at 0.6c by its points: D equals the closed form for u = (0.6, 0, 0),
  and the spacetime.doppler channel (and, lit, the colour with Doppler colour on) equals
  the same quad moved by spacetime:fourVelocity, decoupled, on the rigid path.
- A mesh of triangles whose points move at different speeds (and change speed at the
  middle sample): D at each hit pixel equals the closed form with the blended velocity
  computed from USD's own points (UsdGeom.Mesh.GetPointsAttr().Get(t)).
Without the points' velocities (the body's uniform velocity, 0 here) D would be 1.
"""
import numpy as np
from pxr import Usd, UsdGeom

import warp_st
from warp_st.core import lorentz
from warp_st.rendering.camera import pixel_directions
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.adaptive import min_pixel_angle

from animation_stages import CHROME_DOME, hit_events, write
from deform_stages import grid, mesh_stage, translating_quad_stages

W, H = 96, 72
LIGHT = '''def DistantLight "Sun"
{
    float inputs:angle = 0
    float inputs:intensity = 2
    float3 xformOp:rotateXYZ = (-20, 15, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}
'''


def _lab_directions(scene, frame, hit):
    return pixel_directions(scene.camera_state(None, frame), W, H, frame="lab")[hit]


def _translating_pair(tmp_path, extra: str = ""):
    """``deform_stages.translating_quad_stages`` loaded: (deforming, fourVelocity twin)."""
    deforming, uniform = translating_quad_stages(extra)
    return warp_st.load(write(tmp_path, "d.usda", deforming)), warp_st.load(write(tmp_path, "u.usda", uniform))


def test_translating_points_doppler_is_their_velocity(tmp_path):
    """Tolerance 2e-5 on D (D ~ 0.6 to 0.8 here): the vertex velocities are float64
    differences of the sampled events rounded once to float32 (6e-8 relative), the kernel
    blends and divides in float32 (a few ulps of values ~1); the lab directions of the oracle
    are the float64 pixel centres, the kernel's within 1e-7. Against the fourVelocity twin
    (the rigid path): the same float32 rounding on both sides, 2e-5."""
    deforming, uniform = _translating_pair(tmp_path)
    assert not np.any(deforming.bodies[0].velocity)  # the motion is the points' alone
    seen = 0
    for frame in (55.0, 62.0, 70.0):
        a = Renderer(deforming, frames=[frame], width=W, height=H).render(frame)
        hit = a.object_id > 0
        expected = lorentz.doppler(_lab_directions(deforming, frame, hit), (0.6, 0.0, 0.0), body_decoupled=True)
        err = np.abs(a.doppler[hit] - expected)
        assert err.max() <= 2e-5, (frame, float(err.max()))
        assert np.ptp(expected) > 0.05  # D varies across the quad (the view directions differ)
        u = warp_st.render(uniform, frame=frame, width=W, height=H)
        both = hit & (u.object_id > 0)
        assert np.abs(a.doppler[both] - u.doppler[both]).max() <= 2e-5, frame
        seen += int(both.sum())
    assert seen > 300


def test_translating_points_shade_with_their_velocity(tmp_path):
    """Lit, Doppler colour and searchlight on: the deforming quad's colours equal its
    fourVelocity twin's (the colour transform reads D from the point's velocity), within
    2e-3 of colours ~0.1 to 1 (float32 shading on two databases whose hits round differently,
    ~1e-6 relative in position, the searchlight's D^4 and the colour table's interpolation)."""
    deforming, uniform = _translating_pair(tmp_path, LIGHT)
    frame = 62.0
    options = dict(width=W, height=H, doppler_color=True, searchlight=True)
    a = Renderer(deforming, frames=[frame], **options).render(frame)
    u = warp_st.render(uniform, frame=frame, **options)
    both = (a.object_id > 0) & (u.object_id > 0)
    assert both.sum() > 100
    plain = warp_st.render(uniform, frame=frame, width=W, height=H)
    assert np.abs(plain.rgba[both, :3] - u.rgba[both, :3]).max() > 0.05  # the transform matters
    assert np.abs(a.rgba[both, :3] - u.rgba[both, :3]).max() <= 2e-3


def test_receding_points_show_the_side_their_velocity_picks(tmp_path):
    """A lit quad turned 60 degrees about +Y (normal N) whose points move along N at 0.6c:
    the light reaching the camera leaves the side the photon moves away from relative to the
    surface point, -(n + u) (spec §2), so where n.N + u.N > 0 the camera sees the far side
    (-N), unlit (the sun lights +N: checked through USD), else the lit side. Frames 24 (the
    near side) and 30 (the far side); 192 x 144 (the quad is seen obliquely). Colours equal
    the fourVelocity twin's within 1e-5 (Lambert in float32 of values ~0.08, measured 3e-8)."""
    yaw, speed = 60.0, 0.6
    normal = np.array([np.sin(np.radians(yaw)), 0.0, np.cos(np.radians(yaw))])
    deforming, uniform = (warp_st.load(write(tmp_path, name, text)) for name, text in zip(
        ("d.usda", "u.usda"), translating_quad_stages(LIGHT, start=(-8.0, 1.0, -6.0), velocity=tuple(speed * normal),
                                                      yaw=yaw)))
    stage = Usd.Stage.Open(str(tmp_path / "d.usda"))  # held: a prim of a freed stage is invalid
    sun = stage.GetPrimAtPath("/Sun")
    m = np.array(UsdGeom.Xformable(sun).ComputeLocalToWorldTransform(Usd.TimeCode(0.0)))
    assert -np.array([0.0, 0.0, -1.0]) @ m[:3, :3] @ normal > 0.2  # the light comes from the +N side
    width, height = 192, 144
    far = near = 0
    for frame in (24.0, 30.0):
        a = Renderer(deforming, frames=[frame], width=width, height=height).render(frame)
        u = warp_st.render(uniform, frame=frame, width=width, height=height)
        both = (a.object_id > 0) & (u.object_id > 0)
        flipped = pixel_directions(deforming.camera_state(None, frame), width, height, frame="lab")[both] @ normal + speed > 0
        far, near = far + int(flipped.sum()), near + int((~flipped).sum())
        rgb = a.rgba[both, :3]
        assert (rgb[flipped] == 0.0).all() and (rgb[~flipped] > 0.05).all(), frame
        assert np.abs(rgb - u.rgba[both, :3]).max() <= 1e-5, frame
    assert far > 50 and near > 50


def test_approaching_mirror_points_reflect_with_their_velocity(tmp_path):
    """A mirror quad (metallic 1, diffuse 1) whose points approach the camera at (0.1, 0,
    0.15) reflecting a uniform white dome, searchlight on, one bounce: the reflected light's
    Doppler factor depends on the mirror point's velocity along its normal (the moving
    mirror's energy factor, ``reflect_null``), so it equals the fourVelocity twin's (rigid
    path) per pixel within 1e-4 of values ~3.2 (float32 on both: the reflected ray's
    direction and energy ~1e-6 relative, x 4 in the searchlight's fourth power; measured
    1.4e-6); a mirror at rest would reflect radiance 1."""
    deforming, uniform = (warp_st.load(write(tmp_path, name, text)) for name, text in zip(
        ("d.usda", "u.usda"), translating_quad_stages(CHROME_DOME, start=(-6.0, 1.0, -10.0), velocity=(0.1, 0.0, 0.15),
                                                      inside="rel material:binding = </Chrome>",
                                                      schemas=("MaterialBindingAPI",))))
    frame = 50.0
    options = dict(width=W, height=H, searchlight=True, max_depth=1)
    a = Renderer(deforming, frames=[frame], **options).render(frame)
    u = warp_st.render(uniform, frame=frame, **options)
    both = (a.object_id > 0) & (u.object_id > 0)
    assert both.sum() > 150
    assert np.abs(u.rgba[both, :3] - 1.0).min() > 0.2  # the mirror's motion shifts what it reflects
    assert np.abs(a.rgba[both, :3] - u.rgba[both, :3]).max() <= 1e-4


def _stretching_samples():
    """A 4 x 3 grid of points (3 wide, 2 high) cut into triangles, 20 to the left at time 0;
    each point moves with its own velocity, which changes at the middle sample (time 40),
    where the sheet passes in front of the camera."""
    pts, _counts, quads = grid(4, 3, 3.0, 2.0)
    x, y = pts[:, 0], pts[:, 1]  # -1.5..1.5, -1..1
    pts = pts - (20.0, 0.0, 0.0)
    tris = []
    for q in np.reshape(quads, (-1, 4)):
        tris += [int(i) for i in (q[0], q[1], q[2], q[0], q[2], q[3])]
    v1 = np.column_stack([0.5 + 0.1 * x, 0.05 * y, 0.05 * x - 0.03 * y])
    v2 = np.column_stack([0.45 - 0.05 * x * y, -0.04 * y, -0.05 + 0.03 * x * x])
    mid = pts + 40.0 * v1
    return {0.0: pts, 40.0: mid, 100.0: mid + 60.0 * v2}, [3] * (len(tris) // 3), tris


def _usd_blended_velocity(path: str, prim_path: str, times, points) -> tuple[np.ndarray, np.ndarray]:
    """The velocity USD gives the material point at each event (t, x): x's barycentrics in
    the nearest of the mesh's triangles at time code t (USD's points there), blending the
    corners' displacements over the sample interval holding t divided by its length. Also,
    per event, G: the largest over the triangles at t of (sum of 1 / its altitudes) x (its
    corners' largest velocity difference), which bounds the change of the blend when the
    point moves by dx in the surface: |du| <= G |dx| (|d b_i| <= |dx| / h_i, sum d b_i = 0)."""
    stage = Usd.Stage.Open(path)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(prim_path))
    assert np.allclose(np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(0.0))), np.eye(4))  # world = local
    attr = mesh.GetPointsAttr()
    samples = np.array(attr.GetTimeSamples())
    tris = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    out, gradient = [], []
    for t, x in zip(times, points):
        k = int(np.clip(np.searchsorted(samples, t, side="right") - 1, 0, len(samples) - 2))
        lo, hi = samples[k], samples[k + 1]
        vel = (np.asarray(attr.Get(hi), dtype=np.float64) - np.asarray(attr.Get(lo), dtype=np.float64)) / (hi - lo)
        corners = np.asarray(attr.Get(Usd.TimeCode(float(t))), dtype=np.float64)[tris]  # (T, 3, 3)
        a, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        g = np.stack([np.einsum("ij,ij->i", e1, e1), np.einsum("ij,ij->i", e1, e2), np.einsum("ij,ij->i", e2, e2)], 1)
        r = x - a
        r1, r2 = np.einsum("ij,ij->i", r, e1), np.einsum("ij,ij->i", r, e2)
        det = g[:, 0] * g[:, 2] - g[:, 1] ** 2
        b1, b2 = (g[:, 2] * r1 - g[:, 1] * r2) / det, (g[:, 0] * r2 - g[:, 1] * r1) / det
        bary = np.column_stack([1.0 - b1 - b2, b1, b2])
        foot = a + b1[:, None] * e1 + b2[:, None] * e2
        outside = np.maximum(-bary, 0.0).sum(axis=1)  # 0 inside the triangle
        best = int(np.argmin(np.linalg.norm(x - foot, axis=1) + outside))
        out.append(bary[best] @ vel[tris[best]])
        area2 = np.linalg.norm(np.cross(e1, e2), axis=1)  # twice the area: altitude h_i = area2 / opposite edge
        edges = np.stack([np.linalg.norm(corners[:, (i + 2) % 3] - corners[:, (i + 1) % 3], axis=1) for i in range(3)], 1)
        v = vel[tris]
        spread = np.max([np.linalg.norm(v[:, i] - v[:, j], axis=1) for i, j in ((0, 1), (1, 2), (0, 2))], axis=0)
        gradient.append(float((edges.sum(axis=1) / area2 * spread).max()))
    return np.array(out), np.array(gradient)


def test_stretching_points_doppler_is_the_blend_of_their_velocities(tmp_path):
    """Frames 50 and 58: events around time codes 32 to 44, on both sides of the sample at
    40. Bound per pixel: the renderer's u is the blend at the point x* of USD's triangle that
    the tetrahedra map the hit x to (same time, barycentrics (lam_a, lam_b, lam_c + f)), and
    the slices keep |x - x*| within half a pixel (0.5 x pixel angle x the hit's distance s,
    the rule; the oracle's foot of x in the triangle's plane is no further from x*), so
    |du| <= G x 0.5 x angle x s (``_usd_blended_velocity``'s G) and, decoupled, |dD| =
    D D' |n.du| <= D^2 |du| / (1 - D |du|); plus 2e-5 for float32 (the hit's time and
    position ~1e-6 relative, the velocities and D a few ulps). Measured: 4.8e-4 at most,
    the bound ~1e-2. The body's own velocity (0) would give D = 1, off by up to 0.2; the
    next interval's velocities at a corner on the slice above, 0.1."""
    samples, counts, indices = _stretching_samples()
    path = write(tmp_path, "stretch.usda", mesh_stage("Sheet", samples, counts, indices))
    scene = warp_st.load(path)
    spread, seen = [], []
    for frame in (50.0, 58.0):
        image = Renderer(scene, frames=[frame], width=W, height=H).render(frame)
        hit = image.object_id > 0
        times, points, s = hit_events(scene, image, frame, W, H)
        assert len(times) > 200, frame
        u, gradient = _usd_blended_velocity(path, "/Sheet", times, points)
        expected = lorentz.doppler(_lab_directions(scene, frame, hit), u, body_decoupled=True)
        du = gradient * 0.5 * min_pixel_angle(scene.camera_state(None, frame), W, H) * s
        assert (expected * du < 0.5).all()
        bound = expected ** 2 * du / (1.0 - expected * du) + 2e-5
        err = np.abs(image.doppler[hit] - expected)
        assert (err <= bound).all(), float((err - bound).max())
        assert bound.max() < 0.05  # well below what the mutations give
        spread.append(np.ptp(u, axis=0))
        seen.append(times)
    seen = np.concatenate(seen)
    assert seen.min() < 40.0 < seen.max()  # both sample intervals are seen
    assert np.max(spread) > 0.1  # the points move at different velocities
