"""The database is recentred on a grid point near the camera, not on every camera event
(rendering/anchor.py, docs/spec.md §5 addition 0.8.0).

Laws:
- the anchor is the camera event rounded per axis to a multiple of G, a power of two at or
  above the database's largest finite 4D extent / ANCHOR_CELLS; without a finite extent, or
  where the rounding is not finite, it is the event itself;
- an image rendered with the geometry recentred on the anchor equals the same frame with the
  geometry recentred on the camera event itself (0.7.0's rule; the oracle here): the same hit
  mask, and depth, eventTime, properTime, sourceTime and colour within float32 rounding of
  coordinates of the database's size (below);
- frames whose camera events round to one anchor share one recentred geometry.
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import warp_st
import warp_st.rendering.anchor as anchor_module
import warp_st.rendering.device_rigid as device_rigid
from warp_st.rendering.anchor import ANCHOR_CELLS, anchor_step, geometry_anchor
from warp_st.rendering.renderer import Renderer

ROOT = Path(__file__).resolve().parents[2]
W, H = 64, 36


def test_the_anchor_is_the_event_on_a_power_of_two_grid():
    lo, hi = np.array([-3.0, -1.0, 0.0, -50.0]), np.array([17.0, 1.0, 2.0, 50.0])
    step = anchor_step(lo, hi)
    assert step == 2.0 ** math.ceil(math.log2(100.0 / ANCHOR_CELLS)) == 8.0
    event = np.array([13.7, -3.9, 0.2, 1e3 + 2.1])
    np.testing.assert_array_equal(geometry_anchor(event, step), [16.0, -0.0, 0.0, 1000.0])
    assert (np.abs(geometry_anchor(event, step) - event) <= step / 2).all()
    # a static body's infinite lifetime: the finite axes decide; none finite: the event itself
    assert anchor_step(np.array([-np.inf, 0, 0, 0]), np.array([np.inf, 4.0, 1.0, 1.0])) == 0.25
    assert anchor_step(np.full(4, -np.inf), np.full(4, np.inf)) == 0.0
    np.testing.assert_array_equal(geometry_anchor(event, 0.0), event)
    np.testing.assert_array_equal(geometry_anchor(np.array([1e308, 0, 0, 0]), 2.0 ** -100), [1e308, 0, 0, 0])


def test_an_empty_database_or_an_overflowing_grid_says_nothing_of_it():
    # An empty database's root box lies at t = +inf (accel/bvh.build_bvh): inf - inf is NaN,
    # which is no extent; a rounding to the grid that overflows falls back to the event.
    # Neither may print numpy's RuntimeWarning into the user's render.
    far = np.array([np.inf, 0.0, 0.0, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert anchor_step(far, far.copy()) == 0.0
        np.testing.assert_array_equal(geometry_anchor(np.array([1e308, 0, 0, 0]), 2.0 ** -100), [1e308, 0, 0, 0])


def _render(path, frames, *, at_event: bool, monkeypatch, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = warp_st.load(str(path))  # its own scene: its own database cache
    with monkeypatch.context() as m:
        if at_event:
            m.setattr(anchor_module, "geometry_anchor", lambda event, step: np.array(event, dtype=np.float64))
        r = Renderer(scene, frames=frames, width=W, height=H, **kw)
        return r, [r.render(f) for f in frames]


@pytest.mark.parametrize("path, frames, kw", [
    # deforming: tetrahedra leaves on the rigid path (their recentring is what the anchor saves)
    ("examples/animation/waving_flag.usda", [20.3, 21.7], {}),
    ("examples/animation/waving_flag.usda", [20.3], {"samples": 4, "shutter": 0.5}),  # jittered rays
    ("usd_scenes/mirrors/flanges_coupled.usda", [3.3, 7.9], {}),  # mirrors: sourceTime
    ("examples/animation/waving_flag.usda", [20.3], {"primitive": "tet", "precision": "float64"}),
])
def test_an_anchored_frame_equals_the_frame_recentred_on_its_camera(path, frames, kw, monkeypatch):
    r, anchored = _render(ROOT / path, frames, at_event=False, monkeypatch=monkeypatch, **kw)
    step = anchor_step(r.bvh.node_lo[0], r.bvh.node_hi[0])
    events = [np.array([c.time, *c.position]) for c in (r._cameras[f] for f in frames)]
    assert any((geometry_anchor(e, step) != e).any() for e in events), "the test needs an offset anchor"
    _, exact = _render(ROOT / path, frames, at_event=True, monkeypatch=monkeypatch, **kw)
    size = float(np.max(np.where(np.isfinite(r.bvh.node_hi[0] - r.bvh.node_lo[0]),
                                 r.bvh.node_hi[0] - r.bvh.node_lo[0], 0.0)))
    # float32 (2^-24 relative) coordinates within 2 G + the scene's distances of the anchor,
    # a few roundings each: 64 ulps of the database's size (float64: 1e-9 of it)
    tol = (1e-9 if kw.get("precision") == "float64" else 64 * 2.0 ** -24) * max(size, 1.0)
    for a, b in zip(anchored, exact):
        hit = b.object_id > 0
        np.testing.assert_array_equal(a.object_id > 0, hit)
        for name in ("depth", "event_time", "proper_time", "source_time"):
            x, y = getattr(a, name)[hit], getattr(b, name)[hit]
            both = np.isfinite(x) & np.isfinite(y)
            np.testing.assert_array_equal(np.isfinite(x), np.isfinite(y))
            assert np.abs(x[both] - y[both]).max(initial=0.0) <= tol, name
        assert np.abs(a.rgba - b.rgba).max() <= 1e-4  # colours from those events (float32 shading)


def test_frames_in_one_cell_share_one_recentred_geometry(monkeypatch):
    calls = []
    make = device_rigid.make_rigid_geometry

    def counted(*args):
        calls.append(args[-1].copy())
        return make(*args)

    monkeypatch.setattr(device_rigid, "make_rigid_geometry", counted)
    frames = [20.0 + 0.1 * i for i in range(8)]
    r, _ = _render(ROOT / "examples/animation/waving_flag.usda", frames, at_event=False, monkeypatch=monkeypatch)
    step = anchor_step(r.bvh.node_lo[0], r.bvh.node_hi[0])
    cells = {tuple(geometry_anchor(np.array([c.time, *c.position]), step)) for c in r._cameras.values()}
    assert len(calls) == len(cells) < len(frames)
