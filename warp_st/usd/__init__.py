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
    imported, the plugin is registered directly, which makes the schemas known
    only if ``Usd.SchemaRegistry`` has not been built yet (USD builds it once).
    Stages read the same either way: the reader looks at the ``apiSchemas``
    metadata and the raw attributes, with the SPEC fallbacks in code.
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
