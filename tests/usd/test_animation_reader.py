"""The reader honours time-sampled xformOps (docs/spec.md §2.1, issue 18).

Laws: the probes follow USD's own ComputeLocalToWorldTransform at fractional time codes;
a coupled SpacetimeBodyAPI body whose pivot moves at >= c is bad input (exit 2, one line
naming the prim, the interval's time codes and the speed, nothing written); a gprim body
of its own at >= c renders decoupled with a warning; spacetime:fourVelocity composes with
the animation; the "TimeSampled" warning stays for what is still not honoured.
"""
import numpy as np
import pytest
from pxr import Usd, UsdGeom

import warp_st
from warp_st.commands.cli import main
from warp_st.core.scene import SceneError
from warp_st.usd.animation import PROBE_TOLERANCE

from animation_stages import CUBE, HEADER, orbit, write


def _body(ops: str, extra: str = "", api: bool = True) -> str:
    schema = ' (prepend apiSchemas = ["SpacetimeBodyAPI"])' if api else ""
    return HEADER + f'''def Xform "Ship"{schema}
{{
    {extra}
    {ops}
    def Cube "Hull"
    {{
        double size = 1
    }}
}}
'''


FAST = ('double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (1, 0, 0), 20: (13, 0, 0) }\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate"]')


def test_probes_follow_usd_at_fractional_time_codes(tmp_path):
    """Between the probes the reader keeps, USD's pivot lies on their chords within the
    probe tolerance (PROBE_TOLERANCE x (1 + |pivot|), |pivot| = 5; checked at 7 points
    per probe interval; the refinement tests the quarter points, and a rotation's sagitta
    peaks at the middle one, so no slack)."""
    path = write(tmp_path, "orbit.usda", orbit(CUBE, speed=0.8))
    motion = warp_st.load(path).bodies[0].motion
    stage = Usd.Stage.Open(path)  # held: a prim of a freed stage is invalid
    prim = stage.GetPrimAtPath("/Orbit/Moon")
    assert motion.sample_times == (0.0, 100.0) and len(motion.times) > 100
    worst = 0.0
    for k in range(0, len(motion.times) - 1, 37):
        a, b = motion.times[k], motion.times[k + 1]
        for f in np.linspace(0.0, 1.0, 7):
            t = a + f * (b - a)
            usd = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(t)))[3, :3]
            worst = max(worst, float(np.abs(usd - (motion.pivot[k] + f * (motion.pivot[k + 1] - motion.pivot[k]))).max()))
    assert worst <= PROBE_TOLERANCE * (1.0 + 5.0), worst


