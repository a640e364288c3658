"""The Renderer's measuring options (used by examples/benchmarks/, never by a render):
``sweep_fraction`` (the time-segment rule) and ``adjust_windows`` (the visibility windows).

Laws:

- sweep_fraction = f cuts each visible interval of a body moving at speed u into
  K = ceil(u (t1 - t0) / (f size)) segments (1 when it sweeps less than f x its size),
  3 tetrahedra per triangle per segment (closed form, docs/spec.md §2); the memory estimate
  counts that database; the image is the default rule's (the same exact extrusion in
  other boxes: the same objects, depth to float32 rounding);
- adjust_windows: what it returns is what is extruded, and nothing else. The identity
  renders the default image bit for bit; no windows, no geometry; called once per build
  with one window per body.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from warp_st.core.scene import surface_triangles
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.visibility import intervals, visibility_windows
from warp_st.testing import SphereView, sphere_view_scene

VIEW = SphereView(width=48, height=36, segments=16, velocity=(0.9, 0.0, 0.0))
FRAMES = [VIEW.t_c, VIEW.t_c + 12.0]


def _renderer(**kw):
    """The options measure the 4D extrusion's rules: the prism database."""
    return Renderer(sphere_view_scene(VIEW), frames=FRAMES, width=VIEW.width, height=VIEW.height,
                    **{"primitive": "prism", **kw})


def _expected_tetrahedra(r, fraction):
    body = r.scene.bodies[0]
    cams = [r.scene.camera_state("/Camera", f) for f in FRAMES]
    window = visibility_windows(r.scene, cams, infinite=False, max_depth=r.max_depth)[0]
    pts = np.concatenate([s.points for s in body.surfaces])
    size = float(np.max(pts.max(axis=0) - pts.min(axis=0)))  # 2R for the UV sphere
    triangles = sum(len(surface_triangles(s)) for s in body.surfaces)
    segments = 0
    for lo, hi in intervals(window):
        sweep = body.speed * (hi - lo)
        segments += 1 if sweep <= fraction * size else math.ceil(sweep / (fraction * size))
    return 3 * triangles * segments


def test_sweep_fraction_sets_the_time_segments():
    default = _renderer()
    ref = default.render(VIEW.t_c)
    estimates = {}
    for fraction in (0.25, 2.0):
        r = _renderer(sweep_fraction=fraction)
        assert r.stats.tetrahedra == _expected_tetrahedra(r, fraction), fraction
        assert r.describe()["time_segments"] == f"sweep {fraction:g} x body size"
        estimates[fraction] = r.memory_estimate
        img = r.render(VIEW.t_c)
        assert (ref.object_id > 0).mean() > 0.05
        assert np.array_equal(img.object_id, ref.object_id)
        hit = ref.object_id > 0
        np.testing.assert_allclose(img.depth[hit], ref.depth[hit], rtol=1e-5)  # float32 rounding of two extrusions
    assert _expected_tetrahedra(default, 0.25) > _expected_tetrahedra(default, 2.0)
    assert estimates[0.25] > estimates[2.0]  # the memory guard counts the database it will build


def test_sweep_fraction_is_refused_on_the_rigid_path():
    """The rigid path has no time segments: the option would be ignored, so it is refused."""
    with pytest.raises(ValueError, match="sweep_fraction"):
        _renderer(sweep_fraction=1.0, primitive="rigid")


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_sweep_fraction_must_be_positive_and_finite(bad):
    with pytest.raises(ValueError, match="sweep_fraction"):
        _renderer(sweep_fraction=bad)


def test_adjust_windows_decides_what_is_extruded():
    default = _renderer()
    ref = default.render(VIEW.t_c)
    calls = []

    def identity(scene, windows):
        calls.append((scene, list(windows)))
        return windows

    same = _renderer(adjust_windows=identity)
    assert len(calls) == 1 and len(calls[0][1]) == len(calls[0][0].bodies) == 1
    assert same.stats.tetrahedra == default.stats.tetrahedra
    img = same.render(VIEW.t_c)
    for channel in ("rgba", "depth", "event_time", "object_id"):
        assert getattr(img, channel).tobytes() == getattr(ref, channel).tobytes(), channel

    empty = _renderer(adjust_windows=lambda scene, windows: [None] * len(windows))
    assert empty.stats.tetrahedra == 0
    assert not (empty.render(VIEW.t_c).object_id > 0).any()

    def first_half(scene, windows):
        return [None if w is None else (intervals(w)[0][0], 0.5 * sum(intervals(w)[0])) for w in windows]

    half = _renderer(adjust_windows=first_half)
    assert 0 < half.stats.tetrahedra < default.stats.tetrahedra
