"""Turning rigid bodies as per-vertex worldlines (spacetime/turning.py, docs/spec.md §2.1 0.8.0).

Oracles: USD's own ComputeLocalToWorldTransform at every sample time and at dense times
between them (the chords' error bound), finite differences of it (the chords' velocities),
and the index order the prisms' tetrahedra are split by (watertightness)."""
from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

import warp_st
from warp_st.core.lorentz import contraction_matrix
from warp_st.rendering.camera import pixel_directions
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.animation import animated_bodies, animation_cuts, body_radius, piece_count
from warp_st.spacetime import turning
from warp_st.spacetime.turning import VELOCITY_TOLERANCE, is_worldlines, worldline_body, worldline_count

from animation_stages import CUBE, HEADER, orbit, orbit_degrees, spinning_rod, write

SIZE = dict(width=160, height=90)


def _rolling(decoupled: bool) -> str:
    coupling = "custom bool spacetime:lorentzDecoupled = true" if decoupled else ""
    return HEADER + f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    {coupling}
    double3 xformOp:translate.timeSamples = {{ 0: (-5, 0, 0), 100: (5, 0, 0) }}
    double xformOp:rotateZ.timeSamples = {{ 0: 0, 100: -300 }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    {CUBE}
}}
'''


def _sliding() -> str:
    return HEADER + f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate.timeSamples = {{ 0: (-5, 0, 0), 100: (5, 0, 0) }}
    uniform token[] xformOpOrder = ["xformOp:translate"]
    {CUBE}
}}
'''


@pytest.mark.parametrize("text, expected", [
    (spinning_rod(0.7), True),  # coupled, its pivot at rest: A(v) = I
    (_rolling(True), True),  # decoupled: A = I whatever the pivot does
    (_rolling(False), True),  # coupled on a moving pivot: A(v(s_k)) in the points, the pivot's clock (Unreleased)
    (_sliding(), False),  # translation only: the pieces are continuous
    # a lone analytic sphere: the rigid path's exact shape
    (orbit('def Sphere "Ball"\n    {\n        double radius = 0.5\n    }'), False),
    # a sphere beside a mesh: the pieces' adaptive sphere (its triangles at every probe cost too much)
    (orbit('def Sphere "Ball"\n    {\n        double radius = 0.5\n    }\n' + CUBE, decoupled=False), False),
    # a cylinder beside a mesh (never exact): its triangles, worldlines (the rolling wheel's tyre)
    (orbit('def Cylinder "Tyre"\n    {\n        double radius = 0.5\n        double height = 0.2\n    }\n'
           + CUBE, decoupled=False), True),
])
def test_which_bodies_are_traced_as_worldlines(tmp_path, text, expected):
    scene = warp_st.load(write(tmp_path, "s.usda", text))
    (body,) = [b for b in scene.bodies if b.motion is not None]
    assert worldline_body(body) is expected
    cam = scene.camera_state(None, 50.0)
    (_i, cuts), = animation_cuts(scene, [cam], worldlines=True, **SIZE)
    assert is_worldlines(cuts) is expected
    # the default path: float32 keeps the rigid path, the worldline body its tetrahedra leaves
    # (spacetime/mixed.py); float64 goes to the tetrahedral path
    r = Renderer(scene, frames=[50.0], **SIZE)
    assert r.primitive == "rigid" and (r.stats.tetrahedra > 0) is expected
    assert (Renderer(scene, frames=[50.0], precision="float64", **SIZE).primitive == "tet") is expected


def _usd_points(path: str, gprim: str, local: np.ndarray, t: float) -> np.ndarray:
    stage = Usd.Stage.Open(path)
    m = UsdGeom.Xformable(stage.GetPrimAtPath(gprim)).ComputeLocalToWorldTransform(Usd.TimeCode(t))
    return np.array([m.Transform(Gf.Vec3d(*p)) for p in local.tolist()])


