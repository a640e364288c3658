"""The animated example stages (examples/animation/, issue 18) load, show their body and
move it as authored.

Law: on the wheel rolling at 0.8c and the moon orbiting at 0.8c every hit pixel of the
animated body carries the Doppler factor of its pivot's velocity, D = 1 / (gamma (1 + n.v))
for a camera at rest (docs/spec.md §1; n the pixel's lab direction), v USD's pivot velocity
at the event time (a central difference of ComputeLocalToWorldTransform): the rolling
wheel's constant (0.8, 0, 0), the orbit's tangent of speed 0.8. Tolerance: a piece moves
along its chord, whose direction is within half the piece's turn theta of the tangent, so
|dD| <= D^2 gamma |v| theta / 2 (10 % margin for the chord's shorter length, second order)
plus float32 rounding (1e-5); theta is 0 for the wheel's straight path.
"""
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import warp_st
from warp_st.rendering.camera import pixel_directions
from warp_st.rendering.renderer import Renderer

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "animation"
W, H = 96, 54


@pytest.mark.parametrize("name, prim, frame", [("rolling_wheel", "/Wheel", 56.0),
                                               ("circular_orbit", "/Orbit/Moon", 40.0)])
def test_animated_pixels_carry_their_pivot_doppler(name, prim, frame):
    path = str(EXAMPLES / f"{name}.usda")
    scene = warp_st.load(path)
    index = scene.body_paths().index(prim)
    renderer = Renderer(scene, frames=[frame], width=W, height=H)
    image = renderer.render(frame)
    (cuts,) = [rows for i, rows in renderer.animation if i == index]
    spin = 0.8 / 5.0 if name == "circular_orbit" else 0.0  # the orbit's turn rate, rad per time
    theta = spin * float(np.diff([row[0] for row in cuts]).max())
    mine = image.object_id == index + 1
    assert mine.sum() > 30
    cam = scene.camera_state(None, frame)
    n = pixel_directions(cam, W, H, frame="lab")[mine]
    stage = Usd.Stage.Open(path)
    xformable = UsdGeom.Xformable(stage.GetPrimAtPath(prim))
    step = 1e-4
    velocities = []
    for t in image.event_time[mine].astype(np.float64):
        a = np.array(xformable.ComputeLocalToWorldTransform(Usd.TimeCode(t - step)))[3, :3]
        b = np.array(xformable.ComputeLocalToWorldTransform(Usd.TimeCode(t + step)))[3, :3]
        velocities.append((b - a) / (2 * step))
    v = np.array(velocities)
    assert np.allclose(np.linalg.norm(v, axis=1), 0.8, atol=1e-6)
    expected = np.sqrt(1.0 - 0.64) / (1.0 + np.einsum("ij,ij->i", n, v))
    gamma = 1.0 / np.sqrt(1.0 - 0.64)
    bound = 1.1 * expected ** 2 * gamma * 0.8 * theta / 2.0 + 1e-5
    assert (np.abs(image.doppler[mine] - expected) <= bound).all()


def test_spinning_rod_is_seen_and_its_pivot_rests():
    scene = warp_st.load(str(EXAMPLES / "spinning_rod.usda"))
    (rod,) = [b for b in scene.bodies if b.motion is not None]
    assert np.allclose(rod.motion.pivot, rod.motion.static_pivot)
    image = warp_st.render(scene, frame=50.0, width=W, height=H)
    mine = image.object_id == scene.bodies.index(rod) + 1
    assert mine.sum() > 20


def test_waving_flag_is_its_script_and_waves():
    """examples/animation/waving_flag.usda is what waving_flag.py writes; its flag deforms
    (points samples every 2 time codes), is seen at frame 32 and moves between frames 32
    and 34 (the banner at 0.8c and the wave)."""
    import runpy

    script = runpy.run_path(str(EXAMPLES / "waving_flag.py"))
    assert (EXAMPLES / "waving_flag.usda").read_text() == script["stage_text"]()
    scene = warp_st.load(str(EXAMPLES / "waving_flag.usda"))
    (banner,) = [b for b in scene.bodies if b.prim_path == "/Banner"]
    flag = [s for s in banner.surfaces if s.samples is not None]
    assert [s.prim_path for s in flag] == ["/Banner/Flag"] and banner.decoupled
    renderer = Renderer(scene, frames=[32.0, 34.0], width=W, height=H)
    a, b = renderer.render(32.0), renderer.render(34.0)
    mine = scene.bodies.index(banner) + 1
    assert (a.object_id == mine).sum() > 100
    assert ((a.object_id == mine) != (b.object_id == mine)).sum() > 20
