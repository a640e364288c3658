"""Shadows on a rotating body: its pieces of uniform motion (docs/spec.md §2.1) model one
surface within ``Body.seam``, so a shadow ray leaving one piece must not stop on its
neighbours' copy of the same face (self-shadow acne), and must still find the body's real
shadow on itself: a face receding from the light faster than the light reaches it, and the
retarded body sweeping across its own shadow rays. The rule is one for every light: a
distant one and an area light (a small RectLight far away in the same direction).

Oracle: the closed-form rotating box (checked against USD's ComputeLocalToWorldTransform)
and a float64 march of each shadow ray through it, at every rod pixel of a side face turned
to the sun. Lit or not is read from the pixel against the top face's, which nothing can
shadow (its rays leave the rod's slab upwards at once).
"""
from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

import warp_st
from warp_st.rendering.camera import pixel_directions

RATE = 20.053522829578812  # degrees per time code: the tips (2 from the axis) at 0.7 c
HALF = np.array([2.0, 0.15, 0.15])  # the bar: a unit cube scaled (4, 0.3, 0.3)
STAGE = """#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = 0
    endTimeCode = 20
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeCameraAPI"])
{{
    double3 xformOp:translate = (0, 9, 6)
    float3 xformOp:rotateXYZ = (-55, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    float focalLength = 24
}}
{light}
def Xform "Rod" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate = (0, 1, 0)
    double xformOp:rotateY.timeSamples = {{ 0: 0, 20: {angle!r} }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    def Cube "Bar"
    {{
        double size = 1
        double3 xformOp:scale = (4, 0.3, 0.3)
        uniform token[] xformOpOrder = ["xformOp:scale"]
    }}
}}
"""


#: The sun: a distant light, or a small RectLight 1000 away in the same direction (the
#: area-light path: its one sample is a point light there; the oracle aims at its centre).
LIGHTS = {
    "distant": """def DistantLight "Sun"
{
    float inputs:intensity = 2.5
    bool inputs:normalize = 1
    float3 xformOp:rotateXYZ = (-40, 30, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}""",
    "rect": """def RectLight "Sun"
{
    float inputs:intensity = 2500000
    float inputs:width = 1
    float inputs:height = 1
    double3 xformOp:translate = (383.022221559489, 642.7876096865394, 663.4139481689385)  # 1000 x the sun
    float3 xformOp:rotateXYZ = (-40, 30, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}""",
}


def _world(q, t):
    """The inverse of ``_rod_coordinates``."""
    th = np.radians(RATE * t)
    c, s = np.cos(th), np.sin(th)
    return np.stack([q[..., 0] * c + q[..., 2] * s, q[..., 1] + 1.0, -q[..., 0] * s + q[..., 2] * c], axis=-1)


def _rod_coordinates(p, t):
    """World points at lab times t in the bar's axes (half extents HALF), closed form."""
    th = np.radians(RATE * t)
    c, s = np.cos(th), np.sin(th)
    q = p - np.array([0.0, 1.0, 0.0])
    return np.stack([q[..., 0] * c - q[..., 2] * s, q[..., 1], q[..., 0] * s + q[..., 2] * c], axis=-1)


