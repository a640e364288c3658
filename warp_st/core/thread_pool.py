"""The process's thread pools, one per size and name, kept between calls (starting the
threads cost ~10 ms a frame): the renderer's tile launches (``each_on_threads``: the
calling thread and the pool's each take the next tile; ``wp.launch`` releases the GIL, so
two threads give ~1.6-1.9x on two cores), an image's bands of rows, the bottom levels'
shapes, the bodies' triangle sets and the shapes' table gathers (NumPy releases the GIL
in them). A task must not wait for another task of the same pool: the BVH builder's level
splits, run inside the shapes' tasks, take a pool of another name (``accel/bvh.py``)."""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["each_on_threads", "thread_pool"]

_POOLS: dict[tuple[int, int, str], ThreadPoolExecutor] = {}


def thread_pool(n_threads: int, name: str = "warp-st") -> ThreadPoolExecutor:
    """This process's pool ``name`` of ``n_threads`` threads; a forked child makes its own."""
    key = (os.getpid(), n_threads, name)
    pool = _POOLS.get(key)
    if pool is None:
        pool = _POOLS[key] = ThreadPoolExecutor(max_workers=n_threads, thread_name_prefix=name)
    return pool


def each_on_threads(fn, items, n_threads: int, name: str = "warp-st-each") -> None:
    """``fn(item)`` for every item of ``items`` on ``n_threads`` threads: the calling
    thread and ``n_threads`` - 1 of pool ``name``, each taking the next item until none is
    left. One task a thread, not one an item: a task per item (``pool.map``) hands each
    item to a worker and its result back, ~3 context switches an item, which on two
    threads cost the renderer's 64 tiles of a 512 x 512 frame ~1.3 ms of system time.
    After an exception no thread takes another item; the first one raised is raised
    here once every thread has stopped. ``fn`` must not call this with the same pool."""
    items = list(items)
    if n_threads <= 1 or len(items) <= 1:
        for item in items:
            fn(item)
        return
    lock = threading.Lock()
    source = iter(items)
    done = object()
    errors: list[BaseException] = []

    def work():
        while True:
            with lock:
                item = done if errors else next(source, done)
            if item is done:
                return
            try:
                fn(item)
            except BaseException as error:
                with lock:
                    errors.append(error)
                return

    pool = thread_pool(n_threads - 1, name)
    helpers = [pool.submit(work) for _ in range(min(n_threads, len(items)) - 1)]
    work()
    for helper in helpers:
        helper.result()
    if errors:
        raise errors[0]
