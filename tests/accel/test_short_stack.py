"""The rigid top level's short traversal stack (traverse.stack_for, SHORT_STACK).

Laws: a tree of L binary levels has at most (L + 1) // 2 wide levels (bvh_wide.collapse),
so ``stack_for`` gives it three entries per wide level or the full stack; the renderer
takes the short stack's kernels for a top level that fits and the full stack's for one
that does not, and the images (every plane) and node visits are the full stack's, bit for
bit (a traversal is the same whatever its stack's length, until the stack would fill).
"""
from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import warp_st
from warp_st.accel.bvh import build_bvh
from warp_st.accel.bvh_wide import collapse
from warp_st.kernels import traverse
from warp_st.kernels.traverse import SHORT_STACK, STACK_SIZE, stack_for
from warp_st.rendering.renderer import Renderer

ROOT = Path(__file__).resolve().parents[2]
CHANNELS = ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id", "source_time", "bounces")


@pytest.mark.parametrize("n", [1, 2, 3, 7, 40, 300, 5000, 40000])
def test_the_stack_holds_three_entries_per_wide_level(n):
    rng = np.random.default_rng(n)
    lo = np.concatenate([rng.uniform(-1, 1, (n, 1)), rng.uniform(-50, 50, (n, 3))], axis=1)
    hi = lo + rng.uniform(0.01, 3.0, (n, 4))
    bvh = build_bvh(lo, hi, "rigid", leaf_size=1)
    wide = collapse(bvh).depth
    assert wide <= (bvh.depth + 1) // 2
    assert stack_for(bvh.depth) >= 3 * wide
    assert stack_for(bvh.depth) in (SHORT_STACK, STACK_SIZE)


def _planes(img) -> dict:
    return {c: np.ascontiguousarray(getattr(img, c)).tobytes() for c in CHANNELS}


@pytest.mark.parametrize("stage", ["relativistic_parade.usda", "mirrors/flanges_coupled.usda", "thesis/colour_cube.usda"])
def test_short_stack_images_are_the_full_stacks(stage, monkeypatch):
    scene = warp_st.load(str(ROOT / "usd_scenes" / stage))
    short = Renderer(scene, frames=[0.0], width=64, height=36)
    assert short.kernels.stack == SHORT_STACK  # the shipped stages' top levels fit
    a = short.render(0.0)
    visits_short = short.stats.last_mean_visits
    monkeypatch.setattr(traverse, "stack_for", lambda levels: STACK_SIZE)
    full = Renderer(dataclasses.replace(scene), frames=[0.0], width=64, height=36)
    assert full.kernels.stack == STACK_SIZE
    b = full.render(0.0)
    assert _planes(a) == _planes(b)
    assert visits_short == full.stats.last_mean_visits


def test_a_deep_top_level_takes_the_full_stack():
    """The benchmark's 1,000 moving cubes: a top level of 27 binary levels."""
    spec = importlib.util.spec_from_file_location("bench_two_level_cubes",
                                                  ROOT / "examples" / "benchmarks" / "bench_two_level.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    r = Renderer(bench.cubes_scene(1000, moving=True), frames=[0.0], width=32, height=32)
    assert stack_for(r.database.bvh.depth) == STACK_SIZE and r.kernels.stack == STACK_SIZE
    r.render(0.0)  # no overflow (the renderer raises on one)
