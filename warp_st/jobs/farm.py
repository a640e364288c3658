"""Frames on Dask distributed workers (``warp-st render --workers N`` / ``--scheduler ADDRESS``).

A Dask task is one frame, rendered by :func:`warp_st.jobs.sequence.run_task`: each worker process
builds its renderer (stage load, extrusion, BVH) once per sequence, keeps it for the next
frames and writes each frame's files itself, atomically. So the workers and the planning
process must see the same filesystem under the same paths (always true of a LocalCluster;
on a real cluster: the stage, the layers it references and the output folder).

A worker that dies mid-frame: Dask sends its frames to another worker (up to
``distributed.scheduler.allowed-failures`` deaths per frame, then ``KilledWorker``); the
caller checks every frame's files at the end and renders whatever is still missing.
"""
from __future__ import annotations

import contextlib
import logging
import os
import time

from warp_st.jobs.tasks import forget_renderer, run_task

__all__ = ["LOCAL_FRAMES", "MIN_CORES", "default_workers", "run", "dask_setup"]

#: With ``workers=None``: sequences of at most this many frames render in this process ...
LOCAL_FRAMES = 16
#: ... and so does every sequence on a machine with fewer cores than this. On 2 cores a
#: LocalCluster was measured slower than this process (docs/pipeline.md): the renderer's
#: tile threads already use every core, and each worker loads the stage and builds the BVH.
MIN_CORES = 4


def default_workers(n_tasks: int) -> int:
    """Worker processes for ``workers=None``: 0 (this process) for up to :data:`LOCAL_FRAMES`
    frames or below :data:`MIN_CORES` cores, else one per core."""
    cores = os.cpu_count() or 1
    return 0 if n_tasks <= LOCAL_FRAMES or cores < MIN_CORES else cores


def dask_setup(worker) -> None:
    """Dask preload hook of the workers :func:`run` starts: ignore SIGINT.

    A terminal's ^C reaches the whole process group; the planning process then cancels
    the frames and closes the cluster, letting each worker finish the frame it is writing.
    """
    import signal

    with contextlib.suppress(ValueError):  # not the main thread
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _client(workers: int, scheduler):
    """(client, tile threads per frame): a LocalCluster of ``workers`` processes, or ``scheduler``'s."""
    from distributed import Client, LocalCluster

    if isinstance(scheduler, Client):
        yield scheduler, None
    elif scheduler is not None:
        with Client(scheduler, set_as_default=False) as client:
            yield client, None
    else:
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, memory_limit=0,
                          dashboard_address=None, silence_logs=logging.CRITICAL, preload=[__name__]) as cluster, \
                Client(cluster, set_as_default=False) as client:
            yield client, max(1, (os.cpu_count() or 1) // workers)


def _remote(task, scene, threads):
    """The Dask task: one frame on this worker, its tiles on ``threads`` threads
    (None: the cores shared among the worker's task threads)."""
    from distributed import get_worker

    worker = get_worker()
    if threads is None:
        threads = max(1, (os.cpu_count() or 1) // max(1, worker.state.nthreads))
    return run_task(task, scene, worker=worker.address, threads=threads)


def _with_memory_share(task, workers: int):
    """Without an explicit max_memory, each of ``workers`` local processes gets its share of the default."""
    import dataclasses

    from warp_st.core.limits import default_max_memory

    options = dict(task.options)
    limit = default_max_memory()
    if "max_memory" in options or limit is None:
        return task
    options["max_memory"] = limit // workers
    return dataclasses.replace(task, options=tuple(sorted(options.items())))


def _held(dask_worker) -> list:
    """Keys of the tasks this worker is about to run, runs or has finished (``client.run``)."""
    states = ("ready", "constrained", "executing", "long-running", "memory")
    return [key for key, ts in dask_worker.state.tasks.items() if ts.state in states]


@contextlib.contextmanager
def _deferred_signals():
    """Note SIGINT / SIGTERM / SIGHUP instead of acting on them inside Dask's calls (an
    exception raised there leaves its event loop in a mess); on leaving the block the first
    one noted is raised again under the handlers from before. A second signal acts at once.
    Yields the list of noted signals. Outside the main thread: nothing to do."""
    import signal
    import threading

    noted: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield noted
        return
    saved = {}

    def restore():
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        saved.clear()

    def note(signum, frame):
        noted.append(signum)
        if len(noted) > 1:
            restore()
            signal.raise_signal(signum)

    for sig in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is not None:
            saved[sig] = signal.signal(sig, note)
    try:
        yield noted
    finally:
        restore()
    if noted:
        signal.raise_signal(noted[0])


def run(tasks, scene, *, workers: int, scheduler, done) -> int:
    """Render ``tasks`` on a Dask cluster; ``done(index, result, build, value)`` as each finishes.

    scene: the Scene of in-memory sources (sent once to every worker) or None. Frames
    whose workers died too often are not passed to ``done``. ^C / SIGTERM: the frames
    still queued on the scheduler are cancelled, the ones the workers hold (one or two
    each) are finished and reported, then the signal acts (a second one acts at once).
    Returns the number of workers.
    """
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    with _deferred_signals() as signals, _client(workers, scheduler) as (client, threads):
        if scheduler is None:
            tasks = [_with_memory_share(t, workers) for t in tasks]
        scene_arg = client.scatter(scene, broadcast=True, hash=False) if scene is not None else None
        futures = [client.submit(_remote, task, scene_arg, threads, pure=False) for task in tasks]
        index = {f.key: i for i, f in enumerate(futures)}
        reported: set = set()

        def collect(batch, errors=(KilledWorker,), until=lambda: False):
            finished = as_completed(batch, loop=client.loop)
            while not finished.is_empty() and not until():
                for future in finished.next_batch(block=False):
                    if future.cancelled():
                        continue
                    try:
                        outcome = future.result()
                    except errors:
                        continue  # a KilledWorker frame is left for the caller to render
                    reported.add(future.key)
                    done(index[future.key], *outcome)
                time.sleep(0.02)

        try:
            collect(futures, until=lambda: bool(signals))
            if signals:  # the workers finish the frames they hold; the rest is cancelled
                held = {key for keys in client.run(_held).values() for key in keys}
                client.cancel([f for f in futures if f.key not in held and not f.done()])
                collect([f for f in futures if f.key not in reported and (f.key in held or f.done())],
                        errors=Exception)
        except BaseException:
            client.cancel(futures)
            raise
        finally:
            if scheduler is not None:  # a cluster that outlives us: free the workers' databases
                with contextlib.suppress(Exception):
                    client.run(forget_renderer)
        return len(client.nthreads())
