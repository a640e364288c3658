"""What render calls reuse (warp_st.rendering.frame_inputs): structs and the film, kept on the database.

Laws: a render served cached Shading / Camera structs and a reused film returns, bit
for bit, the image an uncached render of a fresh copy of the scene returns, whatever
option or frame changed in between (the key holds everything the structs are made of;
the kernel rewrites every pixel of every plane); an Image returned earlier is never
touched by a later render (its planes are copies); two renders at once never share a
film; the mean node visits summed per kernel thread are the per-ray visits' mean.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import warp as wp

import warp_st
from warp_st.core import tessellate
from warp_st.core.scene import Body, CameraState, Material, RenderSettings, Scene, Surface
from warp_st.rendering import frame_inputs
from warp_st.rendering.camera import pixel_directions
from warp_st.rendering.renderer import Renderer

ROOT = Path(__file__).resolve().parents[2]
PARADE = ROOT / "usd_scenes" / "relativistic_parade.usda"
MIRRORS = ROOT / "usd_scenes" / "mirrors" / "flanges_coupled.usda"  # metallic flanges: max_depth shows
CHANNELS = ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id", "source_time", "bounces")


@pytest.fixture(scope="module")
def parade():
    return warp_st.load(str(PARADE))


@pytest.fixture(scope="module")
def mirrors():
    with pytest.warns(UserWarning):  # its materials' roughness is not honoured
        return warp_st.load(str(MIRRORS))


def planes(img) -> dict:
    """Every plane's bytes (NaN payloads and signed zeros included) and the header."""
    out = {c: np.ascontiguousarray(getattr(img, c)).tobytes() for c in CHANNELS}
    out.update({f"extra:{k}": np.ascontiguousarray(v).tobytes() for k, v in img.extra.items()})
    out["metadata"] = repr(sorted(img.metadata.items()))
    return out


def fresh(scene) -> Scene:
    """The same scene as a new object: nothing cached for it (database_cache keys on identity)."""
    return dataclasses.replace(scene)


