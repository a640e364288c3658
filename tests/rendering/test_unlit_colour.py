"""Without lights a surface shows emissive + diffuse (docs/spec.md §3), for any velocity
while the Doppler colour options are off; with a light it is lit (the shade() path).

Oracle: the closed form. A sphere at rest (or moving) filling the image centre, no
dome, background black: every hit pixel is emissive + diffuse exactly (a float32 sum of
two constants: the tolerance is one float32 rounding of values below 1, 1e-7), every miss
is the background with alpha 0.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import warp_st
from warp_st.core import tessellate
from warp_st.core.scene import Body, CameraState, Light, Material, RenderSettings, Scene, Surface

DIFFUSE = (0.2, 0.3, 0.4)
EMISSIVE = (0.5, 0.125, 0.0)


def sphere_scene(velocity=(0.0, 0.0, 0.0), lights=()) -> Scene:
    cam = CameraState("/Camera", 0.0, np.zeros(3), np.eye(3), focal_length=27.0, horizontal_aperture=36.0,
                      vertical_aperture=36.0)
    pts, tris, nrm = tessellate.sphere(1.0, 24)
    centre = np.array([0.0, 0.0, -6.0])
    surf = Surface("/Ball", pts + centre, tris, Material(diffuse=DIFFUSE, emissive=EMISSIVE), nrm)
    body = Body("/Ball", (surf,), centre, np.asarray(velocity, float), -6.0, (-math.inf, math.inf))
    return Scene(source="<test:unlit>", bodies=(body,), lights=tuple(lights), cameras=(cam.prim_path,),
                 settings=RenderSettings(), default_camera=cam.prim_path,
                 camera_state=lambda path, frame: dataclasses.replace(cam, time=float(frame)))


@pytest.mark.parametrize("velocity", [(0.0, 0.0, 0.0), (0.6, 0.0, 0.0)])
def test_unlit_surface_is_emissive_plus_diffuse(velocity):
    img = warp_st.render(sphere_scene(velocity), frame=0, width=48, height=48)
    hit = img.object_id > 0
    assert 100 < hit.sum() < hit.size
    want = np.array(EMISSIVE, np.float32) + np.array(DIFFUSE, np.float32)
    np.testing.assert_allclose(img.rgba[hit][:, :3], np.broadcast_to(want, (int(hit.sum()), 3)), rtol=0, atol=1e-7)
    assert np.all(img.rgba[hit][:, 3] == 1.0)
    assert np.all(img.rgba[~hit] == 0.0)


def test_a_light_shades_the_surface():
    """A distant light from behind the camera: the lit colour is emissive + diffuse x
    radiance x cos, below the unlit sum at the limb (cos < 1) and not equal to it."""
    sun = Light("distant", (1.0, 1.0, 1.0), direction=(0.0, 0.0, 1.0), prim_path="/Sun")
    img = warp_st.render(sphere_scene(lights=(sun,)), frame=0, width=48, height=48)
    hit = img.object_id > 0
    unlit = np.array(EMISSIVE, np.float32) + np.array(DIFFUSE, np.float32)
    assert np.all(img.rgba[hit][:, :3] <= unlit + 1e-6)
    assert np.any(np.abs(img.rgba[hit][:, :3] - unlit).max(axis=1) > 0.01)


def test_doppler_is_the_first_hits_through_mirrors():
    """The Doppler AOV is the first hit's (docs/spec.md §4), whatever the path does after
    it: the moving flanges' mirrors rendered with 4 bounces give the Doppler plane of the
    render with none, bit for bit (the first hit is the same ray's), on pixels whose
    colour comes from behind a mirror too."""
    from pathlib import Path

    stage = Path(__file__).resolve().parents[2] / "usd_scenes" / "mirrors" / "flanges_coupled.usda"
    with pytest.warns(UserWarning):  # its materials' roughness is not honoured
        scene = warp_st.load(str(stage))
    deep = warp_st.render(scene, frame=0, width=64, height=48, max_depth=4)
    flat = warp_st.render(scene, frame=0, width=64, height=48, max_depth=0)
    assert np.count_nonzero(deep.bounces) > 50
    assert np.array_equal(deep.doppler, flat.doppler, equal_nan=True)


def test_unlit_mirrors_reflect_about_the_shading_normal():
    """Unlit, the kernel skips the shading normal where nothing needs it; mirrors do.
    Oracle: the same scene with a black distant light (which makes the kernel shade every
    hit with its normal) when every non-mirror surface is emissive only (diffuse 0): a
    black light adds exactly 0 to emissive, so both images agree bit for bit. A smooth
    mirror ball shows a wall of nine coloured cubes behind the camera; reflected about the facet
    normals instead, the cubes' edges in the ball move."""
    mirror = sphere_scene().bodies[0]
    ball = mirror.surfaces[0]
    ball = dataclasses.replace(ball, material=Material(diffuse=(0.9, 0.9, 0.9), metallic=1.0))
    bodies = [dataclasses.replace(mirror, surfaces=(ball,))]
    pts, tris = tessellate.cube(2.5)
    spots = [(x, y, 4.0) for x in (-3.0, 0.0, 3.0) for y in (-3.0, 0.0, 3.0)]  # a wall of cubes behind the camera
    for i, spot in enumerate(spots):
        c = np.asarray(spot, float)
        colour = tuple(float(x) for x in np.roll([0.9, 0.5, 0.1], i) * (0.3 + 0.07 * i))
        surf = Surface(f"/Cube{i}", pts + c, tris, Material(diffuse=(0.0, 0.0, 0.0), emissive=colour))
        bodies.append(Body(f"/Cube{i}", (surf,), c, np.zeros(3), -float(np.linalg.norm(c)), (-math.inf, math.inf)))
    unlit = dataclasses.replace(sphere_scene(), bodies=tuple(bodies))
    black = Light("distant", (0.0, 0.0, 0.0), direction=(0.3, 0.5, 0.8), prim_path="/Black")
    lit = dataclasses.replace(unlit, lights=(black,))
    kw = dict(frame=0, width=128, height=128, max_depth=2)
    a, b = warp_st.render(unlit, **kw), warp_st.render(lit, **kw)
    assert np.count_nonzero(a.rgba[..., :3].sum(axis=-1)) > 40  # the ball (~830 pixels) shows the cubes
    assert a.rgba.tobytes() == b.rgba.tobytes()
    assert np.array_equal(a.source_time, b.source_time, equal_nan=True)
