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

from animation_stages import hit_events, write
from deform_stages import grid, mesh_stage

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


def test_translating_points_doppler_is_their_velocity(tmp_path):
    """Tolerance 2e-5 on D (D ~ 0.6 to 0.8 here): the vertex velocities are float64
    differences of the sampled events rounded once to float32 (6e-8 relative), the kernel
    blends and divides in float32 (a few ulps of values ~1); the lab directions of the oracle
    are the float64 pixel centres, the kernel's within 1e-7. Against the fourVelocity twin
    (the rigid path): the same float32 rounding on both sides, 2e-5."""
    pts, counts, indices = grid(4, 3, 3.0, 2.0)
    pts = pts - (30.0, 0.0, 0.0)
    text = mesh_stage("Quad", {0.0: pts, 100.0: pts + (60.0, 0.0, 0.0)}, counts, indices)
    deforming = warp_st.load(write(tmp_path, "d.usda", text))
    uniform_text = mesh_stage("Quad", {0.0: pts}, counts, indices).replace(
        'def Mesh "Quad"\n{', 'def Mesh "Quad" (prepend apiSchemas = ["SpacetimeBodyAPI"])\n{\n    custom double4 '
        'spacetime:fourVelocity = (1, 0.6, 0, 0)\n    custom bool spacetime:lorentzDecoupled = true')
    uniform = warp_st.load(write(tmp_path, "u.usda", uniform_text))
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
    pts, counts, indices = grid(4, 3, 3.0, 2.0)
    pts = pts - (30.0, 0.0, 0.0)
    text = mesh_stage("Quad", {0.0: pts, 100.0: pts + (60.0, 0.0, 0.0)}, counts, indices) + LIGHT
    deforming = warp_st.load(write(tmp_path, "d.usda", text))
    uniform_text = (mesh_stage("Quad", {0.0: pts}, counts, indices) + LIGHT).replace(
        'def Mesh "Quad"\n{', 'def Mesh "Quad" (prepend apiSchemas = ["SpacetimeBodyAPI"])\n{\n    custom double4 '
        'spacetime:fourVelocity = (1, 0.6, 0, 0)\n    custom bool spacetime:lorentzDecoupled = true')
    uniform = warp_st.load(write(tmp_path, "u.usda", uniform_text))
    frame = 62.0
    options = dict(width=W, height=H, doppler_color=True, searchlight=True)
    a = Renderer(deforming, frames=[frame], **options).render(frame)
    u = warp_st.render(uniform, frame=frame, **options)
    both = (a.object_id > 0) & (u.object_id > 0)
    assert both.sum() > 100
    plain = warp_st.render(uniform, frame=frame, width=W, height=H)
    assert np.abs(plain.rgba[both, :3] - u.rgba[both, :3]).max() > 0.05  # the transform matters
    assert np.abs(a.rgba[both, :3] - u.rgba[both, :3]).max() <= 2e-3


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


def _usd_blended_velocity(path: str, prim_path: str, times, points) -> np.ndarray:
    """The velocity USD gives the material point at each event (t, x): x's barycentrics in
    the nearest of the mesh's triangles at time code t (USD's points there), blending the
    corners' displacements over the sample interval holding t divided by its length."""
    stage = Usd.Stage.Open(path)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(prim_path))
    assert np.allclose(np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(0.0))), np.eye(4))  # world = local
    attr = mesh.GetPointsAttr()
    samples = np.array(attr.GetTimeSamples())
    tris = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    out = []
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
    return np.array(out)


def test_stretching_points_doppler_is_the_blend_of_their_velocities(tmp_path):
    """Frames 50 and 60: events around time codes 35 to 47, on both sides of the sample at
    40. Tolerance 1e-3 on D (D ~ 0.4 to 1.3): between slices the tetrahedra depart from
    USD's interpolated triangles by at most DEFORM_TOLERANCE x the body's size (2.5e-4 x
    ~60 here: the extent over all samples, so k is large), which moves the hit's
    barycentrics, and so its blended velocity, by at most that over a triangle's edge
    (~1) times the corners' velocity spread (< 0.3): |du| < 5e-3 at worst, measured
    far below; |dD| <= D^2 |du| (decoupled). Float32 rounding of the hit (depth ~45 x 1e-7)
    and of the velocities is below 1e-5. The body's own velocity (0) would give D = 1, off
    by up to 0.6."""
    samples, counts, indices = _stretching_samples()
    path = write(tmp_path, "stretch.usda", mesh_stage("Sheet", samples, counts, indices))
    scene = warp_st.load(path)
    errors, spread, seen = [], [], []
    for frame in (50.0, 58.0):
        image = Renderer(scene, frames=[frame], width=W, height=H).render(frame)
        hit = image.object_id > 0
        times, points, _s = hit_events(scene, image, frame, W, H)
        assert len(times) > 200, frame
        u = _usd_blended_velocity(path, "/Sheet", times, points)
        expected = lorentz.doppler(_lab_directions(scene, frame, hit), u, body_decoupled=True)
        errors.append(np.abs(image.doppler[hit] - expected))

        spread.append(np.ptp(u, axis=0))
        seen.append(times)
    seen = np.concatenate(seen)
    assert seen.min() < 40.0 < seen.max()  # both sample intervals are seen
    err = np.concatenate(errors)
    assert err.max() <= 1e-3, float(err.max())
    assert np.max(spread) > 0.1  # the points move at different velocities