@pytest.mark.parametrize("velocities", [True, False])
def test_worldlines_follow_usd_within_the_tolerances(tmp_path, monkeypatch, velocities):
    """Every vertex at every sample time is USD's point (to the probes' 1e-5), between the
    samples its chord stays within a quarter pixel of USD's path, and its chord velocity
    within VELOCITY_TOLERANCE of USD's plus the probes' own chord error (how much USD's
    velocity turns over one probe interval). Without the velocity rule (which binds for
    the 0.7c tips: ~ every probe) the chords' second-order error alone needs far fewer
    samples than the pieces' held orientations."""
    if not velocities:
        monkeypatch.setattr(turning, "VELOCITY_TOLERANCE", np.inf)
    path = write(tmp_path, "rod.usda", spinning_rod(0.7))
    scene = warp_st.load(path)
    cams = [scene.camera_state(None, f) for f in (30.0, 60.0)]
    (i, cuts), = animation_cuts(scene, cams, worldlines=True, **SIZE)
    (_j, pieces), = animation_cuts(scene, cams, **SIZE)
    assert 10 < worldline_count(cuts) <= len(scene.bodies[i].motion.times) - 1  # at most every probe interval
    assert piece_count(pieces) > 10
    if not velocities:
        assert worldline_count(cuts) < piece_count(pieces) / 10
    rod = [b for b in animated_bodies(scene, ((i, cuts),))[0] if b.prim_path == "/Rod"]
    assert len(rod) == 1 and rod[0].seam == 0.0 and rod[0].motion is None
    (surface,) = rod[0].surfaces
    samples = surface.samples
    assert len(samples.times) == worldline_count(cuts) + 1
    # the unshared corners, back in the Bar's unit cube (the Bar scales it by (4, 0.4, 0.4))
    local = (np.asarray(surface.points) - scene.bodies[i].motion.static_pivot) / np.array([4.0, 0.4, 0.4])
    assert np.allclose(np.abs(local), 0.5)
    radius = body_radius(scene.bodies[i])
    for k in range(0, len(samples.times), 37):
        t = float(samples.times[k])
        np.testing.assert_allclose(samples.points[k], _usd_points(path, "/Rod/Bar", local, t),
                                   atol=2e-5 * (1.0 + radius))  # the probes follow USD within 1e-5 (1 + |p|)
    # Between samples: the chord against USD at 9 times per interval, within half of half a
    # pixel (the tetrahedra take the other half) at the nearest the cameras see the rod
    # (their distance to the pivot less the radius), plus the probes' 1e-5 (1 + |p|) of USD.
    n = pixel_directions(cams[0], SIZE["width"], SIZE["height"])
    angle = float(np.arccos(np.clip(np.sum(n[45, 80] * n[45, 81]), -1.0, 1.0)))  # a centre pixel's
    near = min(float(np.linalg.norm(c.position - scene.bodies[i].motion.static_pivot)) for c in cams) - radius
    tol = 0.25 * angle * near + 2e-5 * (1.0 + radius)
    probe = float(np.diff(scene.bodies[i].motion.times).max())

    def usd_velocity(t, h=1e-4):
        return (_usd_points(path, "/Rod/Bar", local, t + h) - _usd_points(path, "/Rod/Bar", local, t - h)) / (2 * h)

    worst = 0.0
    for k in range(1, len(samples.times) - 2, 97 if velocities else 1):  # USD holds outside: no finite difference there
        a, b = float(samples.times[k]), float(samples.times[k + 1])
        for f in np.linspace(0.1, 0.9, 9):
            t = a + f * (b - a)
            worst = max(worst, float(np.linalg.norm(samples.at(t) - _usd_points(path, "/Rod/Bar", local, t),
                                                    axis=1).max()))
        chord = (samples.points[k + 1] - samples.points[k]) / (b - a)
        # the probes' own chords turn from USD's velocity by at most its change over one probe interval
        slack = float(np.linalg.norm(usd_velocity(a + probe) - usd_velocity(a), axis=1).max())
        for t in (a, 0.5 * (a + b), b) if velocities else ():
            # 1e-6: the finite difference's error (h^2 w^3 R / 6 ~ 1e-10 here) and rounding
            assert np.linalg.norm(chord - usd_velocity(t), axis=1).max() <= VELOCITY_TOLERANCE + slack + 1e-6
    assert 0.0 < worst <= tol, worst


def test_unshared_corners_keep_every_triangles_order(tmp_path):
    """The flat box gets a copy of its corners per triangle, numbered so that every
    triangle's corners keep their order (the prisms' tetrahedra split their shared sides
    by it: the tube stays watertight), and at the same places."""
    scene = warp_st.load(write(tmp_path, "rod.usda", spinning_rod(0.7)))
    body = scene.bodies[[b.prim_path for b in scene.bodies].index("/Rod")]
    cam = scene.camera_state(None, 30.0)
    (_i, cuts), = animation_cuts(scene, [cam], worldlines=True, **SIZE)
    (rod,) = [b for b in animated_bodies(scene, ((scene.bodies.index(body), cuts),))[0] if b.prim_path == "/Rod"]
    old, new = body.surfaces[0], rod.surfaces[0]
    tri_old, tri_new = np.asarray(old.triangles), np.asarray(new.triangles)
    assert len(new.points) == 3 * len(tri_old)
    assert np.bincount(tri_new.reshape(-1)).max() == 1  # no corner shared
    np.testing.assert_array_equal(np.asarray(new.points)[tri_new], np.asarray(old.points)[tri_old])
    np.testing.assert_array_equal(np.argsort(tri_new, axis=1), np.argsort(tri_old, axis=1))


