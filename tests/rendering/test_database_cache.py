"""The database belongs to the scene (issue 17; warp_st.rendering.database_cache).

Laws: a second ``warp_st.render`` of the same Scene object with the same options and
frames builds nothing and returns the same image bit for bit (the same database, the
same kernel, the same rays); a scene changed in Python is a new object and gets its own
database (identity keys invalidate by construction); options that change the database
(resolution-dependent sphere tessellation, light-speed mode, frames outside the cached
windows) build a new one whose image equals an uncached render; the cache lives no
longer than its scene. Builds are counted (``database_cache.builds``), never timed.
"""
from __future__ import annotations

import dataclasses
import gc
import weakref
from pathlib import Path

import numpy as np
import pytest

import warp_st
from warp_st.rendering import database_cache
from warp_st.rendering.renderer import Renderer

ROOT = Path(__file__).resolve().parents[2]
PARADE = ROOT / "usd_scenes" / "relativistic_parade.usda"
#: Moving meshes without analytic spheres: the tessellation does not depend on the frames.
MOVING = ROOT / "usd_scenes" / "thesis" / "sphere_and_cubes_moving.usda"
CHANNELS = ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id", "source_time", "bounces")


@pytest.fixture(scope="module")
def parade():
    return warp_st.load(str(PARADE))


def same(a, b) -> bool:
    """Every channel equal bit for bit (NaN where NaN)."""
    return all(np.array_equal(getattr(a, c), getattr(b, c), equal_nan=True) for c in CHANNELS)


def close(a, b) -> None:
    """Images of the same scene from two databases over different windows: the same
    hits (object ids), colours and times to float32 rounding. A wider window slices the
    worldlines at other times, which moves the stored vertices by float64 rounding and
    their float32 copies by an ulp or so; 1e-4 is ~1000 ulps of the unit-sized values."""
    assert np.array_equal(a.object_id, b.object_id)
    np.testing.assert_allclose(a.rgba, b.rgba, atol=1e-4)
    np.testing.assert_allclose(a.event_time, b.event_time, rtol=1e-4, atol=1e-4, equal_nan=True)


def test_second_render_builds_nothing_and_is_bit_identical(parade):
    kw = dict(frame=0, width=64, height=36)
    first = warp_st.render(parade, **kw)
    n = database_cache.builds()
    second = warp_st.render(parade, **kw)
    assert database_cache.builds() == n, "the second call rebuilt the database"
    assert same(first, second)
    r = Renderer(parade, frames=[0], width=64, height=36)
    assert not r.stats.database_built and database_cache.builds() == n


def test_a_replaced_scene_rebuilds_and_sees_its_change(parade):
    kw = dict(frame=0, width=64, height=36)
    base = warp_st.render(parade, **kw)
    n = database_cache.builds()
    copy = dataclasses.replace(parade)
    assert same(warp_st.render(copy, **kw), base)
    assert database_cache.builds() == n + 1, "a new Scene object must get its own database"
    # A changed scene: every body at rest. Were the cache keyed by anything but identity
    # (the source file, the body paths) the old database would serve it.
    rest = dataclasses.replace(parade, bodies=tuple(dataclasses.replace(b, velocity=np.zeros(3))
                                                    for b in parade.bodies))
    moved = warp_st.render(rest, **kw)
    assert database_cache.builds() == n + 2
    assert not np.array_equal(moved.object_id, base.object_id)


def test_options_that_change_the_database_rebuild_it(parade):
    # Resolution: tessellated UsdGeom.Spheres are cut for the pixel size; exact ones
    # (the rigid path's default) keep one database whatever the resolution.
    small = Renderer(parade, frames=[0], width=64, height=36, quadrics="tessellated")
    large = Renderer(parade, frames=[0], width=640, height=360, quadrics="tessellated")
    assert small.sphere_segments != large.sphere_segments
    assert large.stats.database_built or large.database is not small.database
    exact_small = Renderer(parade, frames=[0], width=64, height=36)
    n = database_cache.builds()
    exact_large = Renderer(parade, frames=[0], width=640, height=360)
    assert exact_small.sphere_segments == exact_large.sphere_segments == {}
    assert database_cache.builds() == n and exact_large.database is exact_small.database
    # Exact and tessellated spheres are cached apart.
    assert exact_small.database is not small.database
    # Light speed: infinite c sees other lab times, so other windows.
    finite = warp_st.render(parade, frame=0, width=64, height=36)
    n = database_cache.builds()
    infinite = warp_st.render(parade, frame=0, width=64, height=36, light_speed="infinite")
    assert database_cache.builds() == n + 1
    fresh = warp_st.render(dataclasses.replace(parade), frame=0, width=64, height=36, light_speed="infinite")
    assert same(infinite, fresh)
    assert not same(finite, infinite)


def test_frames_outside_the_cached_windows_rebuild_inside_reuse():
    scene = warp_st.load(str(MOVING))
    kw = dict(width=64, height=36)
    Renderer(scene, frames=[0, 10], **kw)
    n = database_cache.builds()
    reused = warp_st.render(scene, frame=10, **kw)  # inside the windows of frames 0 and 10
    assert database_cache.builds() == n
    assert (reused.object_id > 0).mean() > 0.05
    close(reused, warp_st.render(dataclasses.replace(scene), frame=10, **kw))
    n = database_cache.builds()
    warp_st.render(scene, frame=60, **kw)  # the bodies have moved on: other lab times
    assert database_cache.builds() == n + 1


def test_the_cache_lives_no_longer_than_its_scene():
    scene = warp_st.load(str(PARADE))
    warp_st.render(scene, frame=0, width=32, height=18)
    ref = weakref.ref(scene)
    assert database_cache.for_scene(scene).databases
    del scene
    gc.collect()
    assert ref() is None, "a cache entry keeps its scene alive"


def test_a_repeated_call_takes_its_renderer_again(parade, monkeypatch):
    """warp_st.render with the frame and options of a recent call makes no Renderer (the
    scene keeps it detached: database_cache.SceneCache.renderer) and returns the same
    image bit for bit; other options make one."""
    kw = dict(frame=0, width=48, height=27)
    first = warp_st.render(parade, **kw)
    made = []
    init = Renderer.__init__

    def counted(self, *args, **kwargs):
        made.append(kwargs)
        init(self, *args, **kwargs)

    monkeypatch.setattr(Renderer, "__init__", counted)
    n = database_cache.builds()
    again = warp_st.render(parade, **kw)
    assert not made, "the second call made a renderer"
    assert same(first, again) and database_cache.builds() == n
    assert again.metadata == first.metadata
    warp_st.render(parade, frame=0, width=48, height=27, max_depth=1)
    assert len(made) == 1


def test_a_kept_renderer_does_not_outlive_its_database():
    """Law: when the cache drops a database (past MAX_DATABASES), the renderer a call kept
    on it goes too, so the scene holds no more databases than the cache's limit; the same
    call then makes a new renderer and database, and the same image."""
    scene = warp_st.load(str(PARADE))
    kw = dict(frame=0, width=48, height=27)
    image = warp_st.render(scene, **kw)
    cache = database_cache.for_scene(scene)
    first = weakref.ref(cache.databases[-1])
    for width in (64, 96, 128, 160):  # tessellated spheres: a database per resolution
        Renderer(scene, frames=[0], width=width, height=width // 2, quadrics="tessellated")
    assert all(d is not first() for d in cache.databases)
    gc.collect()
    assert first() is None, "a kept renderer keeps a dropped database alive"
    n = database_cache.builds()
    assert same(warp_st.render(scene, **kw), image) and database_cache.builds() == n + 1
