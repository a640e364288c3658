"""The animated example stages (examples/animation/, issue 18) load, show their body and
move it as authored.

Law: on the wheel rolling at 0.45c and the moon orbiting at 0.8c every hit pixel of the
animated body carries the Doppler factor of its own point's velocity (docs/spec.md §2.1),
D = 1 / (gamma_u (1 + n.u)) for a camera at rest (§1; n the pixel's lab direction; gamma_u
1 for the decoupled moon), u what USD's animation gives the material point at the hit event
(t, x): with o(t) the pivot and L(t) the linear part of M(t_s)^-1 M(t) (central differences
of ComputeLocalToWorldTransform), r = (x - o) A^-1 L^-1 and u = o' + r L' A (row vectors,
A the contraction of o', I decoupled). The wheel's contact point is at rest, its top at 0.9c.
Tolerance per pixel: |dD| <= |grad_u D| |du| + 1e-5 D (float32), |du| the sum of: a piece
moves along its chord, within half its turn theta of the tangent (1.1 |v| theta / 2, 10 %
for the chord's shorter length) and within R_orbit theta^2 / 8 of the circle (times the
moon's own turn rate, as an error of x - o); the turn part is omega x r within 5e-5
relative (tan(delta)/delta at the probes' spacing plus their interpolation tolerance:
tests/rendering/test_rotational_doppler.py). theta is 0 for the wheel's straight path.
The wheel is per-vertex worldlines (Unreleased, spacetime/turning.py): its chords' velocities
are within VELOCITY_TOLERANCE of the probes', which turn from USD's by at most one probe
interval's turn x omega |r|.
"""
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import warp_st
from warp_st.core import lorentz
from warp_st.core.lorentz import contraction_matrix
from warp_st.rendering.camera import pixel_directions
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.turning import VELOCITY_TOLERANCE, is_worldlines

from animation_stages import hit_events

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "animation"
W, H = 96, 54


def _usd_point_velocity(stage, prim, t, x, decoupled, step=1e-4):
    """u of the module docstring for the hit event (t, x)."""
    xformable = UsdGeom.Xformable(stage.GetPrimAtPath(prim))

    def world(time):
        return np.array(xformable.ComputeLocalToWorldTransform(Usd.TimeCode(float(time))), dtype=np.float64)

    start = np.linalg.inv(world(stage.GetStartTimeCode()))
    pivot = world(t)[3, :3]
    velocity = (world(t + step)[3, :3] - world(t - step)[3, :3]) / (2 * step)
    linear = (start @ world(t))[:3, :3]
    rate = ((start @ world(t + step)) - (start @ world(t - step)))[:3, :3] / (2 * step)
    a = contraction_matrix(velocity, decoupled)
    r = (x - pivot) @ np.linalg.inv(a) @ np.linalg.inv(linear)
    return velocity, velocity + r @ rate @ a


@pytest.mark.parametrize("name, prim, frame, speed", [("rolling_wheel", "/Wheel", 56.0, 0.45),
                                                      ("circular_orbit", "/Orbit/Moon", 40.0, 0.8)])
def test_animated_pixels_carry_their_points_doppler(name, prim, frame, speed):
    path = str(EXAMPLES / f"{name}.usda")
    scene = warp_st.load(path)
    index = scene.body_paths().index(prim)
    body = scene.bodies[index]
    renderer = Renderer(scene, frames=[frame], width=W, height=H)
    image = renderer.render(frame)
    (cuts,) = [rows for i, rows in renderer.animation if i == index]
    spin = speed / 5.0 if name == "circular_orbit" else 0.0  # the orbit's turn rate, rad per time
    worldlines = is_worldlines(cuts)  # the wheel (Unreleased): per-vertex worldlines, the moon (a Sphere) pieces
    assert worldlines is (name == "rolling_wheel")
    theta = 0.0 if worldlines else spin * max(b[0] - a[0] for a, b in zip(cuts, cuts[1:]) if not np.isinf(b[2]))
    mine = image.object_id == index + 1
    assert mine.sum() > 30
    times, points, _s = hit_events(scene, image, frame, W, H)
    hit = image.object_id[image.object_id > 0] == index + 1
    n = pixel_directions(scene.camera_state(None, frame), W, H, frame="lab")[mine]
    stage = Usd.Stage.Open(path)
    pairs = [_usd_point_velocity(stage, prim, t, x, body.decoupled) for t, x in zip(times[hit], points[hit])]
    v, u = (np.array(column) for column in zip(*pairs))
    assert np.allclose(np.linalg.norm(v, axis=1), speed, atol=1e-6)
    expected = lorentz.doppler(n, u, body_decoupled=body.decoupled)
    g2 = 1.0 if body.decoupled else 1.0 / (1.0 - np.einsum("ij,ij->i", u, u))
    grad = expected * np.linalg.norm(g2[:, None] * u * (0.0 if body.decoupled else 1.0)
                                     + n / (1.0 + np.einsum("ij,ij->i", n, u))[:, None], axis=1)
    du = 1.1 * speed * theta / 2.0 + spin * 5.0 * theta ** 2 / 8.0 + 5e-5 * np.linalg.norm(u - v, axis=1)
    if worldlines:  # the chords' velocity rule, plus the turn of USD's velocity over one probe interval
        turn = float(np.linalg.norm(np.diff(body.motion.linear, axis=0), ord=2, axis=(1, 2)).max())
        du = du + VELOCITY_TOLERANCE + turn * np.linalg.norm(u - v, axis=1)
    bound = grad * du + 1e-5 * expected
    err = np.abs(image.doppler[mine] - expected)
    assert (err <= bound).all(), float((err / bound).max())
    if name == "rolling_wheel":  # the top (0.9c) and the contact point (at rest) are seen
        assert np.linalg.norm(u, axis=1).max() > 0.85 and np.linalg.norm(u, axis=1).min() < 0.1


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


def test_rolling_wheel_08c_is_its_script_and_rolls_in_its_rest_frame():
    """examples/animation/rolling_wheel_08c.usda is what rolling_wheel_08c.py writes, and (read
    by USD alone: loading it boosts ~5,000 points, ~35 s, docs/design/rolling-wheel.md) its
    wheel is animated in its rest frame at 0.8c, spinning at w' = v / R: rolling without
    slipping in the axle's frame."""
    import runpy

    from pxr import Usd

    script = runpy.run_path(str(EXAMPLES / "rolling_wheel_08c.py"))
    assert (EXAMPLES / "rolling_wheel_08c.usda").read_text() == script["stage_text"]()
    stage = Usd.Stage.Open(str(EXAMPLES / "rolling_wheel_08c.usda"))  # held: a prim of a freed stage is invalid
    wheel = stage.GetPrimAtPath("/Wheel")
    assert wheel.GetAttribute("spacetime:animationFrame").Get() == "rest"
    u = wheel.GetAttribute("spacetime:fourVelocity").Get()
    v = u[1] / u[0]
    spin = wheel.GetAttribute("xformOp:rotateZ")
    rate = np.radians(spin.Get(1.0) - spin.Get(0.0))  # per rest time code
    radius = float(wheel.GetAttribute("xformOp:translate").Get()[1])  # the axle's height
    assert v == 0.8 and abs(rate + v / radius) < 1e-9
