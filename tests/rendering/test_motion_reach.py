"""Animated bodies are cut only where the frames can reach them (spacetime/reach.py, issue 18).

Laws:
- clipping never changes an image: the examples' orbit and wheel render every channel bit
  for bit alike with and without it (each frame alone and, but for the wheel, as a sequence); the pieces of the
  chunks kept are the same rows either way (a chunk is cut from its own start), so nothing
  is left to rounding; the rod (worldlines beside a rigid floor) alike within a few float32
  ulps (``ROUNDING_ULPS``: its held ends join the floor's motion group);
- a single frame of a long animation cuts a small part of the pieces the whole span
  would, and a frame at the end of it still sees the body;
- a shadow the animated body casts, and its reflection in a mirror, from times outside
  its direct reach still render (the reach holds the shadow rays' and mirror paths'
  reach, not only the past lightcone's);
- cuts with gaps are equal keys of the database cache.
"""
from pathlib import Path

import numpy as np
import pytest

import warp_st
from warp_st.rendering import renderer as renderer_module
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.animation import animation_cuts, piece_count

from animation_stages import CHROME, CUBE, HEADER, orbit_degrees, write

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "animation"
W, H = 48, 27
CHANNELS = ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id", "source_time", "bounces")


def _unclipped(monkeypatch):
    """The renderer with every chunk cut (a reach that names no body)."""
    monkeypatch.setattr(renderer_module, "motion_reach", lambda scene, margins, **_: {})


def _images(scene, frames, width=W, height=H, **options):
    """(images per frame of one Renderer for ``frames``, its animated segment count)."""
    r = Renderer(scene, frames=frames, width=width, height=height, **options)
    return [r.render(f) for f in frames], r.describe()["animated_segments"]


def _clipped_and_full(path, monkeypatch, frame=60.0, width=64, height=48, **options):
    """The image of ``frame`` clipped and unclipped (the clipping having dropped pieces)."""
    (clipped,), clipped_pieces = _images(warp_st.load(path), [frame], width, height, **options)
    _unclipped(monkeypatch)
    (full,), full_pieces = _images(warp_st.load(path), [frame], width, height, **options)
    assert clipped_pieces < full_pieces
    return clipped, full


#: The spinning rod is traced as per-vertex worldlines (spacetime/turning.py), tetrahedra
#: leaves beside the floor's instance; clipping it leaves its motion's held ends as rigid
#: pieces at rest, which join the floor's motion group (spacetime/rigid.py: one group's
#: queries start where a ray enters the group's rest box, so bodies in contact round alike).
#: The floor's query then starts at another point of the same float32 ray: its hits agree to
#: the rounding of that start and of t from it, a few float32 ulps (measured 8 at frame 60: depth
#: 6.7e-6 of 14.65; 16 allowed), not bit for bit.
ROUNDING_ULPS = {"spinning_rod": 16}


def _assert_same(a, b, ulps: int = 0):
    for name in CHANNELS:
        x, y = getattr(a, name), getattr(b, name)
        if ulps and np.issubdtype(np.asarray(x).dtype, np.floating):
            np.testing.assert_array_equal(np.isfinite(x), np.isfinite(y), err_msg=name)
            both = np.isfinite(x) & np.isfinite(y)
            bound = ulps * 2.0 ** -24 * np.maximum(np.abs(y[both]), 1.0)
            assert (np.abs(x[both] - y[both]) <= bound).all(), name
        else:
            assert np.array_equal(x, y, equal_nan=np.issubdtype(np.asarray(x).dtype, np.floating)), name


#: Frame lists rendered per stage: each frame alone and as a sequence; the wheel (its whole
#: span as worldlines unclipped: ~30 s a database on CI's machine) alone only.
FRAME_LISTS = {"circular_orbit": ([70.0], [40.0, 70.0]), "spinning_rod": ([70.0], [40.0, 70.0]),
               "rolling_wheel": ([70.0],)}


