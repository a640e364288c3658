"""Kernel launches over a frame's tiles, each thread replaying one recorded launch."""
from __future__ import annotations

import threading

from warp_st.kernels.render_kernel import PIXELS_PER_THREAD

__all__ = ["tile_launches", "MAX_KEPT"]

#: Launches a ``kept`` dict holds at most (a thread and kernel each; the oldest go first):
#: callers on ever new threads would otherwise leave one behind per thread.
MAX_KEPT = 8

_lock = threading.Lock()  # a kept dict's entries change under it (threads of one call or of several)


def tile_launches(wp, kernel, inputs: list, per_thread: int = PIXELS_PER_THREAD, end: bool = True,
                  kept: dict | None = None):
    """``launch(tile)`` of ``kernel`` over tile = (first item, items): ``inputs``, then the
    tile's first item (and with ``end`` its end), a kernel thread per ``per_thread`` items
    (the pixel kernel's layout). Each thread packs its launch once
    (``wp.launch(record_cmd=True)``) and replays it with the tile's range set, instead of
    packing the inputs (the structs' ~40 arrays) under the GIL for every tile
    (docs/design/two-level.md).

    ``kept``: a dict, owned by the caller, that keeps each thread's recorded launch between
    calls (the renderer's: its database's). A thread's first tile then sets the launch's
    inputs again instead of recording a new one: ~35 us against ~70-110 us a thread and
    call, once the interpreter has run a frame's kernels since (docs/design/two-level.md).
    The dict holds each thread's last inputs until that thread's next call."""
    wp.load_module(kernel.module, device="cpu")  # before any thread records: two loading it at once crash
    exe = kernel.module.load("cpu", 1)  # the module's code a CPU launch (block size 1) runs
    kept = {} if kept is None else kept
    ready = set()  # the threads whose launch holds this call's inputs
    at = len(inputs)

    def launch(tile):
        first, count = tile
        dim = -(-count // per_thread)
        me = threading.get_ident()
        key = (kernel, per_thread, end, me)
        cmd = kept.get(key)
        if cmd is None or cmd[0].module_exec is not exe:  # none yet, or made before the module was reloaded
            cmd = [wp.launch(kernel, dim=dim, device="cpu", inputs=[*inputs, first, first + count][:at + 1 + end],
                             record_cmd=True), dim]
            with _lock:
                kept.pop(key, None)
                while len(kept) >= MAX_KEPT:
                    kept.pop(next(iter(kept)))
                kept[key] = cmd
            ready.add(me)
        else:
            if me not in ready:
                for index, value in enumerate(inputs):
                    cmd[0].set_param_at_index(index, value)
                ready.add(me)
            cmd[0].set_param_at_index(at, first)
            if end:
                cmd[0].set_param_at_index(at + 1, first + count)
            if dim != cmd[1]:
                cmd[0].set_dim(dim)
                cmd[1] = dim
        cmd[0].launch()

    return launch
