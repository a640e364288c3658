"""Primary-ray coverage of a fast-turning body (issue 18: "no coverage errors against a
brute-force march away from the silhouette"). examples/animation/spinning_rod.usda's rod,
its tips at 0.7c, is traced as per-vertex worldlines (spacetime/turning.py): watertight, so
no ray slips between held orientations (the pieces showed 5 and 7 holes at these frames).

Oracle: a float64 march of every pixel's primary ray (finite c: the event at distance s
is at lab time t_c - s) through the closed-form rotating box, checked against USD's
ComputeLocalToWorldTransform. A pixel is the rod's when the march meets the box shrunk by
TOL, and not when it misses the box grown by TOL (TOL = 0.01 > the half-pixel modelling
error, ~0.004 at the rod here); a march-silhouette pixel is one the two disagree on, or
whose 3 x 3 neighbours the shrunk march does not agree on; "away from the silhouette" is
not within 1 px of one. The same march checks the rod's shadow on the floor (no light
specks through seams) and the rod's Doppler.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

import warp_st
from warp_st.rendering.camera import pixel_directions

ROD = Path(__file__).resolve().parents[2] / "examples" / "animation" / "spinning_rod.usda"
RATE = 2005.3522829578812 / 100.0  # degrees per time code (the stage's rotateY samples)
HALF = np.array([2.0, 0.15, 0.15])  # the bar: a unit cube scaled (4, 0.3, 0.3), centred at (0, 1, 0)
TOL = 0.01


def _rod_coordinates(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """World points at lab times t in the bar's axes, closed form."""
    th = np.radians(RATE * t)
    c, s = np.cos(th), np.sin(th)
    q = p - np.array([0.0, 1.0, 0.0])
    return np.stack([q[..., 0] * c - q[..., 2] * s, q[..., 1], q[..., 0] * s + q[..., 2] * c], axis=-1)


def _march(cam, width: int, height: int, frame: float, grow: float) -> np.ndarray:
    """(H, W) bool: the primary ray meets the box grown by ``grow`` (negative: shrunk),
    sampled every ~1e-3 along the slab of the bar's y extent (the only place it can be)."""
    n = pixel_directions(cam, width, height).reshape(-1, 3).astype(np.float64)
    c = np.asarray(cam.position, dtype=np.float64)
    lo, hi = 1.0 - HALF[1] - abs(grow), 1.0 + HALF[1] + abs(grow)
    with np.errstate(divide="ignore"):
        s0, s1 = (hi - c[1]) / n[:, 1], (lo - c[1]) / n[:, 1]
    s0, s1 = np.minimum(s0, s1), np.maximum(s0, s1)
    f = np.linspace(0.0, 1.0, 512)
    out = np.zeros(len(n), bool)
    for a in range(0, len(n), 4096):
        s = s0[a:a + 4096, None] + f[None] * (s1 - s0)[a:a + 4096, None]
        q = np.abs(_rod_coordinates(c + s[..., None] * n[a:a + 4096, None, :], frame - s))
        out[a:a + 4096] = (q <= HALF + grow).all(-1).any(1)
    return out.reshape(height, width)


@pytest.mark.parametrize("frame", [30.0, 45.0])
def test_spinning_rod_has_no_holes_or_extras_away_from_the_silhouette(frame):
    stage = Usd.Stage.Open(str(ROD))
    bar = UsdGeom.Xformable(stage.GetPrimAtPath("/Rod/Bar"))
    for t in (0.0, 13.37, frame - 7.5):  # the closed form is USD's
        p = np.array(bar.ComputeLocalToWorldTransform(Usd.TimeCode(t)).Transform(Gf.Vec3d(0.3, -0.2, 0.4)))
        np.testing.assert_allclose(_rod_coordinates(p, t), [1.2, -0.06, 0.12], atol=1e-9)

    width, height = 320, 180
    scene = warp_st.load(str(ROD))
    image = warp_st.render(scene, frame=frame, width=width, height=height)
    rod_id = 1 + [b.prim_path for b in scene.bodies].index("/Rod")
    rendered = image.object_id == rod_id
    cam = scene.camera_state(None, frame)
    inside, outside = _march(cam, width, height, frame, -TOL), ~_march(cam, width, height, frame, TOL)
    edge = ~(inside | outside)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            edge |= np.roll(inside, (dy, dx), (0, 1)) != inside
    away = ~edge
    for dy in (-1, 0, 1):  # not within 1 px of a silhouette pixel
        for dx in (-1, 0, 1):
            away &= ~np.roll(edge, (dy, dx), (0, 1))
    assert (away & inside).sum() > 1000  # the rod's interior: ~2,000 pixels here
    holes = away & inside & ~rendered
    extras = away & outside & rendered
    assert holes.sum() == 0, np.argwhere(holes)[:10].tolist()
    assert extras.sum() == 0, np.argwhere(extras)[:10].tolist()


