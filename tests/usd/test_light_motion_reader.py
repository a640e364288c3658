"""Animated UsdLux lights as the reader samples them (docs/spec.md §3.4): time-sampled xformOps on a
light (or its ancestors) are honoured (no "not rendered" warning) and give ``Light.motion``, USD's
interpolation probed like a body's; a light animated at >= c warns naming the xformOp.
Exact comparisons (rel 1e-12) against USD's own ComputeLocalToWorldTransform: the probes are
USD's values, only rounded in float64 arithmetic."""
from __future__ import annotations

import textwrap
import warnings

import numpy as np
from pxr import Usd, UsdGeom

from warp_st.usd.reader import load_scene


def _load(tmp_path, body):
    path = tmp_path / "lights.usda"
    # c = 1 stage unit per time code (docs/spec.md §1.1): the speeds below are in those units
    path.write_text("#usda 1.0\n(\n    startTimeCode = 0\n    endTimeCode = 10\n)\n" + textwrap.dedent(body)
                    + '\ndef Sphere "Ball" {}\n'
                    + 'def RenderSettings "Settings" {\n    double spacetime:lightSpeedUnitsPerTimeCode = 1\n}\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(str(path))
    return path, scene, [str(w.message) for w in caught]


def test_a_light_under_an_animated_xform_has_its_worldline_and_no_warning(tmp_path):
    path, scene, messages = _load(tmp_path, '''
        def Xform "Rig" {
            double xformOp:rotateY.timeSamples = { 0: 0, 10: 90 }
            uniform token[] xformOpOrder = ["xformOp:rotateY"]
            def SphereLight "Lamp" {
                double3 xformOp:translate = (2, 1, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
            }
        }
    ''')
    (light,) = scene.lights
    assert not [m for m in messages if "not rendered" in m], messages
    m = light.motion
    assert m is not None and m.sample_times == (0.0, 10.0)
    assert len(m.times) > 2, "a rotating parent bends the path: the probes refine it"
    np.testing.assert_allclose(light.position, m.static_pivot, rtol=1e-12)
    stage = Usd.Stage.Open(str(path))
    prim = UsdGeom.Xformable(stage.GetPrimAtPath("/Rig/Lamp"))
    for t, o in zip(m.times, m.pivot):
        want = np.array(prim.ComputeLocalToWorldTransform(Usd.TimeCode(float(t))).ExtractTranslation())
        np.testing.assert_allclose(o, want, rtol=1e-12, atol=1e-12)
    assert light.extent >= float(np.linalg.norm(m.pivot - m.static_pivot, axis=1).max())


def test_a_static_light_has_no_motion(tmp_path):
    _path, scene, _ = _load(tmp_path, 'def DistantLight "Sun" {}')
    assert scene.lights[0].motion is None


def test_a_light_animated_faster_than_light_warns_naming_its_xformop(tmp_path):
    _path, scene, messages = _load(tmp_path, '''
        def SphereLight "Lamp" {
            double3 xformOp:translate.timeSamples = { 0: (0, 1, 0), 10: (30, 1, 0) }
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    ''')
    assert scene.lights[0].motion is not None
    (hit,) = [m for m in messages if "moves at 3 c" in m]
    assert "/Lamp" in hit and "xformOp:translate" in hit


def test_validate_reports_each_animated_light(tmp_path, capsys):
    """`warp-st validate` lists an INFO line per animated light: its samples and speed (0.5 c: 50
    stage units over 10 time codes), or a DistantLight's turn rate (2 degrees over 10), beside an
    animated body's line."""
    from warp_st.commands.cli import main

    path, _scene, _ = _load(tmp_path, '''
        def SphereLight "Lamp" {
            double3 xformOp:translate.timeSamples = { 0: (-25, 3, 0), 10: (-20, 3, 0) }
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
        def DistantLight "Sun" {
            float xformOp:rotateX.timeSamples = { 0: -140, 10: -142 }
            uniform token[] xformOpOrder = ["xformOp:rotateX"]
        }
        def SphereLight "Still" {}
        def Cube "Box" {
            double3 xformOp:translate.timeSamples = { 0: (0, 0, 0), 10: (1, 0, 0) }
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    ''')
    assert main(["validate", str(path)]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if "animated light" in line]
    assert lines == [
        f"INFO {path}:/Lamp: animated light: 2 time samples (0 to 10), speed 0.5 to 0.5 c "
        "(each hit lit from its retarded position)",
        f"INFO {path}:/Sun: animated light: 2 time samples (0 to 10), turning up to 0.2 degrees per time code "
        "(direction at each hit's time)"]
