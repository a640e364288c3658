"""Coupled bodies turning on a moving pivot as per-vertex worldlines (spacetime/turning.py,
docs/spec.md §2.1, Unreleased): examples/animation/rolling_wheel.usda at 0.45c (a
UsdGeom.Cylinder tyre beside mesh spokes) and a coupled cube on a circular orbit at 0.8c.

Oracles, none of them the renderer's: USD's own ComputeLocalToWorldTransform at each hit's
event time with the closed-form contraction undone along the pivot's instantaneous
velocity (the authored rest surface); a float64 march of the primary rays through the
closed-form rotating, contracted wheel (coverage); the closed-form integral of dt / gamma
along the pivot (proper time)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

import warp_st
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.adaptive import min_pixel_angle
from warp_st.spacetime.turning import is_worldlines

from animation_stages import CUBE, HEADER, cube_surface_distance, hit_events, orbit, write
from example_scripts import load_example

WHEEL = Path(__file__).resolve().parents[2] / "examples" / "animation" / "rolling_wheel.usda"
COVERAGE = load_example("animation/wheel_coverage.py")  # the closed-form wheel and its march
SPEED, GAMMA, TYRE = COVERAGE.SPEED, COVERAGE.GAMMA, COVERAGE.TYRE
_wheel_coordinates, _inside_wheel = COVERAGE.wheel_coordinates, COVERAGE.inside_wheel


def test_the_closed_form_is_usds():
    stage = Usd.Stage.Open(str(WHEEL))
    spoke = UsdGeom.Xformable(stage.GetPrimAtPath("/Wheel/Spokes/Spoke1"))
    wheel = UsdGeom.Xformable(stage.GetPrimAtPath("/Wheel"))
    for t in (0.0, 13.37, 55.5):
        m = wheel.ComputeLocalToWorldTransform(Usd.TimeCode(t))
        p = np.array(m.Transform(Gf.Vec3d(0.3, -0.2, 0.1)))
        o = np.array(m.ExtractTranslation())
        lab = o + (p - o) * np.array([1.0 / GAMMA, 1.0, 1.0])  # contracted along the pivot's velocity, x
        np.testing.assert_allclose(_wheel_coordinates(lab, np.array(t)), [0.3, -0.2, 0.1], atol=1e-9)
        # a spoke's corner: on its box's surface in the closed form's axes
        corner = np.array(spoke.ComputeLocalToWorldTransform(Usd.TimeCode(t)).Transform(Gf.Vec3d(0.5, 0.5, 0.5)))
        q = _wheel_coordinates(o + (corner - o) * np.array([1.0 / GAMMA, 1.0, 1.0]), np.array(t))
        assert _inside_wheel(q, 1e-9) and not _inside_wheel(q, -1e-6)


def _tyre_distance(path: str, times, points) -> np.ndarray:
    """Distance of each rest-frame world point from the tyre's surface, carried back through
    USD's ComputeLocalToWorldTransform of /Wheel/Tyre at its time (a rigid transform)."""
    stage = Usd.Stage.Open(path)
    tyre = UsdGeom.Xformable(stage.GetPrimAtPath("/Wheel/Tyre"))
    out = []
    for t, x in zip(times, points):
        m = np.array(tyre.ComputeLocalToWorldTransform(Usd.TimeCode(float(t))), dtype=np.float64)
        q = (np.append(x, 1.0) @ np.linalg.inv(m))[:3]
        rho, z = np.hypot(q[0], q[1]), abs(q[2])
        if rho <= TYRE[0] and z <= TYRE[1]:
            out.append(min(TYRE[0] - rho, TYRE[1] - z))
        else:
            out.append(float(np.hypot(max(rho - TYRE[0], 0.0), max(z - TYRE[1], 0.0))))
    return np.array(out)


def _uncontracted(path: str, body: str, times, points) -> np.ndarray:
    """Each lab point with the contraction along its pivot's velocity undone about the pivot:
    the pivot o(t) is USD's origin of ``body`` at t, its velocity the central difference of
    it (USD's interpolation: exact for the wheel's linear path; 1e-9 of the orbit's)."""
    stage = Usd.Stage.Open(path)
    prim = UsdGeom.Xformable(stage.GetPrimAtPath(body))

    def origin(t):
        return np.array(prim.ComputeLocalToWorldTransform(Usd.TimeCode(float(t))).ExtractTranslation())

    out = []
    for t, x in zip(times, points):
        o = origin(t)
        v = (origin(t + 1e-3) - origin(t - 1e-3)) / 2e-3
        vhat = v / np.linalg.norm(v)
        gamma = 1.0 / np.sqrt(1.0 - v @ v)
        y = x - o
        out.append(o + y + (gamma - 1.0) * (y @ vhat) * vhat)
    return np.array(out)


def _orbit_path(tmp_path) -> str:
    return write(tmp_path, "orbit.usda", orbit(CUBE, speed=0.8, decoupled=False))


