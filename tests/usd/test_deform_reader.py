"""The reader honours deforming meshes (docs/spec.md §2.2, issue 18).

Laws: a mesh's time-sampled points become world-space point samples that follow USD's own
evaluation (points at the fractional time code through ComputeLocalToWorldTransform) at
every lab time, a rotating ancestor included; the points' "TimeSampled" warning goes, the
one for what is still ignored (time-sampled normals) stays; a deforming body is
Lorentz-decoupled (an info line says so); a rigid surface in a body USD animates is sampled
beside the deforming one; UsdSkel-skinned meshes are sampled as UsdSkel bakes them, and
their skel primvars are not warned of; a point count that changes between samples is a
warning (the start time code's points are used).
"""
import numpy as np
import pytest
from pxr import Usd, UsdGeom

import warp_st
from warp_st.usd.animation import PROBE_TOLERANCE

from animation_stages import write
from deform_stages import HEADER, flag_samples, mesh_stage, skinned_box_stage

TURNING = HEADER + '''def Xform "Turntable"
{
    double xformOp:rotateY.timeSamples = { 0: 0, 10: 90 }
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Mesh "Cloth"
    {
        point3f[] points.timeSamples = {
            0: [(-1, -1, 2), (1, -1, 2), (1, 1, 2), (-1, 1, 2)],
            4: [(-1, -1, 3), (1, -1, 3), (1, 2, 3), (-1, 1, 3)],
        }
        normal3f[] normals.timeSamples = { 0: [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)], 4: [(0, 1, 0), (0, 1, 0), (0, 1, 0), (0, 1, 0)] }
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
    }
}
'''


def _usd_world_points(stage, path, t):
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(path))
    tc = Usd.TimeCode(float(t))
    m = np.array(mesh.ComputeLocalToWorldTransform(tc), dtype=np.float64)
    return np.asarray(mesh.GetPointsAttr().Get(tc), dtype=np.float64) @ m[:3, :3] + m[3, :3]


def test_point_samples_follow_usd_at_fractional_time_codes(tmp_path):
    """Points samples at 0 and 4 under a turntable turning 90 degrees over 0-10: at 200
    fractional lab times in [-1, 11] the samples' linear interpolation is USD's world points
    within the refinement's tolerance (PROBE_TOLERANCE x (1 + |p|), |p| <= 3.7; a rotation's
    sagitta peaks at the middle quarter point the refinement tests, so 2x covers the rest of
    the interval). Held before 0 and after 10 as USD holds."""
    path = write(tmp_path, "turning.usda", TURNING)
    with pytest.warns(UserWarning, match="normals: has 2 time samples"):
        scene = warp_st.load(path)
    (body,) = scene.bodies
    samples = body.surfaces[0].samples
    assert samples is not None and body.motion is None and body.decoupled
    assert {0.0, 4.0, 10.0} <= set(samples.times.tolist()) and len(samples.times) > 10  # refined for the turn
    stage = Usd.Stage.Open(path)
    worst = max(float(np.abs(samples.at(t) - _usd_world_points(stage, "/Turntable/Cloth", t)).max())
                for t in np.linspace(-1.0, 11.0, 200))
    assert worst <= 2.0 * PROBE_TOLERANCE * (1.0 + 3.7), worst
    np.testing.assert_allclose(body.surfaces[0].points, _usd_world_points(stage, "/Turntable/Cloth", 0.0), atol=1e-12)


def test_points_samples_are_not_warned_normals_samples_are(tmp_path):
    path = write(tmp_path, "turning.usda", TURNING)
    with pytest.warns(UserWarning):
        scene = warp_st.load(path)
    sampled = {(d.prim, d.attribute) for d in scene.diagnostics if d.code == "TimeSampled"}
    assert sampled == {("/Turntable/Cloth", "normals")}
    (info,) = [d for d in scene.diagnostics if d.code == "Deforming"]
    assert info.severity == "info" and info.prim == "/Turntable/Cloth"
    assert "Lorentz-decoupled" in info.message and "tetrahedral path" in info.message