def receding_spheres(speed: float = 0.5) -> Scene:
    """Four spheres in front of a camera at the origin, flying away at ``speed`` (c = 1):
    at 0.5c frame 0 sees them, frame 10,000 nothing (its past lightcone meets them
    nowhere in view)."""
    cam = CameraState("/Camera", 0.0, np.zeros(3), np.eye(3), focal_length=27.0, horizontal_aperture=36.0,
                      vertical_aperture=36.0)
    pts, tris, nrm = tessellate.sphere(1.0, 16)
    bodies = []
    for i in range(4):
        centre = np.array([(i % 2 - 0.5) * 3.0, (i // 2 - 0.5) * 3.0, -10.0])
        path = f"/S{i}"
        surf = Surface(path, pts + centre, tris, Material(diffuse=(0.3 + 0.1 * i, 0.5, 0.7)), nrm)
        bodies.append(Body(path, (surf,), centre, np.array([0.0, 0.0, -speed]), -float(np.linalg.norm(centre)),
                           (-math.inf, math.inf)))
    return Scene(source="<test:receding>", bodies=tuple(bodies), lights=(), cameras=(cam.prim_path,),
                 settings=RenderSettings(), default_camera=cam.prim_path,
                 camera_state=lambda path, frame: dataclasses.replace(cam, time=float(frame)))


@pytest.mark.parametrize("stage, option", [
    ("mirrors", dict(max_depth=1)), ("parade", dict(doppler_color=True)), ("parade", dict(searchlight=True)),
    ("parade", dict(light_speed="infinite")), ("parade", dict(frame=12)), ("parade", dict(width=48, height=27)),
    ("parade", dict(samples=2, shutter=0.25)), ("parade", dict(cryptomatte=True))],
    ids=lambda o: o if isinstance(o, str) else ",".join(o))
def test_changed_option_is_never_served_stale_structs(request, stage, option):
    """The shared scene rendered with the defaults, then with one option changed: the
    second image is the uncached render's of a fresh copy, bit for bit, and differs from
    the first (else the option would not show a stale struct)."""
    scene = request.getfixturevalue(stage)
    base = dict(frame=0, width=64, height=36)
    before = planes(warp_st.render(scene, **base))
    kw = {**base, **option}
    after = planes(warp_st.render(scene, **kw))
    assert after == planes(warp_st.render(fresh(scene), **kw))
    assert after != before


def test_frames_of_one_database_get_their_own_structs(parade):
    """Frames 0 and 12 from one renderer (one database): frame 12 is what a renderer that
    rendered only frame 12 returns, bit for bit (the camera event is in the key)."""
    r = Renderer(parade, frames=[0.0, 12.0], width=64, height=36)
    r.render(0.0)
    alone = Renderer(fresh(parade), frames=[0.0, 12.0], width=64, height=36).render(12.0)
    assert planes(r.render(12.0)) == planes(alone)


def test_light_speed_modes_of_one_database_get_their_own_structs():
    """One database serves both light-speed modes: built at infinite c for frames -12 to
    0 (the bodies' lab times from -13 to 1), it covers what frame 0 sees at finite c
    (about -11 to -9). The finite-c render of frame 0 after the infinite-c one, from that
    database, is an uncached render's."""
    scene = receding_spheres(speed=0.0)
    kw = dict(width=40, height=40)
    infinite = Renderer(scene, frames=[-12.0, -11.0, -10.0, -9.0, -8.0, 0.0], light_speed="infinite", **kw)
    seen_infinite = planes(infinite.render(0.0))
    finite = Renderer(scene, frames=[0.0], **kw)
    assert not finite.stats.database_built and finite.database is infinite.database
    seen_finite = planes(finite.render(0.0))
    assert seen_finite != seen_infinite
    assert seen_finite == planes(warp_st.render(fresh(scene), frame=0.0, **kw))


def test_reused_film_is_rewritten_everywhere():
    """Frame 0 (spheres seen) then frame 10,000 (nothing seen) into one film: the second
    image is a first render's, bit for bit (no plane keeps frame 0's hits)."""
    scene = receding_spheres()
    r = Renderer(scene, frames=[0.0, 10000.0], width=40, height=40)
    seen = r.render(0.0)
    assert np.count_nonzero(seen.object_id) > 100
    empty = r.render(10000.0)
    assert np.count_nonzero(empty.object_id) == 0
    alone = Renderer(fresh(scene), frames=[0.0, 10000.0], width=40, height=40).render(10000.0)
    assert planes(empty) == planes(alone)


def test_returned_images_own_their_planes(parade):
    """An Image kept from one render is left unchanged by the next render into the same film."""
    r = Renderer(parade, frames=[0.0, 24.0], width=64, height=36)
    first = r.render(0.0)
    kept = planes(first)
    second = r.render(24.0)
    assert planes(second) != kept, "the frames must differ for the test to see an overwrite"
    assert planes(first) == kept


def test_two_renders_at_once_never_share_a_film():
    scene = receding_spheres()
    r = Renderer(scene, width=16, height=16)
    r.render()
    k = r.kernels
    key_a, a = frame_inputs.take_film(r.database, k, 256, 0)
    key_b, b = frame_inputs.take_film(r.database, k, 256, 0)
    assert a is not b
    frame_inputs.give_back(r.database, key_a, a)
    assert frame_inputs.take_film(r.database, k, 256, 0)[1] is a  # the idle film is reused
    assert a.overflow.numpy()[0] == 0


def test_mean_visits_are_the_primary_rays_visits():
    """Unlit, no mirrors: a pixel's node visits are its camera ray's, which the probe
    kernel counts ray by ray on the frame's geometry. The render sums them per kernel
    thread (PIXELS_PER_THREAD pixels) over tiles on two threads. The probe's rays are
    the float64 pinhole rounded to float32 as the kernel rounds it; a ray an ulp apart
    may visit a node more or less, so the means agree to 1 %, far tighter than any
    lost or doubled tile (1/64 of the pixels each, at 256 x 256)."""
    scene = receding_spheres()
    r = Renderer(scene, width=256, height=256, max_depth=0, threads=2)
    r.render(0.0)
    cam = scene.camera_state(scene.default_camera, 0.0)
    dirs = pixel_directions(cam, 256, 256, frame="lab").reshape(-1, 3).astype(np.float32)
    geo = r.database.geometry_for("float32", (0.0, 0.0, 0.0, 0.0), None)
    n = len(dirs)
    k = r.kernels
    prim = wp.zeros(n, dtype=wp.int32, device="cpu")
    s = wp.zeros(n, dtype=wp.float32, device="cpu")
    visits = wp.zeros(n, dtype=wp.int32, device="cpu")
    wp.launch(k.cast_rays, dim=n, inputs=[geo, wp.zeros(n, dtype=k.vec4, device="cpu"),
                                          wp.array(dirs, dtype=wp.vec3, device="cpu"), 1, prim, s, visits, 0],
              device="cpu")
    expected = visits.numpy().mean()
    assert expected > 0.15  # a sixth of the rays enter the scene box (its one leaf: one visit each)
    assert r.stats.last_mean_visits == pytest.approx(expected, rel=0.01)


def test_the_probe_traces_a_tile_from_its_first_ray():
    """Law: ``cast_rays`` launched on tiles, each with its first ray (how the benchmarks
    launch it, as the renderer's tiles pass their pixel range), writes what one launch
    over every ray writes, ray for ray (the same rays through the same kernel: exact)."""
    scene = receding_spheres()
    r = Renderer(scene, width=64, height=64, max_depth=0)
    r.render(0.0)
    cam = scene.camera_state(scene.default_camera, 0.0)
    dirs = wp.array(pixel_directions(cam, 64, 64, frame="lab").reshape(-1, 3).astype(np.float32), dtype=wp.vec3,
                    device="cpu")
    geo = r.database.geometry_for("float32", (0.0, 0.0, 0.0, 0.0), None)
    n = dirs.shape[0]
    k = r.kernels
    origins = wp.zeros(n, dtype=k.vec4, device="cpu")
    outs = []
    for tiles in ([(0, n)], [(0, 1000), (1000, 3000), (3000, n)]):
        out = [wp.full(n, -7, dtype=wp.int32, device="cpu"), wp.zeros(n, dtype=wp.float32, device="cpu"),
               wp.zeros(n, dtype=wp.int32, device="cpu")]
        for a, b in tiles:
            wp.launch(k.cast_rays, dim=b - a, inputs=[geo, origins, dirs, 1, *out, a], device="cpu")
        outs.append([o.numpy() for o in out])
    (prim, s, visits), (tile_prim, tile_s, tile_visits) = outs
    assert (prim >= 0).sum() > 100 and (prim == -1).sum() > n // 2  # hits and misses
    np.testing.assert_array_equal(tile_prim, prim)
    np.testing.assert_array_equal(tile_s, s)
    np.testing.assert_array_equal(tile_visits, visits)


def test_image_memory_is_reused_only_once_its_image_is_gone(parade):
    """A live Image's planes are never handed to the next render; a dropped one's are."""
    r = Renderer(parade, frames=[0.0, 24.0], width=64, height=36)
    first = r.render(0.0)
    kept, address = planes(first), first.rgba.ctypes.data
    second = r.render(24.0)
    assert second.rgba.ctypes.data != address and planes(first) == kept
    del first
    third = r.render(0.0)
    assert third.rgba.ctypes.data == address  # the dropped Image's block, with no new pages
    assert planes(third) == kept
    assert planes(second) == planes(Renderer(fresh(parade), frames=[0.0, 24.0], width=64, height=36).render(24.0))


def test_only_the_last_database_keeps_idle_buffers(parade):
    """Two databases of one scene (the light-speed modes see other windows): after a
    render from the second, the first keeps no film and no Image block."""
    first = Renderer(parade, frames=[0.0], width=64, height=36)
    first.render(0.0)
    assert first.database.films and first.database.image_blocks
    second = Renderer(parade, frames=[0.0], width=64, height=36, light_speed="infinite")
    assert second.database is not first.database
    second.render(0.0)
    assert not first.database.films and not first.database.image_blocks
    assert second.database.films and second.database.image_blocks