def _world(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The inverse of ``_rod_coordinates``."""
    th = np.radians(RATE * t)
    c, s = np.cos(th), np.sin(th)
    return np.stack([q[..., 0] * c + q[..., 2] * s, q[..., 1] + 1.0, -q[..., 0] * s + q[..., 2] * c], axis=-1)


def test_spinning_rod_doppler_follows_the_closed_form():
    """The worldlines' points emit with their chords' velocities (the coupled rod: with
    gamma of their own speed): D = 1 / (gamma_u (1 + n.u)) for the camera at rest, u the
    closed-form velocity of the rod point at the hit event (tips at 0.7c: D from ~0.55 to
    ~1.1). Tolerance 5e-3: the chords' velocities are within VELOCITY_TOLERANCE (2e-3) of
    the probes', whose own chords turn from USD's tangent by up to half its change over a
    probe interval (~3e-3 here); dD ~ D^2 gamma |du| (measured: 1.3e-3 at 320 x 180)."""
    width, height, frame = 160, 90, 30.0
    scene = warp_st.load(str(ROD))
    image = warp_st.render(scene, frame=frame, width=width, height=height, doppler_color=True)
    rod = image.object_id == 1 + [b.prim_path for b in scene.bodies].index("/Rod")
    assert rod.sum() > 200
    cam = scene.camera_state(None, frame)
    n = pixel_directions(cam, width, height)[rod].astype(np.float64)
    t = image.event_time[rod].astype(np.float64)
    q = _rod_coordinates(np.asarray(cam.position, dtype=np.float64) + (frame - t)[:, None] * n, t)
    u = (_world(q, t + 1e-6) - _world(q, t - 1e-6)) / 2e-6
    expected = np.sqrt(1.0 - np.einsum("ij,ij->i", u, u)) / (1.0 + np.einsum("ij,ij->i", n, u))
    assert np.ptp(expected) > 0.3  # the rotation's Doppler is in view
    err = np.abs(image.doppler[rod].astype(np.float64) - expected)
    assert err.max() <= 5e-3, float(err.max())


def test_spinning_rod_shadow_on_the_floor_has_no_light_specks():
    """Every floor pixel's shadow ray (towards the sun, back in time: finite c) marched in
    float64 through the closed-form box: where it crosses the box shrunk by TOL the floor
    must be dark, where it misses the box grown by TOL lit (the pieces let 19 rays through
    their seams here: light specks in the rod's shadow). Dark: under half the lit floor's
    brightness (the floor is flat and the sun distant: one brightness where lit)."""
    width, height, frame = 320, 180, 30.0
    scene = warp_st.load(str(ROD))
    image = warp_st.render(scene, frame=frame, width=width, height=height)
    floor = image.object_id == 1 + [b.prim_path for b in scene.bodies].index("/Ground")
    cam = scene.camera_state(None, frame)
    t = image.event_time[floor].astype(np.float64)
    x = np.asarray(cam.position, dtype=np.float64) + (frame - t)[:, None] * pixel_directions(cam, width, height)[floor]
    sun = np.asarray(scene.lights[0].direction, dtype=np.float64)
    # the ray can meet the bar only inside its slab of y (sun[1] > 0: the sun is up)
    u0, u1 = (1.0 - HALF[1] - TOL - x[:, 1]) / sun[1], (1.0 + HALF[1] + TOL - x[:, 1]) / sun[1]
    f = np.linspace(0.0, 1.0, 400)
    blocked, near = np.zeros(len(x), bool), np.zeros(len(x), bool)
    for a in range(0, len(x), 2000):
        u = u0[a:a + 2000, None] + f[None] * (u1 - u0)[a:a + 2000, None]
        q = np.abs(_rod_coordinates(x[a:a + 2000, None, :] + u[..., None] * sun, t[a:a + 2000, None] - u))
        blocked[a:a + 2000] = (q <= HALF - TOL).all(-1).any(1)
        near[a:a + 2000] = (q <= HALF + TOL).all(-1).any(1)
    lum = image.rgba[..., :3].sum(-1)[floor].astype(np.float64)
    dark = lum < 0.5 * np.median(lum[~near])
    assert blocked.sum() > 1000  # the rod's shadow is in view (~1,500 pixels)
    assert (~dark & blocked).sum() == 0, int((~dark & blocked).sum())
    assert (dark & ~near).sum() == 0, int((dark & ~near).sum())


@pytest.mark.parametrize("frame", [40.0])
def test_coupled_moon_as_pieces_has_no_holes_or_extras_away_from_the_silhouette(frame):
    """circular_orbit.usda's coupled moon holds a Sphere, so it stays pieces of uniform motion
    (spacetime/turning.py) contracted along each piece's velocity: their seams (overlapping in
    time, spacetime/animation.py) let no primary ray through and add none, against the float64
    march of examples/animation/orbit_coverage.py (its closed form is checked against USD's
    ComputeLocalToWorldTransform below). 160 x 90: the march's shrink and growth 0.05, above
    the pieces' half-pixel tolerance (~0.04 at the moon's nearest). At frame 40 the moon's
    velocity is across the view: the moon left uncontracted (decoupled) gives 183 extras."""
    from example_scripts import load_example

    orbit = load_example("animation/orbit_coverage.py")
    stage = Usd.Stage.Open(str(orbit.ORBIT))
    moon = UsdGeom.Xformable(stage.GetPrimAtPath("/Orbit/Moon"))
    rest = np.array([0.3, -0.2, 1.1])
    for t in (13.7, 50.0, 99.5):  # the closed form against USD (the contraction applied about the pivot)
        m = np.array(moon.ComputeLocalToWorldTransform(Usd.TimeCode(t)), dtype=np.float64)
        o, v, _th = orbit.pivot(np.array(t))
        unit = v / np.linalg.norm(v)
        lab = np.append(rest, 1.0) @ m
        lab = o + (lab[:3] - o) - (1.0 - np.sqrt(1.0 - v @ v)) * ((lab[:3] - o) @ unit) * unit
        assert np.allclose(orbit.moon_coordinates(lab, np.array(t)), rest, atol=1e-12)
    result = orbit.coverage(frame, 160, 90)
    assert result["moon"] > 500 and result["pieces"] > 100, result
    assert result["holes"] == 0 and result["extras"] == 0, result