def test_exact_quadrics_asked_for_keep_the_pieces(tmp_path):
    """Exact quadrics are the rigid path's: a scene with a turning body asked for them renders
    its pieces there (not an error of the tetrahedral path)."""
    scene = warp_st.load(write(tmp_path, "rod.usda", spinning_rod(0.7)))
    r = Renderer(scene, frames=[30.0], quadrics="exact", **SIZE)
    assert r.primitive == "rigid"
    assert not any(is_worldlines(cuts) for _i, cuts in r.animation)


def _counter_orbit() -> str:
    """A coupled box on a circular orbit at 0.8c whose own rotateY undoes 0.9 of the orbit's:
    it turns slowly in the lab (0.1 of the orbit's rate) while the direction of its pivot's
    velocity turns with the orbit, so its contraction A(v(t)), not its orientation L(t),
    sets the chords' error."""
    degrees = orbit_degrees(0.8, 5.0, 100.0)
    return HEADER + f'''def Xform "Orbit"
{{
    double xformOp:rotateY.timeSamples = {{ 0: 0, 100: {degrees!r} }}
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Xform "Moon" (prepend apiSchemas = ["SpacetimeBodyAPI"])
    {{
        double3 xformOp:translate = (5, 0, 0)
        double xformOp:rotateY.timeSamples = {{ 0: 0, 100: {-0.9 * degrees!r} }}
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
        {CUBE}
    }}
}}
'''


def _contracted_usd(path: str, local: np.ndarray, t: float, h: float = 1e-4) -> np.ndarray:
    """§2.1's coupled world points of the box's authored points ``local`` at lab time t:
    USD's rest placement, contracted about the pivot (USD's origin of /Orbit/Moon) along
    the pivot's velocity (a central difference of USD's: the tangent of the circle; one-sided
    at the first and last time code, where USD holds: the inside's, as the samples take it)."""
    stage = Usd.Stage.Open(path)
    moon = UsdGeom.Xformable(stage.GetPrimAtPath("/Orbit/Moon"))

    def origin(time):
        return np.array(moon.ComputeLocalToWorldTransform(Usd.TimeCode(time)).ExtractTranslation())

    o = origin(t)
    lo, hi = max(t - h, 0.0), min(t + h, 100.0)
    v = (origin(hi) - origin(lo)) / (hi - lo)
    a = contraction_matrix(v, False)
    return o + (_usd_points(path, "/Orbit/Moon/Box", local, t) - o) @ a


@pytest.mark.parametrize("velocities", [True, False])
def test_coupled_worldlines_follow_the_contracted_usd_path(tmp_path, monkeypatch, velocities):
    """A coupled body turning on a moving pivot (spacetime/turning.py, Unreleased): every
    vertex at every sample time is USD's point contracted along the pivot's velocity (to the
    probes' 1e-5 and the chords' velocity against the circle's tangent, 1e-4 in all), and
    between the samples its chord stays within a quarter pixel of that path (plus the same
    1e-4). Without the velocity rule the position rule alone sets the samples: then the
    contraction's change is what the bound must hold (it fails with the contraction left
    out of the rule)."""
    if not velocities:
        monkeypatch.setattr(turning, "VELOCITY_TOLERANCE", np.inf)
        monkeypatch.setattr(turning, "TAU_RATE_TOLERANCE", np.inf)
    path = write(tmp_path, "orbit.usda", _counter_orbit())
    scene = warp_st.load(path)
    cams = [scene.camera_state(None, f) for f in (30.0, 60.0)]
    (i, cuts), = animation_cuts(scene, cams, worldlines=True, **SIZE)
    assert is_worldlines(cuts) and turning.moving_pivot(scene.bodies[i])
    (moon,) = [b for b in animated_bodies(scene, ((i, cuts),))[0] if b.surfaces[0].samples is not None]
    (surface,) = moon.surfaces
    samples = surface.samples
    assert moon.clock is not None and not moon.velocity.any()
    local = np.asarray(surface.points) - scene.bodies[i].motion.static_pivot  # the Cube's own (size 1.2)
    assert np.allclose(np.abs(local), 0.6)
    for k in [*range(0, len(samples.times), 7), len(samples.times) - 1]:
        t = float(samples.times[k])
        # the first and last samples take the one-sided chord's velocity (the inside's), turned
        # from the circle's tangent by half a probe interval's turn (0.16 x ~0.05 / 2 rad): A
        # differs by at most 2 (1 - 1 / gamma) x that, 3e-3 x |r| (9.4e-4 measured at the corners)
        ends = k in (0, len(samples.times) - 1)
        np.testing.assert_allclose(samples.points[k], _contracted_usd(path, local, t), atol=3e-3 if ends else 1e-4)
    radius = body_radius(scene.bodies[i])
    n = pixel_directions(cams[0], SIZE["width"], SIZE["height"])
    angle = float(np.arccos(np.clip(np.sum(n[45, 80] * n[45, 81]), -1.0, 1.0)))
    motion = scene.bodies[i].motion

    def quarter_pixel(a, b):  # at the nearest any camera sees the body in [a, b]: its pivot's distance less R
        pivot = motion.pivot[(motion.times >= a) & (motion.times <= b)]
        return 0.25 * angle * (min(float(np.linalg.norm(pivot - c.position, axis=1).min()) for c in cams) - radius)

    worst = 0.0  # the largest error as a fraction of its interval's quarter pixel
    for k in range(0, len(samples.times) - 1, 5 if velocities else 1):
        a, b = float(samples.times[k]), float(samples.times[k + 1])
        tol = quarter_pixel(a, b) + 1e-4
        for f in np.linspace(0.1, 0.9, 9):
            t = a + f * (b - a)
            error = float(np.linalg.norm(samples.at(t) - _contracted_usd(path, local, t), axis=1).max())
            worst = max(worst, error / tol)
    assert 0.0 < worst <= 1.0, worst


