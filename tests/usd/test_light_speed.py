"""The speed of light of a stage (docs/spec.md §1.1): lab time = c_s x time code.

Oracles: the closed form of c_s (299792458 m/s in the stage's units), the light-travel
time d / c_s of a plane at distance d, and the scaling law itself: a stage rendered with
c_s = k at time code f is the same stage with every time code multiplied by k rendered
with c_s = 1 at k f (the same pixels, event times k times larger).
"""
from __future__ import annotations

import numpy as np
import pytest
from cli_helpers import run

import warp_st
from warp_st.core.light_speed import PHYSICAL_LIGHT_SPEED, parse_light_speed
from warp_st.core.scene import SceneError

SIZE = dict(width=48, height=32)


def stage(tmp_path, *, meta="", camera="", settings="", samples=(0, 10), name="s.usda"):
    """A box moving along x by time samples, a camera looking at it down -z (distance 10)."""
    a, b = samples
    text = f"""#usda 1.0
(
    upAxis = "Y"
    startTimeCode = {a}
    endTimeCode = {b}
{meta}
)
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
{camera}
}}
def Cube "Box"
{{
    double size = 2
    double3 xformOp:translate.timeSamples = {{ {a}: (-2, 0, 0), {b}: (2, 0, 0) }}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
{settings}
"""
    path = tmp_path / name
    path.write_text(text)
    return path


def test_physical_default_is_the_closed_form(tmp_path):
    scene = warp_st.load(stage(tmp_path, meta="    metersPerUnit = 0.5\n    timeCodesPerSecond = 30"))
    assert scene.light_speed == pytest.approx(PHYSICAL_LIGHT_SPEED / 0.5 / 30, rel=1e-15)
    assert scene.light_speed_origin.startswith("the physical speed of light")
    # USD's fallbacks: 0.01 m per unit, 24 time codes per second
    assert warp_st.load(stage(tmp_path, name="f.usda")).light_speed == pytest.approx(PHYSICAL_LIGHT_SPEED / 0.24)


def test_schema_stage_keeps_one_unit_per_time_code(tmp_path):
    scene = warp_st.load(stage(tmp_path, camera='    double spacetime:time = 0'))
    assert scene.light_speed == 1.0
    assert not any(d.code == "LightSpeed" for d in scene.diagnostics)  # nothing new is printed


def test_render_settings_and_override(tmp_path):
    settings = 'def RenderSettings "Settings"\n{\n    double spacetime:lightSpeedMetersPerSecond = 48\n}\n'
    path = stage(tmp_path, meta="    metersPerUnit = 1\n    timeCodesPerSecond = 24", settings=settings)
    assert warp_st.load(path).light_speed == pytest.approx(2.0)  # 48 m/s = 2 units per time code
    assert warp_st.load(path, light_speed="3u/tc").light_speed == 3.0  # the command line wins
    assert warp_st.load(path, light_speed=parse_light_speed("physical")).light_speed == pytest.approx(
        PHYSICAL_LIGHT_SPEED / 24)


def test_both_settings_attributes_are_bad_input(tmp_path, capsys):
    settings = ('def RenderSettings "Settings"\n{\n    double spacetime:lightSpeedMetersPerSecond = 48\n'
                '    double spacetime:lightSpeedUnitsPerTimeCode = 2\n}\n')
    path = stage(tmp_path, settings=settings)
    with pytest.raises(SceneError, match="/Settings: spacetime:lightSpeedUnitsPerTimeCode: conflicts"):
        warp_st.load(path)
    code, _, err = run(capsys, "render", path, "-o", tmp_path / "x.exr", "--width", "8", "--height", "8", "--quiet")
    assert code == 2 and len(err.splitlines()) == 1 and "spacetime:lightSpeedUnitsPerTimeCode" in err
    assert not list(tmp_path.glob("*.exr"))


@pytest.mark.parametrize("text", ["0m/s", "-1u/tc", "3", "fast", "nanm/s"])
def test_bad_light_speed_option(tmp_path, capsys, text):
    code, _, err = run(capsys, "render", stage(tmp_path), "--light-speed", text, "--quiet")
    assert code == 2 and "--light-speed" in err


def test_event_time_is_the_light_travel_time(tmp_path):
    """Physical c: a hit at distance Z left the box Z / c_s time codes before the frame."""
    scene = warp_st.load(stage(tmp_path, meta="    metersPerUnit = 1\n    timeCodesPerSecond = 24"))
    image = warp_st.render(scene, frame=5.0, **SIZE)
    hit = image.object_id > 0
    assert hit.sum() > 50
    expected = 5.0 - image.depth[hit].astype(np.float64) / scene.light_speed
    # stored as float32 relative to t_c = 5: relative error <= 2^-24 of the lookback (~7e-7),
    # plus float32 depth's own rounding (2^-24 relative)
    np.testing.assert_allclose(image.event_time[hit], expected, rtol=0, atol=4 * 2.0**-24 * 7.3e-7 + 1e-15)
    assert image.camera_time == 5.0