def test_rigid_surface_of_an_animated_deforming_body_is_sampled(tmp_path):
    """A SpacetimeBodyAPI body moved by a translate (0 -> (5, 0, 0) over 0-10) holds a
    deforming flag and a rigid cube: the body has no rigid motion left, the cube's points
    are sampled through its world transform (USD's at every lab time), and an info says
    the coupled body is treated as decoupled."""
    samples, counts, indices = flag_samples(10.0)
    flag = mesh_stage("Flag", samples, counts, indices).split(HEADER, 1)[1]
    text = HEADER + '''def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (5, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "Hull"
    {
        double size = 1
    }
''' + flag.replace("\n", "\n    ") + "\n}\n"
    path = write(tmp_path, "ship.usda", text)
    scene = warp_st.load(path)
    (body,) = scene.bodies
    assert body.motion is None and body.decoupled
    hull, cloth = body.surfaces
    assert hull.samples is not None and cloth.samples is not None
    stage = Usd.Stage.Open(path)
    cube = UsdGeom.Xformable(stage.GetPrimAtPath("/Ship/Hull"))
    for t in (2.5, 7.25, 12.0):
        m = np.array(cube.ComputeLocalToWorldTransform(Usd.TimeCode(t)), dtype=np.float64)
        m0 = np.array(cube.ComputeLocalToWorldTransform(Usd.TimeCode(0.0)), dtype=np.float64)
        want = (hull.points - m0[3, :3]) @ np.linalg.inv(m0[:3, :3]) @ m[:3, :3] + m[3, :3]
        np.testing.assert_allclose(hull.samples.at(t), want, atol=1e-9)
        np.testing.assert_allclose(cloth.samples.at(t), _usd_world_points(stage, "/Ship/Flag", t), atol=1e-9)
    (info,) = [d for d in scene.diagnostics if d.code == "Deforming"]
    assert "spacetime:lorentzDecoupled is not set" in info.message


def test_skinned_mesh_is_sampled_and_its_binding_not_warned(tmp_path):
    """The skinned box: samples at UsdSkel's baked times differ from the bind pose once the
    joint turns, and no warning is left (skinning, skel primvars, points)."""
    path = skinned_box_stage(str(tmp_path / "arm.usda"))
    scene = warp_st.load(path)
    assert [d for d in scene.diagnostics if d.severity == "warning"] == []
    samples = scene.bodies[0].surfaces[0].samples
    assert samples is not None and samples.times[0] == 0.0 and samples.times[-1] >= 10.0
    np.testing.assert_allclose(samples.at(0.0), scene.bodies[0].surfaces[0].points)
    assert np.abs(samples.at(10.0) - samples.at(0.0)).max() > 0.5  # the upper ring swung over


def test_point_count_changing_between_samples_is_a_warning(tmp_path):
    samples, counts, indices = flag_samples(10.0)
    samples[10.0] = np.concatenate([samples[10.0], [[9.0, 9.0, 9.0]]])
    path = write(tmp_path, "grow.usda", mesh_stage("Flag", samples, counts, indices))
    with pytest.warns(UserWarning, match=r"/Flag: points: the point count changes between time samples"):
        scene = warp_st.load(path)
    assert scene.bodies[0].surfaces[0].samples is None


def test_posed_skeleton_without_animation_renders_its_pose(tmp_path):
    """The skinned box with its upper joint held at 60 degrees (rotations not time-sampled):
    nothing moves, so no samples, but the surface is UsdSkel's posed mesh (BakeSkinning on a
    flattened copy, in the test), not the bind pose."""
    from pxr import Gf, UsdSkel, Vt

    path = skinned_box_stage(str(tmp_path / "posed.usda"))
    stage = Usd.Stage.Open(path)
    rotations = stage.GetPrimAtPath("/Arm/Skel/Bend").GetAttribute("rotations")
    rotations.Clear()
    rotations.Set(Vt.QuatfArray([Gf.Quatf(1, 0, 0, 0), Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), 60).GetQuat())]))
    stage.Save()
    surface = warp_st.load(path).bodies[0].surfaces[0]
    assert surface.samples is None
    baked = Usd.Stage.Open(Usd.Stage.Open(path).Flatten())
    assert UsdSkel.BakeSkinning(UsdSkel.Root(baked.GetPrimAtPath("/Arm")))
    np.testing.assert_allclose(surface.points, _usd_world_points(baked, "/Arm/Box", 0.0), atol=1e-6)
    assert surface.points[:, 0].min() < -0.9  # the upper ring swung over (bind pose: |x| <= 0.2)


def test_point_samples_are_lab_times_at_the_stage_light_speed(tmp_path):
    """Lab time = light speed x time code (docs/spec.md §1): at 3 stage units per time code
    the flag's samples (time codes 0 and 10) are at lab times 0 and 30, and the surface is
    the start time code's points."""
    samples, counts, indices = flag_samples(10.0)
    path = write(tmp_path, "flag.usda", mesh_stage("Flag", samples, counts, indices))
    scene = warp_st.load(path, light_speed="3u/tc")
    surface = scene.bodies[0].surfaces[0]
    assert surface.samples.times.tolist() == [0.0, 30.0]
    np.testing.assert_allclose(surface.samples.at(15.0), 0.5 * (samples[0.0] + samples[10.0]), atol=1e-6)
