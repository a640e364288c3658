"""USD side of warp_st: the codeless schema plugin and the stage reader."""
from __future__ import annotations

import os
import sys
from pathlib import Path

SCHEMA_DIR = Path(__file__).resolve().parent / "schema"


def register_schemas() -> None:
    """Make ``SpacetimeBodyAPI`` / ``SpacetimeCameraAPI`` known to USD.

    Before the first ``pxr`` import this only extends ``PXR_PLUGINPATH_NAME`` (the
    plugin is then discovered with the built-in ones). If ``pxr`` is already
    imported, the plugin is registered directly; stages still read correctly
    without it (the reader looks at ``apiSchemas`` metadata and raw attributes).
    """
    path = str(SCHEMA_DIR)
    if "pxr" not in sys.modules:
        current = os.environ.get("PXR_PLUGINPATH_NAME", "")
        parts = [p for p in current.split(os.pathsep) if p]
        if path not in parts:
            os.environ["PXR_PLUGINPATH_NAME"] = os.pathsep.join([path, *parts])
    else:  # pragma: no cover - depends on import order in the host process
        from pxr import Plug

        Plug.Registry().RegisterPlugins([path])