def test_time_scaling_law(tmp_path):
    """c_s = 2 at time code 5 == every time code doubled at c_s = 1 and time code 10."""
    slow = warp_st.load(stage(tmp_path, name="a.usda"), light_speed="2units/timecode")
    unit = warp_st.load(stage(tmp_path, samples=(0, 20), name="b.usda"), light_speed="1u/tc")
    a, b = warp_st.render(slow, frame=5.0, **SIZE), warp_st.render(unit, frame=10.0, **SIZE)
    hit = a.object_id > 0
    assert hit.sum() > 50 and np.array_equal(hit, b.object_id > 0)
    # the box moves at 0.2 c in both: contracted and delayed alike; float32 rounding of the
    # lab times (10 vs 20) differs, so depths and colours agree to a few float32 ulps
    np.testing.assert_allclose(a.depth[hit], b.depth[hit], rtol=1e-5)
    np.testing.assert_allclose(a.rgba, b.rgba, atol=1e-5)
    np.testing.assert_allclose(2.0 * a.event_time[hit], b.event_time[hit], rtol=1e-6)
    # and slow light shows the delay: the box is seen ~Z / 2 time codes ago
    assert float(np.median(5.0 - a.event_time[hit])) == pytest.approx(float(np.median(a.depth[hit])) / 2, rel=1e-3)


def test_header_records_the_light_speed(tmp_path, capsys):
    out = tmp_path / "x.exr"
    code, _, err = run(capsys, "render", stage(tmp_path), "-o", out, "--width", "16", "--height", "8",
                       "--light-speed", "7units/timecode")
    assert code == 0, err
    header = warp_st.read_exr(out).metadata
    assert header["lightSpeedUnitsPerTimeCode"] == "7.0"
    assert header["lightSpeedOrigin"].startswith("--light-speed 7 units/timecode")


def test_authored_times_become_lab_times(tmp_path):
    """referenceTime, lifetime and animation samples are time codes: x c_s in the scene
    (fourVelocity is dimensionless and stays)."""
    path = tmp_path / "b.usda"
    path.write_text('''#usda 1.0
def Xform "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    double4 spacetime:fourVelocity = (1, 0.5, 0, 0)
    double spacetime:referenceTime = 3
    double2 spacetime:lifetime = (-1, 4)
    double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (0, 1, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "Hull"
    {
    }
}
''')
    one, two = warp_st.load(path), warp_st.load(path, light_speed="2u/tc")
    assert one.light_speed == 1.0 and two.light_speed == 2.0
    assert (one.bodies[0].reference_time, one.bodies[0].lifetime) == (3.0, (-1.0, 4.0))
    assert (two.bodies[0].reference_time, two.bodies[0].lifetime) == (6.0, (-2.0, 8.0))
    np.testing.assert_array_equal(two.bodies[0].motion.times, 2.0 * one.bodies[0].motion.times)
    np.testing.assert_array_equal(two.bodies[0].velocity, [0.5, 0.0, 0.0])
    # the pivot: USD's translate at the time code plus 0.5 c over the lab time since t_ref
    m = two.bodies[0].motion
    np.testing.assert_allclose(m.pivot[:, 0], 0.5 * (m.times - 6.0), atol=1e-12)
    np.testing.assert_allclose(m.pivot[:, 1], m.times / 20.0, atol=1e-12)


def test_validate_takes_the_light_speed(tmp_path, capsys):
    """The box moves 4 units in 10 time codes: 0.4 c at 1 unit per time code, 4 c at 0.1."""
    path = stage(tmp_path)
    code, out, _ = run(capsys, "validate", path)
    assert code == 0 and "physical speed of light" in out and "Superluminal" not in out and " 4 c " not in out
    code, out, _ = run(capsys, "validate", path, "--light-speed", "0.1units/timecode")
    assert code == 0 and "light speed 0.1 stage units per time code: --light-speed 0.1 units/timecode" in out
    assert "the animated pivot moves at 4 c between time codes 0 and 10 (>= the speed of light): rendered " \
           "Lorentz-decoupled" in out
    code, _, err = run(capsys, "validate", path, "--light-speed", "fast")
    assert code == 2 and "--light-speed" in err


def test_render_sequence_takes_the_stage_light_speed(tmp_path):
    """``render_sequence(path, stage_light_speed=...)`` renders what ``load(path,
    light_speed=...)`` renders, and records it; a Scene already has one, so giving it again
    is refused (``light_speed`` stays the renderer's finite / infinite mode)."""
    path = stage(tmp_path)
    result = warp_st.render_sequence(path, [5.0], tmp_path / "q.####.exr", workers=0, progress=False,
                                     stage_light_speed="2u/tc", **SIZE)
    written = warp_st.read_exr(result.files[0])
    assert written.metadata["lightSpeedUnitsPerTimeCode"] == "2.0"
    direct = warp_st.render(warp_st.load(path, light_speed="2u/tc"), frame=5.0, **SIZE)
    hit = direct.object_id > 0
    assert hit.sum() > 50 and np.array_equal(hit, written.object_id > 0)
    # the same renderer and rays: equal to float32 (the EXR stores the times as float32 offsets)
    np.testing.assert_allclose(written.event_time[hit], direct.event_time[hit], rtol=1e-6)
    with pytest.raises(ValueError, match="stage_light_speed"):
        warp_st.render_sequence(warp_st.load(path), [5.0], tmp_path / "r.####.exr", workers=0,
                                stage_light_speed="2u/tc")
