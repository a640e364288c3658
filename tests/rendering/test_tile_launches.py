"""tile_launches: a thread's recorded launch replayed over tiles of any size covers each
tile's pixels once, on one thread or two (the renderer's tile loop)."""
import numpy as np
import pytest
import warp as wp

from warp_st.core.thread_pool import each_on_threads
from warp_st.kernels.render_kernel import PIXELS_PER_THREAD
from warp_st.rendering.launches import tile_launches
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
