"""One process-wide pool of worker threads, one per core, for independent host work.

NumPy and Warp's CPU launches release the GIL, so their work on two threads takes about
half the time. A task on this pool must not wait for other tasks of it (two waiting
tasks would hold both workers): the BVH builder's level splits have a pool of their own
(``accel/bvh.py``).
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["worker_pool", "worker_count"]

_POOL: list = []
_LOCK = threading.Lock()


def worker_count() -> int:
    """The pool's size: the machine's cores."""
    return os.cpu_count() or 1


def worker_pool() -> ThreadPoolExecutor:
    """The pool, started on first use."""
    with _LOCK:
        if not _POOL:
            _POOL.append(ThreadPoolExecutor(max_workers=worker_count(), thread_name_prefix="warp_st-worker"))
        return _POOL[0]