@pytest.mark.parametrize("name", sorted(FRAME_LISTS))
def test_clipping_changes_no_image(name, monkeypatch):
    path = str(EXAMPLES / f"{name}.usda")
    clipped = [_images(warp_st.load(path), frames) for frames in FRAME_LISTS[name]]
    _unclipped(monkeypatch)
    full = [_images(warp_st.load(path), frames) for frames in FRAME_LISTS[name]]
    # the clipping did drop pieces (the chunks after the last frame at least)
    assert all(cut[1] < whole[1] for cut, whole in zip(clipped, full))
    assert (clipped[0][0][0].object_id > 0).sum() > 0.3 * W * H
    for (cut, _n), (whole, _m) in zip(clipped, full):
        for a, b in zip(cut, whole):
            _assert_same(a, b, ROUNDING_ULPS.get(name, 0))


def test_clipping_changes_no_image_at_an_infinite_light_speed(monkeypatch):
    """Rays are instantaneous: the reach is the frame's own time (and the shadows of it)."""
    clipped, full = _clipped_and_full(str(EXAMPLES / "spinning_rod.usda"), monkeypatch, 70.0, W, H,
                                      light_speed="infinite")
    assert (full.object_id == 2).sum() > 20  # the rod is in view
    _assert_same(clipped, full, ROUNDING_ULPS["spinning_rod"])


def _long_orbit(tmp_path, end=1000.0):
    """A cube on a 0.5c orbit of radius 5 over time codes 0 to ``end`` (no light: the reach
    is the past lightcone's)."""
    text = HEADER.replace("endTimeCode = 100", f"endTimeCode = {end:g}") + f'''def Xform "Orbit"
{{
    double xformOp:rotateY.timeSamples = {{ 0: 0, {end:g}: {orbit_degrees(0.5, 5.0, end)!r} }}
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Xform "Moon" (prepend apiSchemas = ["SpacetimeBodyAPI"])
    {{
        double3 xformOp:translate = (5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        {CUBE}
    }}
}}
'''
    return write(tmp_path, "long_orbit.usda", text)


def test_a_single_frame_of_a_long_animation_cuts_few_pieces(tmp_path):
    scene = warp_st.load(_long_orbit(tmp_path))
    cam = scene.camera_state(None, 500.0)
    (_i, whole), = animation_cuts(scene, [cam], width=64, height=36)
    renderer = Renderer(scene, frames=[500.0], width=64, height=36)
    clipped = renderer.describe()["animated_segments"]
    # The camera is 14 from the orbit's centre: the cube is seen about 9 to 19 time units
    # before the frame; with the chunks (about 1.6 time units) and the held ends, a few
    # dozen pieces of the whole span's thousands.
    assert piece_count(whole) > 1000
    assert clipped < 0.05 * piece_count(whole)
    end = Renderer(scene, frames=[1000.0], width=64, height=36)
    image = end.render(1000.0)
    assert end.describe()["animated_segments"] < 0.05 * piece_count(whole)
    assert (image.object_id == 1).sum() > 10  # the cube, seen at the end of its motion


