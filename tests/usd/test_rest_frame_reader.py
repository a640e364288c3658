"""Bodies animated in their own rest frame (``spacetime:animationFrame = "rest"``, docs/spec.md
§2.1, addition 0.7.0): what the reader hands the deforming path.

Laws:
- each vertex's lab worldline (the renderer's own ``points_at``: the lab samples plus the
  uniform motion) is the Lorentz boost of its rest-frame rotation (float64 closed form,
  ``tests/rest_frame_stages.py``) at random vertices and rest times;
- the wheel rolling without slipping at v = 0.8: its top moves at 2v / (1 + v^2) in the lab
  (not 2v), its contact point is at rest on the ground;
- "lab" (the fallback) reads the animation as before; a bad token, "rest" on a decoupled
  body, and a point at >= c in the rest frame are one-line errors naming the attribute.
"""
import numpy as np
import pytest

import warp_st
from warp_st.core.scene import SceneError
from warp_st.spacetime.deform import points_at

from animation_stages import write
from rest_frame_stages import PHASE, PIVOT, R, V, OMEGA, lab_event, rest_vertices, wheel_stage

#: The bound of the lab worldlines against the closed form: the rest samples follow USD's
#: rotation within PROBE_TOLERANCE (1e-5) x (1 + |p|) <= 2.7e-5 (|p| <= 1.7), which the
#: boost amplifies at most by 1 / (1 - v |u'|) = 2.8 (u' = 0.8 the rim speed in S'); the
#: common lab times follow each boosted polyline within REST_LAB_TOLERANCE x size = 2e-4
#: (size 2, the rest wheel's diameter). 7.6e-5 + 2e-4 < 3e-4.
BOUND = 3e-4


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    scene = warp_st.load(write(tmp_path_factory.mktemp("wheel"), "wheel.usda", wheel_stage(caps=False)))
    return scene.bodies[0]


def test_lab_worldlines_are_the_boosted_rest_rotation(wheel):
    """400 random (vertex, rest time t' in [-8, 8]) pairs: the closed-form lab event (t, x)
    against the renderer's position of that vertex at lab time t."""
    rng = np.random.default_rng(18)
    r = rest_vertices()
    assert wheel.decoupled and wheel.surfaces[0].samples is not None  # a deforming body: lab positions
    errors = []
    for j, t_rest in zip(rng.integers(0, len(r), 400), rng.uniform(-8.0, 8.0, 400)):
        event = lab_event(r[j], t_rest)
        errors.append(np.linalg.norm(points_at(wheel, event[0])[j] - event[1:]))
    assert max(errors) <= BOUND, max(errors)


def _lab_velocity(body, j: int, t: float, h: float = 0.05) -> np.ndarray:
    return (points_at(body, t + h)[j] - points_at(body, t - h)[j]) / (2.0 * h)


def test_top_at_2v_over_1_plus_v2_and_contact_point_at_rest(wheel):
    """Vertex 0 (angle PHASE at t' = 0) passes the top at w' t' = PHASE - pi/2 ... and the
    bottom half a turn later. Central differences over h = 0.05 of worldlines within BOUND:
    a velocity error <= 2 BOUND / (2 h) = 6e-3, plus the curve's third derivative x h^2 / 6
    (< 1e-3 for w' = 0.8); so 1e-2. The lab top speed 0.9756 is neither 2v = 1.6 (the §2.1
    "lab" convention) nor v."""
    r0 = rest_vertices()[0]
    for turn in (0, 1):
        t_top = (PHASE - np.pi / 2 + 2 * np.pi * turn) / OMEGA  # Rot(-w' t') takes angle PHASE to pi/2
        top = lab_event(r0, t_top)
        assert abs(top[2] - (PIVOT[1] + R)) < 1e-12  # the oracle's own top
        u = _lab_velocity(wheel, 0, top[0])
        assert np.abs(u - (2 * V / (1 + V * V), 0.0, 0.0)).max() <= 1e-2, u
        bottom = lab_event(r0, t_top + np.pi / OMEGA)
        assert abs(bottom[2] - (PIVOT[1] - R)) < 1e-12
        assert np.abs(_lab_velocity(wheel, 0, bottom[0])).max() <= 1e-2
        assert abs(points_at(wheel, bottom[0])[0][1] - (PIVOT[1] - R)) <= BOUND  # on the ground


def test_lab_frame_is_the_fallback(tmp_path):
    """Without the attribute (or with "lab") the same stage is §2.1's lab-frame animation, in
    which this wheel's rim moves at v + A (w x r) = 0.8 + 0.6 x 0.8 = 1.28c: bad input; not
    spinning, it is a rigid animated body (not a deforming one)."""
    for attrs in ("", 'custom uniform token spacetime:animationFrame = "lab"'):
        with pytest.raises(SceneError, match=r"/Wheel: xformOp:rotateZ: a point of the animated body moves at 1\.28"):
            warp_st.load(write(tmp_path, "lab.usda", wheel_stage(frame_attrs=attrs)))
        body = warp_st.load(write(tmp_path, "lab.usda", wheel_stage(frame_attrs=attrs, spin=False))).bodies[0]
        assert body.motion is not None and body.surfaces[0].samples is None and not body.decoupled


@pytest.mark.parametrize("attrs, attribute, match", [
    ('custom uniform token spacetime:animationFrame = "axle"', "spacetime:animationFrame", "must be one of lab, rest"),
    ('custom uniform token spacetime:animationFrame = "rest"\n    custom bool spacetime:lorentzDecoupled = true',
     "spacetime:animationFrame", "needs a Lorentz-coupled body"),
    ('custom uniform token spacetime:animationFrame = "rest"\n    double xformOp:rotateX.timeSamples = { 0: 0, 1: 60 }',
     "xformOp:rotateZ", r"a point of the body moves at 1\.\d+ c in its rest frame .* between time codes 0 and 1 "),
])
def test_bad_rest_frame_input(tmp_path, attrs, attribute, match):
    """The third: a faster spin (rotateZ samples of 0.8 rad per time code plus 60 degrees per
    time code about X in the last interval: the rim reaches ~1.3c)."""
    text = wheel_stage(frame_attrs=attrs, caps=False)
    if "rotateX" in attrs:  # the extra op goes into the order: it spins the rim faster in S'
        text = text.replace('["xformOp:translate", "xformOp:rotateZ"]',
                            '["xformOp:translate", "xformOp:rotateZ", "xformOp:rotateX"]')
    path = write(tmp_path, "bad.usda", text)
    with pytest.raises(SceneError, match=match) as err:
        warp_st.load(path)
    assert f"bad.usda: /Wheel: {attribute}:" in str(err.value)
    assert "\n" not in str(err.value)
