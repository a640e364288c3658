"""tile_launches: a thread's recorded launch replayed over tiles of any size covers each
tile's pixels once, on one thread or two (the renderer's tile loop); launches kept between
calls take each call's inputs, and a kept dict stays bounded."""
import numpy as np
import pytest
import warp as wp

from warp_st.core.thread_pool import each_on_threads
from warp_st.kernels.render_kernel import PIXELS_PER_THREAD
from warp_st.rendering.launches import MAX_KEPT, tile_launches
from warp_st.rendering.warp_init import init_warp

init_warp()


@wp.kernel(enable_backward=False, module="unique")
def _mark(hits: wp.array(dtype=wp.int32), offset: int, end: int):
    # The pixel kernel's layout: thread tid takes PIXELS_PER_THREAD pixels from offset, up to end.
    first = offset + wp.tid() * PIXELS_PER_THREAD
    for pixel in range(first, wp.min(first + PIXELS_PER_THREAD, end)):
        wp.atomic_add(hits, pixel, 1)


@pytest.mark.parametrize("threads", [1, 2])
def test_every_pixel_once_whatever_the_tile_sizes(threads):
    # A short tile first (its launch, recorded first, has 2 kernel threads), then full
    # tiles that need 64, then a short one again: a replay that kept the first launch's
    # size or range would leave pixels unmarked or mark some twice.
    sizes = [100, 4096, 4096, 3000, 4096, 50, 4096, 4096]
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    tiles = [(int(a), int(n)) for a, n in zip(starts, sizes)]
    hits = wp.zeros(int(sum(sizes)) + 64, dtype=wp.int32, device="cpu")
    each_on_threads(tile_launches(wp, _mark, [hits]), tiles, threads)
    out = hits.numpy()
    assert np.array_equal(out[:sum(sizes)], np.ones(sum(sizes), np.int32))
    assert not out[sum(sizes):].any()


@pytest.mark.parametrize("threads", [1, 2])
def test_a_kept_launch_takes_each_calls_inputs(threads):
    """Two calls keeping their launches in one dict (the renderer's database's), the second
    with another output array: each call marks its own array's pixels once, and a thread
    that ran both replays the launch it recorded in the first (re-set, not re-recorded)."""
    sizes = [4096, 100, 4096, 4096]
    tiles = [(int(a), int(n)) for a, n in zip(np.concatenate([[0], np.cumsum(sizes)[:-1]]), sizes)]
    kept = {}
    first, second = (wp.zeros(sum(sizes), dtype=wp.int32, device="cpu") for _ in range(2))
    each_on_threads(tile_launches(wp, _mark, [first], kept=kept), tiles, threads)
    recorded = {key[-1]: cmd[0] for key, cmd in kept.items()}
    each_on_threads(tile_launches(wp, _mark, [second], kept=kept), tiles, threads)
    assert np.array_equal(first.numpy(), np.ones(sum(sizes), np.int32))
    assert np.array_equal(second.numpy(), np.ones(sum(sizes), np.int32))
    assert 1 <= len(kept) <= threads
    assert any(kept[key][0] is recorded.get(key[-1]) for key in kept)  # the calling thread's, at least


def test_kept_launches_are_bounded():
    """Launches of threads that never come back go, oldest first: at most MAX_KEPT stay."""
    kept = {("gone", i): [None, 0] for i in range(MAX_KEPT)}
    hits = wp.zeros(100, dtype=wp.int32, device="cpu")
    tile_launches(wp, _mark, [hits], kept=kept)((0, 100))
    assert len(kept) == MAX_KEPT and ("gone", 0) not in kept
    assert np.array_equal(hits.numpy(), np.ones(100, np.int32))


def test_a_kept_launch_of_a_reloaded_module_is_recorded_again():
    """After the kernel's module is unloaded and loaded again, the kept launch (which holds
    the old module's code) is replaced by a new recording, and the call marks its pixels."""
    kept = {}
    hits = wp.zeros(100, dtype=wp.int32, device="cpu")
    tile_launches(wp, _mark, [hits], kept=kept)((0, 100))
    old = next(iter(kept.values()))[0]
    _mark.module.unload()
    tile_launches(wp, _mark, [hits], kept=kept)((0, 100))
    assert len(kept) == 1 and next(iter(kept.values()))[0] is not old
    assert np.array_equal(hits.numpy(), np.full(100, 2, np.int32))
