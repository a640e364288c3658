"""Warp, configured once for the renderer: errors only, no backward pass, the kernel cache
from ``WARP_CACHE_PATH``, and no CPU-only driver notice."""
from __future__ import annotations

import os

from warp_st.core.native_output import captured_output

__all__ = ["init_warp"]


def init_warp():
    """The ``warp`` module, configured (errors only, no backward pass, ``WARP_CACHE_PATH`` as
    the kernel cache) and initialised once without the CPU-only driver notice."""
    import warp as wp

    if not getattr(init_warp, "_ready", False):
        wp.config.log_level = 40  # errors only: no banner or per-module load lines
        wp.config.enable_backward = False
        cache = os.environ.get("WARP_CACHE_PATH")
        if cache:
            wp.config.kernel_cache_dir = cache
        _quiet_init(wp)
        init_warp._ready = True
    return wp


def _quiet_init(wp) -> None:
    """wp.init() without the native 'no CUDA driver' line on a CPU-only machine."""
    if os.environ.get("WARP_ST_DEBUG"):
        wp.init()
        return
    with captured_output():
        wp.init()
