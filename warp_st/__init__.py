"""warp_st: a special-relativistic spacetime renderer.

Objects are temporally extruded into 4D (tetrahedra in (t, x, y, z)), light rays are
straight null lines on the camera's past lightcone (c = 1), and animation emerges
from advancing the camera's time. See docs/spec.md for the contract.
"""
from __future__ import annotations

from warp_st.usd import register_schemas as _register_schemas

_register_schemas()  # must run before the first pxr import

from warp_st.core.conventions import LightSpeed, Precision  # noqa: E402
from warp_st.core.scene import Scene, SceneError  # noqa: E402
from warp_st.core.version import __version__  # noqa: E402

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
    from warp_st.usd.reader import load_scene

    return load_scene(source, **kwargs)


def render(scene, **kwargs):
    """Render one frame of ``scene``; see :func:`warp_st.rendering.render_call.render_frame`."""
    from warp_st.rendering.render_call import render_frame

    return render_frame(scene, **kwargs)


def read_exr(path):
    """Read an EXR written by warp_st back into an :class:`Image` (absolute float64 times)."""
    from warp_st.output.film import read_exr as _read

    return _read(path)


def __getattr__(name):
    if name == "Image":
        from warp_st.output.film import Image

        return Image
    if name in ("render_sequence", "sweep"):
        from warp_st.jobs import sequence

        return getattr(sequence, name)
    raise AttributeError(name)
