"""Image files -> float32 linear texels through OpenImageIO (PNG, JPEG, EXR, and every
other format OIIO reads): the textures of ``UsdUVTexture`` and, later, the sky.

``read_image(path, color_space)`` returns the image as an (H, W, C) float32 array, row 0
the top of the image, with the colour channels decoded to linear:

- ``"raw"``: the stored values (8/16-bit integers as value / max);
- ``"sRGB"``: the sRGB transfer curve removed from the colour channels (alpha stays as
  stored);
- ``"auto"``: the file's own colour-space metadata (OIIO's ``oiio:ColorSpace``) when it
  names one: sRGB when the name says so, raw (linear) otherwise; without it, sRGB for
  8-bit integer data and raw for everything else.

The wrap modes a file declares (``wrapmodes`` metadata, e.g. ``"periodic,clamp"`` in
``.tx`` files) come back as UsdUVTexture tokens for ``wrapS/wrapT = useMetadata``.
A file that cannot be read raises :class:`ImageError` with OIIO's reason. An image inside
a USDZ package (a package-relative path, ``pkg.usdz[inner.png]``, as USD resolves it) is
read through USD's own asset resolver (``Ar``) into a temporary file OIIO opens.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from dataclasses import dataclass

import numpy as np
from pxr import Ar

__all__ = ["ImageError", "Image", "read_image", "srgb_to_linear", "COLOR_SPACES"]

#: UsdUVTexture's sourceColorSpace tokens.
COLOR_SPACES = ("raw", "sRGB", "auto")

#: OIIO's wrap-mode names -> UsdUVTexture's wrap tokens.
_WRAPS = {"periodic": "repeat", "clamp": "clamp", "black": "black", "mirror": "mirror"}


class ImageError(OSError):
    """An image file that cannot be opened or decoded (the message says why)."""


@dataclass(frozen=True, eq=False)
class Image:
    """Linear texels (H, W, C) float32, row 0 at the top; the colour space applied
    ("raw" or "sRGB"); the file's wrap modes (s, t) as UsdUVTexture tokens, or None."""

    texels: np.ndarray
    color_space: str
    wraps: tuple[str, str] | None = None


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    """The sRGB electro-optical transfer function (IEC 61966-2-1), elementwise."""
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


@contextlib.contextmanager
def _local_file(path: str):
    """``path`` itself, or for a package-relative path (an image inside a USDZ) a temporary
    copy of the packaged file's bytes, read through ``Ar`` (removed afterwards)."""
    if not Ar.IsPackageRelativePath(path):
        yield path
        return
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(path))
    if asset is None:
        raise ImageError(f"cannot open {path} in its package")
    inner = Ar.SplitPackageRelativePathInner(path)[1]
    fd, local = tempfile.mkstemp(suffix=os.path.splitext(inner)[1])
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(asset.GetBuffer())
        yield local
    finally:
        os.unlink(local)


def read_image(path: str, color_space: str = "auto") -> Image:
    """The image at ``path`` decoded to linear float32 (see the module docstring)."""
    if color_space not in COLOR_SPACES:
        raise ValueError(f"color_space must be one of {', '.join(COLOR_SPACES)}, got {color_space!r}")
    with _local_file(str(path)) as local:
        return _read_local(local, path, color_space)


def _read_local(local: str, path: str, color_space: str) -> Image:
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(local)
    if inp is None:
        raise ImageError(oiio.geterror() or f"cannot open {path}")
    try:
        spec = inp.spec()
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
        if pixels is None:
            raise ImageError(inp.geterror() or f"cannot read the pixels of {path}")
        declared = str(spec.getattribute("oiio:ColorSpace") or "")
        integer8 = spec.format.basetype in (oiio.UINT8, oiio.INT8)
        wrapmodes = str(spec.getattribute("wrapmodes") or "")
    finally:
        inp.close()
    texels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    if color_space == "auto":
        if declared:
            color_space = "sRGB" if "srgb" in declared.lower() else "raw"
        else:
            color_space = "sRGB" if integer8 else "raw"
    if color_space == "sRGB":
        colour = min(3, texels.shape[2]) if texels.shape[2] != 2 else 1  # grey+alpha: one colour channel
        texels = texels.copy()
        texels[..., :colour] = srgb_to_linear(texels[..., :colour])
    wraps = None
    modes = [_WRAPS.get(m.strip().lower()) for m in wrapmodes.split(",")] if wrapmodes else []
    if modes and all(modes):
        wraps = (modes[0], modes[-1])
    return Image(texels=texels, color_space=color_space, wraps=wraps)