@pytest.mark.parametrize("case", ["wheel", "orbit"])
def test_hit_events_lie_on_the_authored_rest_surface(tmp_path, case):
    """Every hit event of the body, carried back by USD at its event time with the contraction
    undone along the pivot's instantaneous velocity, lies on the authored rest surface.
    Bound (relative to the hit's distance s): the chords' quarter pixel and the tetrahedra's
    half pixel (0.75 x the pixel angle), the tyre's 64-segment tessellation (sagitta
    1.2e-3 of radius 1: < 2e-4 of s >= 8) and float32 rounding of the hit (1e-5, generous)."""
    W, H = (256, 144) if case == "wheel" else (256, 192)
    path = str(WHEEL) if case == "wheel" else _orbit_path(tmp_path)
    body = "/Wheel" if case == "wheel" else "/Orbit/Moon"
    scene = warp_st.load(path)
    index = [b.prim_path for b in scene.bodies].index(body)
    for frame in ((50.0, 62.0) if case == "wheel" else (40.0, 63.0)):
        renderer = Renderer(scene, frames=[frame], width=W, height=H)
        assert is_worldlines(dict(renderer.animation)[index])
        image = renderer.render(frame)
        times, points, s = hit_events(scene, image, frame, W, H)
        mine = (image.object_id == index + 1)[image.object_id > 0]
        times, points, s = times[mine], points[mine], s[mine]
        assert len(times) > 200, frame
        rest = _uncontracted(path, body, times, points)
        if case == "wheel":
            error = _tyre_distance(path, times, rest)
            for k in range(4):
                error = np.minimum(error, cube_surface_distance(path, f"/Wheel/Spokes/Spoke{k}", times, rest, 0.5))
        else:
            error = cube_surface_distance(path, "/Orbit/Moon/Box", times, rest, 0.6)
        angle = min_pixel_angle(scene.camera_state(None, frame), W, H)
        bound = 0.75 * angle + (2e-4 if case == "wheel" else 0.0) + 1e-5
        assert (error / s).max() <= bound, (frame, float((error / s).max()), bound)


@pytest.mark.parametrize("frame", [50.0, 62.0])
def test_rolling_wheel_has_no_holes_or_extras_away_from_the_silhouette(frame):
    """Coverage against the float64 march (examples/animation/wheel_coverage.py), 160 x 90:
    0 holes and 0 extras where no pixel within 1 px is a march-silhouette pixel (the two
    marches, shrunk and grown by its TOL, disagree, or its 3 x 3 neighbours do not agree)."""
    result = COVERAGE.coverage(frame, 160, 90)
    assert result["model"] == "worldlines" and result["wheel"] > 150
    assert (result["holes"], result["extras"]) == (0, 0), result


def _accelerating() -> str:
    """A coupled box rolling along x whose pivot speeds up at time code 50 (0.1c, then 0.3c):
    USD's piecewise-linear velocity jumps there; it turns all the while."""
    return HEADER + f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double spacetime:referenceTime = 20
    double3 xformOp:translate.timeSamples = {{ 0: (-5, 0, 0), 50: (0, 0, 0), 100: (15, 0, 0) }}
    double xformOp:rotateZ.timeSamples = {{ 0: 0, 100: -300 }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    {CUBE}
}}
'''


def _closed_form_tau(t: np.ndarray) -> np.ndarray:
    """The integral of dt / gamma along the pivot from t_ref = 20."""
    a, b = np.sqrt(1.0 - 0.1 ** 2), np.sqrt(1.0 - 0.3 ** 2)
    return np.where(t <= 50.0, (t - 20.0) * a, 30.0 * a + (t - 50.0) * b)


@pytest.mark.parametrize("frame", [40.0, 65.0, 72.0])
def test_proper_time_is_the_pivots_integral_of_dt_over_gamma(tmp_path, frame):
    """properTime of every hit on the body is the pivot's closed-form proper time at the hit's
    lab time (points off the pivot take it, docs/spec.md §2.1). Bound: float32 rounding of
    the event time and the clock (values <= 60: 2e-5) plus the kernel's linear interpolation
    between slices, <= 1e-3 x the time to the nearer slice (TAU_RATE_TOLERANCE: here the
    speed is constant within each sample interval, so it is 0); frame 72 sees hits on both
    sides of the jump at 50 (the lookback is ~14-22)."""
    path = write(tmp_path, "accel.usda", _accelerating())
    scene = warp_st.load(path)
    W, H = 128, 96
    renderer = Renderer(scene, frames=[frame], width=W, height=H)
    assert is_worldlines(dict(renderer.animation)[0])
    image = renderer.render(frame)
    hit = image.object_id == 1
    assert hit.sum() > 100
    t = image.event_time[hit].astype(np.float64)
    tau = image.proper_time[hit].astype(np.float64)
    np.testing.assert_allclose(tau, _closed_form_tau(t), rtol=0.0, atol=2e-5 * (1.0 + np.abs(t).max()))


def test_uniform_rolling_keeps_the_proper_time_of_the_pivot_frame():
    """The 0.45c wheel (constant speed): every hit's proper time is t / gamma, t its lab time
    (t_ref 0), wherever on the wheel (not gamma (t - v.(x - o)), the pieces' per-piece clock)."""
    scene = warp_st.load(str(WHEEL))
    frame, W, H = 56.0, 128, 72
    image = warp_st.render(scene, frame=frame, width=W, height=H)
    hit = image.object_id == 1 + [b.prim_path for b in scene.bodies].index("/Wheel")
    assert hit.sum() > 100
    t = image.event_time[hit].astype(np.float64)
    np.testing.assert_allclose(image.proper_time[hit], t / GAMMA, rtol=0.0, atol=1e-4)


@pytest.mark.parametrize("options", [{"primitive": "tet"}, {"precision": "float64"}])
def test_proper_time_on_the_tetrahedral_path(tmp_path, options):
    """The tetrahedral path's own tables carry the pivot's clock too (float32 and float64)."""
    scene = warp_st.load(write(tmp_path, "accel.usda", _accelerating()))
    image = warp_st.render(scene, frame=72.0, width=64, height=48, **options)
    hit = image.object_id == 1
    assert hit.sum() > 30
    t = image.event_time[hit].astype(np.float64)
    np.testing.assert_allclose(image.proper_time[hit], _closed_form_tau(t), rtol=0.0,
                               atol=2e-5 * (1.0 + np.abs(t).max()))