def _turning_box(start, end) -> str:
    """/Box, a cube of edge 1.6 moving from ``start`` (time code 0) to ``end`` (100) while it
    turns 1000 degrees about +Y (many pieces)."""
    return f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate.timeSamples = {{ 0: {start}, 100: {end} }}
    double xformOp:rotateY.timeSamples = {{ 0: 0, 100: 1000 }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    def Cube "C"
    {{
        double size = 1.6
    }}
}}
'''


#: Straight above the floor point (0, 0, -10): a distant light (spacetime/shadow_reach.py's
#: bound) and a point-like sphere light 40 up (visibility_windows' shadow bound).
LIGHTS = {"distant": '''def DistantLight "Sun"
{
    float inputs:intensity = 2.5
    float3 xformOp:rotateXYZ = (-90, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}
''', "sphere": '''def SphereLight "Lamp"
{
    float inputs:radius = 0.5
    float inputs:intensity = 4000
    double3 xformOp:translate = (0, 40, -10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
'''}


def _shadow_stage(tmp_path, light="distant"):
    """A camera at (0, 1, 0) looking down -Z at the floor around (0, 0, -10); a cube 20
    above that floor point moving slowly along +X and turning, lit from straight above. Its
    shadow on the floor point is cast 30 before the frame (10 to the floor, 20 down to
    it), while the camera sees the cube itself about 21.5 before the frame: outside
    the cube's direct reach (its radius 1.4 about its pivot, its chunks 5.5 time units)."""
    camera = HEADER.replace("(0, 3, 14)", "(0, 1, 0)").replace("(-12, 0, 0)", "(-6, 0, 0)")
    assert camera != HEADER
    text = camera + LIGHTS[light] + '''def Mesh "Floor"
{
    point3f[] points = [(-8, 0, -16), (8, 0, -16), (8, 0, -4), (-8, 0, -4)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 3, 2, 1]
}
''' + _turning_box((-3, 20, -10), (3, 20, -10))
    return write(tmp_path, "shadow.usda", text)


@pytest.mark.parametrize("light", sorted(LIGHTS))
def test_a_shadow_cast_outside_the_direct_reach_still_falls(tmp_path, monkeypatch, light):
    clipped, full = _clipped_and_full(_shadow_stage(tmp_path, light), monkeypatch)
    floor = full.object_id == 1
    lit = full.rgba[..., 0][floor]
    # the unclipped image has the shadow: floor pixels far darker than the lit floor
    assert (lit < 0.1 * lit.max()).sum() >= 4
    assert (full.object_id == 2).sum() == 0  # and not the cube itself (it is out of view)
    _assert_same(clipped, full)


def test_clipped_cuts_find_their_cached_database():
    """Cuts with gaps are equal keys of the scene's database cache: a second renderer of
    the same frame builds nothing."""
    scene = warp_st.load(str(EXAMPLES / "spinning_rod.usda"))
    first = Renderer(scene, frames=[70.0], width=W, height=H, primitive="rigid")  # the pieces (gaps in the cuts)
    assert any(not np.isfinite(row[2]) for _i, rows in first.animation for row in rows)  # a gap
    second = Renderer(scene, frames=[70.0], width=W, height=H, primitive="rigid")
    assert first.stats.database_built and not second.stats.database_built


def _mirror_stage(tmp_path):
    """The camera of ``_shadow_stage`` looking down -Z at a mirror 10 ahead; a turning cube
    4 behind the camera, lit by a distant light. The camera sees the cube in the mirror
    as it was 24 before the frame (10 there, 14 back), directly 4 before: outside the
    cube's direct reach (its radius 1.4, its chunks 5.5 time units)."""
    camera = HEADER.replace("(0, 3, 14)", "(0, 1, 0)").replace("(-12, 0, 0)", "(0, 0, 0)")
    text = camera + '''def DistantLight "Sun"
{
    float inputs:intensity = 2.5
    float3 xformOp:rotateXYZ = (-50, 20, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}
''' + CHROME + '''def Mesh "Mirror" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    point3f[] points = [(-4, -2, -10), (4, -2, -10), (4, 4, -10), (-4, 4, -10)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    rel material:binding = </Chrome>
}
''' + _turning_box((-1, 1, 4), (1, 1, 4))
    return write(tmp_path, "mirror.usda", text)


def test_a_reflection_from_outside_the_direct_reach_still_shows(tmp_path, monkeypatch):
    clipped, full = _clipped_and_full(_mirror_stage(tmp_path), monkeypatch)
    # the cube in the mirror: pixels whose last non-mirror event is about 24 before the frame
    reflected = (full.bounces > 0) & (np.abs(full.source_time - 36.0) < 2.5)
    assert reflected.sum() >= 4
    _assert_same(clipped, full)