@pytest.mark.parametrize("primitive", [None, "rigid"])  # per-vertex worldlines (the default: tetrahedra leaves) and pieces
@pytest.mark.parametrize("light", sorted(LIGHTS))
@pytest.mark.parametrize("frame", [16.0, 17.5])  # events at t ~ 6-8: inside the samples
def test_a_rotating_rod_shadows_itself_where_the_march_says(tmp_path, frame, light, primitive):
    path = tmp_path / "rod.usda"
    path.write_text(STAGE.format(light=LIGHTS[light], angle=20 * RATE))
    stage = Usd.Stage.Open(str(path))
    bar = stage.GetPrimAtPath("/Rod/Bar")
    for t in (0.0, 3.7, frame):  # the closed form is USD's
        m = UsdGeom.Xformable(bar).ComputeLocalToWorldTransform(Usd.TimeCode(t))
        p = np.array(m.Transform(Gf.Vec3d(0.3, -0.2, 0.4)))
        np.testing.assert_allclose(_rod_coordinates(p, t), [1.2, -0.06, 0.12], atol=1e-9)

    width, height = 320, 180
    scene = warp_st.load(str(path))
    image = warp_st.render(scene, frame=frame, width=width, height=height, primitive=primitive)
    cam = scene.camera_state(None, frame)
    rod = image.object_id > 0
    t = image.event_time.astype(np.float64)
    lookback = np.where(rod, frame - t, 0.0)  # c = 1: the distance
    x = np.asarray(cam.position, dtype=np.float64) + lookback[..., None] * pixel_directions(cam, width, height)
    q = _rod_coordinates(x, t)
    lamp = scene.lights[0]
    if lamp.kind == "distant":
        sun = np.broadcast_to(np.asarray(lamp.direction, dtype=np.float64), x.shape)
    else:  # towards the lamp's centre from each hit
        sun = np.asarray(lamp.position, dtype=np.float64) - x
        sun = sun / np.linalg.norm(sun, axis=-1, keepdims=True)
    # The pieces model the surface within half a pixel (~0.01 here): a hit within TOL of one
    # face and 3 TOL away from the others is on that face.
    tol = 0.01
    gap = HALF - np.abs(q)
    on = (gap < tol) & rod[..., None]
    single = on.sum(-1) == 1
    inner = (gap > 3 * tol).sum(-1) == 2
    top = single & inner & on[..., 1] & (q[..., 1] > 0)
    side = single & inner & on[..., 2]
    normal_z = np.sign(q[..., 2])
    th = np.radians(RATE * t)
    n_world = np.stack([np.sin(th) * normal_z, np.zeros_like(th), np.cos(th) * normal_z], -1)
    cos_l = (n_world * sun).sum(-1)
    lum = image.rgba[..., :3].sum(-1).astype(np.float64)
    k = np.median(lum[top] / sun[..., 1][top])  # the unshadowable top face: lum = k cos_l
    assert top.sum() > 50 and k > 0
    # (l + u).n, u the point's velocity: the ray leaves the surface (> 0) or enters the rod
    u_point = (_world(q, t + 1e-6) - _world(q, t - 1e-6)) / 2e-6
    leave = ((sun + u_point) * n_world).sum(-1)
    faces = side & (cos_l > 0.05) & (np.abs(leave) > 0.1)
    assert faces.sum() > 300
    # The oracle's march starts outside the modelled surface's error (2 TOL) and the box is
    # shrunk by TOL, so a ray grazing the rod within the modelling error counts as unblocked;
    # but a ray with (l + u).n < 0 enters the exact rod at once: blocked, however shallow
    # (e.g. at -0.1 it may leave through the top face having entered by less than TOL).
    xs, ts = x[faces], t[faces]
    u = np.concatenate([np.linspace(2 * tol, 0.2, 200), np.linspace(0.2, 8.0, 2000)])
    blocked = leave[faces] < 0.0
    for a in range(0, len(u), 200):
        uu = u[a:a + 200]
        p = _rod_coordinates(xs[:, None, :] + uu[None, :, None] * sun[faces][:, None, :], ts[:, None] - uu[None, :])
        blocked |= (np.abs(p) <= HALF - tol).all(-1).any(1)
    dark = lum[faces] < 0.5 * k * cos_l[faces]
    wrong_dark, wrong_lit = dark & ~blocked, ~dark & blocked
    assert blocked.sum() > 10, "the scene must hold real self-shadow"
    # Acne from the neighbouring pieces was 27 % of these pixels at frame 17.5 (before
    # Body.seam); 2 % leaves room for rays grazing the rod within the modelling error.
    # Frame 16 is nearly all the rod's own shadow (a face receding from the sun).
    assert wrong_dark.mean() < 0.02, (wrong_dark.sum(), faces.sum())
    assert wrong_lit.mean() < 0.02, (wrong_lit.sum(), faces.sum())
