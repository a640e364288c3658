"""Kernel launches over a frame's tiles, each thread replaying one recorded launch."""
from __future__ import annotations

import threading

from warp_st.kernels.render_kernel import PIXELS_PER_THREAD

__all__ = ["tile_launches"]


def tile_launches(wp, kernel, inputs: list, per_thread: int = PIXELS_PER_THREAD, end: bool = True):
    """``launch(tile)`` of ``kernel`` over tile = (first item, items): ``inputs``, then the
    tile's first item (and with ``end`` its end), a kernel thread per ``per_thread`` items
    (the pixel kernel's layout). Each thread packs its launch once
    (``wp.launch(record_cmd=True)``) and replays it with the tile's range set, instead of
    packing the inputs (the structs' ~40 arrays) under the GIL for every tile
    (docs/design/two-level.md)."""
    wp.load_module(kernel.module, device="cpu")  # before any thread records: two loading it at once crash
    recorded = {}  # thread -> [launch, its dim]
    at = len(inputs)

    def launch(tile):
        first, count = tile
        dim = -(-count // per_thread)
        cmd = recorded.get(threading.get_ident())
        if cmd is None:
            cmd = recorded[threading.get_ident()] = [
                wp.launch(kernel, dim=dim, device="cpu", inputs=[*inputs, first, first + count][:at + 1 + end],
                          record_cmd=True), dim]
        else:
            cmd[0].set_param_at_index(at, first)
            if end:
                cmd[0].set_param_at_index(at + 1, first + count)
            if dim != cmd[1]:
                cmd[0].set_dim(dim)
                cmd[1] = dim
        cmd[0].launch()

    return launch