def test_coupled_body_at_light_speed_is_exit_2(tmp_path, capsys):
    """Between time codes 10 and 20 the pivot moves 12 units: 1.2c. The error names the xformOp
    that moves it (the attribute at fault, docs/spec.md §7)."""
    path = write(tmp_path, "fast.usda", _body(FAST))
    out = tmp_path / "out.exr"
    code = main(["render", path, "-o", str(out), "--width", "16", "--height", "16", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    (line,) = err.strip().splitlines()
    assert line == (f"warp-st: error: {path}: /Ship: xformOp:translate: the animated pivot moves at 1.2 c between "
                    "time codes 10 and 20 (>= the speed of light) on a Lorentz-coupled body; slow the animation "
                    "or set spacetime:lorentzDecoupled = true")


def test_decoupled_or_schema_less_body_at_light_speed_renders(tmp_path):
    decoupled = warp_st.load(write(tmp_path, "d.usda", _body(FAST, "custom bool spacetime:lorentzDecoupled = true")))
    assert decoupled.bodies[0].decoupled and not decoupled.diagnostics
    # a plain stage has the physical speed of light (docs/spec.md §1.1): 1.2 units per time
    # code is far below it; at one unit per time code it is 1.2 c
    physical = warp_st.load(write(tmp_path, "p.usda", _body(FAST, api=False)))
    assert not physical.bodies[0].decoupled and physical.bodies[0].motion is not None
    with pytest.warns(UserWarning, match="moves at 1.2 c between time codes 10 and 20.*rendered Lorentz-decoupled"):
        plain = warp_st.load(tmp_path / "p.usda", light_speed="1units/timecode")
    assert plain.bodies[0].decoupled and plain.bodies[0].motion is not None


def test_four_velocity_composes_with_the_animation(tmp_path):
    """fourVelocity (1, 0.2, 0, 0) from t_ref 5 on top of samples (0, 0, 0) at 0 and
    (0, 3, 0) at 10: the pivot is USD's plus 0.2 (t - 5) along x, at every probe and beyond
    the samples (held USD values plus the uniform motion)."""
    scene = warp_st.load(write(tmp_path, "c.usda", _body(
        'double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (0, 3, 0) }\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate"]',
        "custom double4 spacetime:fourVelocity = (1, 0.2, 0, 0)\n    custom double spacetime:referenceTime = 5")))
    motion = scene.bodies[0].motion
    expected = np.column_stack([0.2 * (motion.times - 5.0), 0.3 * motion.times, np.zeros_like(motion.times)])
    assert np.abs(motion.pivot - expected).max() <= 1e-12
    assert np.array_equal(motion.hold_velocity, [0.2, 0.0, 0.0])
    # and so the rendered pieces: held before 0 and after 10, moving with v = (0.2, 0.3, 0) between
    from warp_st.spacetime.animation import piece_bodies
    pieces = piece_bodies(scene.bodies[0], ((0.0, 0.0, 0.0), (10.0, 0.0, 5.0)))
    assert [p.lifetime for p in pieces] == [(-np.inf, 0.0), (0.0, 10.0), (10.0, np.inf)]
    assert np.allclose([p.velocity for p in pieces], [[0.2, 0, 0], [0.2, 0.3, 0], [0.2, 0, 0]], atol=1e-12)


def test_honoured_samples_are_not_warned_the_rest_still_is(tmp_path):
    """The body's and its ancestors' xformOps are honoured (no "TimeSampled" warning); a
    time-sampled xformOp below the body's prim and time-sampled normals still warn (time-sampled
    points are honoured: tests/usd/test_deform_reader.py)."""
    text = HEADER + '''def Xform "Carrier"
{
    double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (1, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
    {
        double xformOp:rotateY.timeSamples = { 0: 0, 10: 10 }
        uniform token[] xformOpOrder = ["xformOp:rotateY"]
        def Xform "Turret"
        {
            double xformOp:rotateX.timeSamples = { 0: 0, 10: 10 }
            uniform token[] xformOpOrder = ["xformOp:rotateX"]
            def Mesh "Gun"
            {
                point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
                normal3f[] normals.timeSamples = { 0: [(0, 0, 1), (0, 0, 1), (0, 0, 1)], 5: [(0, 1, 0), (0, 1, 0), (0, 1, 0)] }
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
            }
        }
    }
}
'''
    with pytest.warns(UserWarning):
        scene = warp_st.load(write(tmp_path, "w.usda", text))
    sampled = {(d.prim, d.attribute) for d in scene.diagnostics if d.code == "TimeSampled"}
    assert sampled == {("/Carrier/Ship/Turret", "xformOp:rotateX"), ("/Carrier/Ship/Turret/Gun", "normals")}
    assert scene.bodies[0].motion is not None and scene.bodies[0].motion.sample_times == (0.0, 10.0)


def test_animated_camera_at_light_speed_is_bad_input(tmp_path):
    text = '''#usda 1.0
(
    startTimeCode = 0
    endTimeCode = 10
)
def Camera "Cam"
{
    double3 xformOp:translate.timeSamples = { 0: (0, 0, 10), 10: (20, 0, 10) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "C"
{
}
'''
    assert np.linalg.norm(warp_st.load(write(tmp_path, "cam.usda", text)).camera_state(None, 3.0).velocity) < 1e-8
    scene = warp_st.load(tmp_path / "cam.usda", light_speed="1u/tc")  # (the physical default: 2e-9 c)
    with pytest.raises(SceneError, match=r"/Cam: xformOpOrder: the animated camera moves at 2 c at time code 3"):
        scene.camera_state(None, 3.0)
    assert np.allclose(scene.camera_state(None, 10.0).velocity, 0.0)  # held after the last sample


def test_validate_lists_animated_bodies(tmp_path, capsys):
    """One INFO line per animated body: samples, the pivot's speed range, the fastest body
    point (the rod's tips: 0.7c, the chords of the probes a hair slower), and the motion
    segments for the stage's camera at the default resolution over its time codes, the
    count the renderer's own rule gives for those cameras."""
    import re

    from warp_st.core.conventions import DEFAULT_RESOLUTION
    import functools

    from warp_st.spacetime.animation import animation_cuts, piece_count
    from warp_st.spacetime.reach import motion_reach

    from animation_stages import spinning_rod

    path = write(tmp_path, "rod.usda", spinning_rod(0.7))
    assert main(["validate", path]) == 0
    out = capsys.readouterr().out
    (line,) = [line for line in out.splitlines() if line.startswith("INFO")]
    # the rod turns on a pivot at rest: the default render traces it as per-vertex worldlines
    match = re.fullmatch(rf"INFO {re.escape(path)}:/Rod: animated: 2 time samples \(0 to 100\), pivot speed 0 to 0 c, "
                         r"body points up to (\S+) c \(coupled\); per-vertex worldlines, (\d+) sample intervals at "
                         r"640 x 360 \(tetrahedral path\)", line)
    assert match, line
    assert abs(float(match.group(1)) - 0.7 * np.sqrt(2.0 ** 2 + 0.2 ** 2 + 0.2 ** 2) / 2.0) <= 1e-3
    scene = warp_st.load(path)
    cameras = [scene.camera_state(None, float(f)) for f in np.linspace(0, 100, 101)]
    size = dict(width=DEFAULT_RESOLUTION[0], height=DEFAULT_RESOLUTION[1])
    reach = functools.partial(motion_reach, cameras=cameras, max_depth=4)
    (lines,) = animation_cuts(scene, cameras, reach=reach, worldlines=True, **size)
    assert int(match.group(2)) == piece_count(lines[1]) > 0
    (cuts,) = animation_cuts(scene, cameras, reach=reach, **size)  # its pieces (primitive rigid or prism)
    assert piece_count(lines[1]) < piece_count(cuts[1])  # far fewer samples than held orientations
    # the rod is 14 from the camera and unlit: the frames see it until about t = 88, the
    # chunks after that are not cut
    (whole,) = animation_cuts(scene, cameras, **size)
    assert piece_count(cuts[1]) < piece_count(whole[1]) == len(whole[1]) + 1


def test_a_camera_time_sampled_in_place_is_at_rest(tmp_path):
    """A camera whose translate is time-sampled but does not move (equal samples) beside a
    constant spacetime:time is at rest: not an animated camera whose time stands still (that
    stays bad input where the camera does move, naming the xformOp that moves it: the motion
    authored is the fault). Found by the fuzz test (tests/usd/test_fuzz_usd.py,
    WARP_ST_FUZZ_SEED=2659931714 and, for the attribute named, 390103457)."""
    def stage(samples):
        return '''#usda 1.0
def Camera "Cam" (prepend apiSchemas = ["SpacetimeCameraAPI"])
{
    custom double spacetime:time = 5
    double3 xformOp:translate.timeSamples = %s
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "C"
{
    double3 xformOp:translate = (0, 0, -6)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
''' % samples
    still = warp_st.load(write(tmp_path, "still.usda", stage("{ 0: (0, 0, 0), 1: (0, 0, 0) }")))
    cam = still.camera_state(still.default_camera, 0.0)
    assert not np.any(cam.velocity) and cam.time == 5.0
    moving = warp_st.load(write(tmp_path, "moving.usda", stage("{ 0: (0, 0, 0), 1: (0.5, 0, 0) }")))
    with pytest.raises(SceneError, match=r"/Cam: xformOp:translate: moves the camera at time code 0, where its "
                                         r"spacetime:time does not increase"):
        moving.camera_state(moving.default_camera, 0.0)