def _speeding_up() -> str:
    """A coupled box turning slowly while its pivot speeds up smoothly from 0.88c to 0.9c
    (a translate sample every time code): 1 / gamma changes by ~2 x its speed's change."""
    xs = ", ".join(f"{t}: ({0.88 * t + 1e-4 * t * t!r}, 0, -30)" for t in range(101))
    return HEADER + f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double spacetime:referenceTime = 10
    double3 xformOp:translate.timeSamples = {{ {xs} }}
    double xformOp:rotateZ.timeSamples = {{ 0: 0, 100: -20 }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    {CUBE}
}}
'''


def test_the_pivots_proper_time_is_linear_between_samples_within_the_rule(tmp_path):
    """Between two samples the kernel takes the pivot's proper time linearly (between the
    slices, which the samples are among); the sample rule keeps the probes' 1 / gamma within
    TAU_RATE_TOLERANCE of each chord's mean, so the chord errs by at most that x the time to
    the nearer sample. Checked at every probe against the closed form of the probes'
    integral (USD's linear interpolation: 1 / gamma constant per time code). It fails without
    the rule (the velocity rule alone lets a chord span ~20 time codes here)."""
    scene = warp_st.load(write(tmp_path, "speeding.usda", _speeding_up()))
    cams = [scene.camera_state(None, 50.0)]
    (i, cuts), = animation_cuts(scene, cams, worldlines=True, **SIZE)
    body = scene.bodies[i]
    times, tau = turning.pivot_clock(body)
    codes = np.arange(101.0)
    inv_gamma = np.sqrt(1.0 - (0.88 + 2e-4 * (codes[:-1] + 0.5)) ** 2)  # each time code's chord speed
    closed = np.concatenate([[0.0], np.cumsum(inv_gamma)])
    np.testing.assert_allclose(np.interp(times, codes, closed) - np.interp(10.0, codes, closed), tau, atol=1e-9)
    samples = np.concatenate([np.asarray(run) for run in cuts[1:]])
    assert len(samples) > 3
    worst = 0.0
    for a, b in zip(samples[:-1], samples[1:]):
        inside = (times > a) & (times < b)
        chord = np.interp(times[inside], [a, b], np.interp([a, b], times, tau))
        room = np.minimum(times[inside] - a, b - times[inside])
        if inside.any():
            worst = max(worst, float((np.abs(tau[inside] - chord) / room).max()))
    assert worst <= 5e-4 + 1e-9, worst  # TAU_RATE_TOLERANCE as documented (docs/spec.md §2.1)


def test_a_slow_turn_on_a_fast_uniform_pivot_is_not_sampled_at_every_probe(tmp_path):
    """A coupled box sliding at 0.8c while turning 30 degrees over its 100 time codes: its
    contraction A(v) is constant, so USD's contracted path is L(t) A and the chords' position
    rule measures against that. Their samples are fewer than the probes (32 of 64 intervals
    measured); with the contraction left out of the rule's bound (L(t) against the chords'
    L A), every chord misses by R (1 - 1 / gamma) and every probe is a sample (64)."""
    text = HEADER + f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate.timeSamples = {{ 0: (-40, 0, 0), 100: (40, 0, 0) }}
    double xformOp:rotateZ.timeSamples = {{ 0: 0, 100: -30 }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    {CUBE}
}}
'''
    scene = warp_st.load(write(tmp_path, "slide.usda", text))
    cams = [scene.camera_state(None, f) for f in (30.0, 60.0)]
    (i, cuts), = animation_cuts(scene, cams, worldlines=True, **SIZE)
    assert is_worldlines(cuts) and turning.moving_pivot(scene.bodies[i])
    probes = len(scene.bodies[i].motion.times) - 1
    assert worldline_count(cuts) <= 0.75 * probes, (worldline_count(cuts), probes)
