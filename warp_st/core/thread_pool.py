"""The process's thread pools, one per size, kept between calls (starting the threads
cost ~10 ms a frame): the renderer's tile launches (``wp.launch`` releases the GIL: two
threads give ~1.6-1.9x on two cores), an image's bands of rows, the bottom levels'
shapes, the bodies' triangle sets and the shapes' table gathers (NumPy releases the GIL
in them). A task must not wait for another task of the same pool: the BVH builder's level
splits, run inside the shapes' tasks, take a pool of another name (``accel/bvh.py``)."""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

__all__ = ["thread_pool"]

_POOLS: dict[tuple[int, int, str], ThreadPoolExecutor] = {}


def thread_pool(n_threads: int, name: str = "warp-st") -> ThreadPoolExecutor:
    """This process's pool ``name`` of ``n_threads`` threads; a forked child makes its own."""
    key = (os.getpid(), n_threads, name)
    pool = _POOLS.get(key)
    if pool is None:
        pool = _POOLS[key] = ThreadPoolExecutor(max_workers=n_threads, thread_name_prefix=name)
    return pool
