"""warp_st: a special-relativistic spacetime renderer.

Objects are temporally extruded into 4D (tetrahedra in (t, x, y, z)), light rays are
straight null lines on the camera's past lightcone (c = 1), and animation emerges
from advancing the camera's time. See SPEC.md for the contract.
"""
from __future__ import annotations

from .usd import register_schemas as _register_schemas

_register_schemas()  # must run before the first pxr import

from .conventions import LightSpeed, Precision  # noqa: E402
from .scene import Scene, SceneError  # noqa: E402

__version__ = "0.3.3"

__all__ = [
    "__version__",
    "LightSpeed",
    "Precision",
    "Scene",
    "SceneError",
    "load",
    "render",
    "read_exr",
    "Image",
    "render_sequence",
    "sweep",
]


def load(source, **kwargs) -> Scene:
    """Read a USD stage (a path or a ``Usd.Stage``) into a :class:`Scene`."""
    from .usd.reader import load_scene

    return load_scene(source, **kwargs)


def render(scene, **kwargs):
    """Render one frame of ``scene``; see :func:`warp_st.renderer.render_frame`."""
    from .renderer import render_frame

    return render_frame(scene, **kwargs)


def read_exr(path):
    """Read an EXR written by warp_st back into an :class:`Image` (absolute float64 times)."""
    from .exr import read_exr as _read

    return _read(path)


def __getattr__(name):
    if name == "Image":
        from .film import Image

        return Image
    if name in ("render_sequence", "sweep"):
        from . import sequence

        return getattr(sequence, name)
    raise AttributeError(name)
