"""One rendered frame: :class:`Image`, its planes and header values (docs/spec.md §4).

The channels themselves are described once, in :mod:`warp_st.output.channels`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from warp_st.output.channels import (  # noqa: F401 - re-exported for callers of the Image API
    _FIELD_DTYPES,
    CHANNEL_NAMES,
    CHANNELS,
    LOW_TIME_CHANNELS,
    REQUIRED_CHANNELS,
    ChannelSpec,
    OutputChannel,
    absolute_time,
    channel_spec,
    join_time,
    quantize_time,
    relative_f32,
)

__all__ = ["Image", "read_exr", "quantize_relative"]


#: dtypes an extra (non-SPEC) channel may have: what EXR stores (HALF, FLOAT, UINT).
_EXTRA_DTYPES = (np.dtype(np.float16), np.dtype(np.float32), np.dtype(np.uint32))


def quantize_relative(relative, origin: float, out=None, scratch=None) -> np.ndarray:
    """``quantize_time(float64(relative) + origin, origin)``, bit for bit: the same
    float64 operations in the same order, in one buffer (a render's time planes from its
    relative kernel times, a pass each instead of six arrays). ``out``: the float64
    result's array (else a new one); ``scratch``: a float32 array of the same shape the
    rounding may overwrite (it may be ``relative`` itself), else a temporary."""
    out = np.empty(np.shape(relative), dtype=np.float64) if out is None else out
    np.copyto(out, relative, casting="unsafe")  # float32 or float64: exact in float64
    origin = np.float64(origin)
    out += origin  # the absolute time ...
    out -= origin  # ... relative again (relative_f32, in float64) ...
    rounded = out.astype(np.float32) if scratch is None else scratch
    if scratch is not None:
        np.copyto(rounded, out, casting="unsafe")
    np.copyto(out, rounded)  # ... rounded to float32, as the EXR stores it
    out += origin  # absolute_time
    return out


def _plane(shape: tuple[int, int], spec: ChannelSpec) -> np.ndarray:
    return np.full(shape, spec.background, dtype=_FIELD_DTYPES[spec.attribute])


@dataclass(eq=False)
class Image:
    """One rendered frame: numpy planes plus the header values of its EXR.

    rgba: beauty, linear, shape (H, W, 4) float32; A = 0 on background.
    depth: Z, distance to the first hit in the camera's rest frame, (H, W)
        float32; +inf on background.
    event_time: lab time of the first-hit event, ABSOLUTE, (H, W) float64; NaN on
        background. See :func:`quantize_time` for exact EXR round trips.
    proper_time: the hit body's proper time at that event, (H, W) float32; NaN.
    doppler: received / emitted frequency, (H, W) float32; NaN on background.
    object_id: 1 + body index in stage traversal order, (H, W) uint32; 0.
    source_time: lab time of the last non-mirror event on the path, ABSOLUTE,
        (H, W) float64; NaN on background.
    bounces: mirror reflections up to that event, (H, W) uint32; 0.

    Planes left as None are filled with their background value. Header values:
    camera_time (t_c), time_origin (defaults to camera_time), frame (USD time
    code), precision, id_manifest (objectId -> prim path), metadata (extra string
    attributes, written as ``spacetime:<key>``; the writer adds ``version``),
    channels: the docs/spec.md §4 channels held (None = all; a file read back lists those
    it had), and extra: channels outside docs/spec.md §4 read from a file (renamed
    RenderVar outputs such as ``beauty.R``) or rendered as Cryptomatte rank channels
    (``CryptoObject00.R``, docs/spec.md §4.4), name -> (H, W) array as stored
    (float16, float32 or uint32; a renamed eventTime is relative to time_origin).
    cryptomatte: the Cryptomatte layers held in ``extra``, typename -> manifest (name ->
    8 hex digits of its id), written to and read from the ``cryptomatte/<key>/*`` header.
    """

    rgba: np.ndarray
    depth: np.ndarray | None = None
    event_time: np.ndarray | None = None
    proper_time: np.ndarray | None = None
    doppler: np.ndarray | None = None
    object_id: np.ndarray | None = None
    source_time: np.ndarray | None = None
    bounces: np.ndarray | None = None
    camera_time: float = 0.0
    time_origin: float | None = None
    frame: float = 0.0
    precision: str = "float32"
    id_manifest: dict[int, str] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    channels: tuple[str, ...] | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    cryptomatte: dict[str, dict[str, str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        rgba = np.ascontiguousarray(self.rgba, dtype=np.float32)
        if rgba.ndim != 3 or rgba.shape[2] != 4:
            raise ValueError(f"Image.rgba must have shape (H, W, 4), got {rgba.shape}")
        self.rgba = rgba
        shape = rgba.shape[:2]
        for spec in CHANNELS:
            if spec.component is not None:
                continue
            value = getattr(self, spec.attribute)
            if value is None:
                value = _plane(shape, spec)
            else:
                value = np.ascontiguousarray(value, dtype=_FIELD_DTYPES[spec.attribute])
                if value.shape != shape:
                    raise ValueError(f"Image.{spec.attribute} must have shape {shape}, got {value.shape}")
            setattr(self, spec.attribute, value)
        self.camera_time = float(self.camera_time)
        self.time_origin = self.camera_time if self.time_origin is None else float(self.time_origin)
        self.frame = float(self.frame)
        self.precision = str(self.precision.value if hasattr(self.precision, "value") else self.precision)
        self.id_manifest = {int(k): str(v) for k, v in dict(self.id_manifest).items()}
        self.metadata = {str(k): str(v) for k, v in dict(self.metadata).items()}
        if self.channels is not None:
            names = tuple(self.channels)
            for name in names:
                channel_spec(name)
            self.channels = tuple(n for n in CHANNEL_NAMES if n in names)  # SPEC order, no duplicates
        extra = {}
        for name, value in dict(self.extra).items():
            value = np.ascontiguousarray(value)
            if name in CHANNEL_NAMES or value.shape != shape or value.dtype not in _EXTRA_DTYPES:
                raise ValueError(f"Image.extra[{name!r}] must be a non-SPEC name with a {shape} "
                                 f"float16, float32 or uint32 array, got {value.dtype} {value.shape}")
            extra[str(name)] = value
        self.extra = extra
        self.cryptomatte = {str(k): {str(n): str(i) for n, i in dict(v).items()}
                            for k, v in dict(self.cryptomatte).items()}

    @property
    def height(self) -> int:
        return int(self.rgba.shape[0])

    @property
    def width(self) -> int:
        return int(self.rgba.shape[1])

    @property
    def channel_names(self) -> tuple[str, ...]:
        """The channels this image holds and writes: SPEC ones (SPEC order), then the extras."""
        return (self.channels if self.channels is not None else CHANNEL_NAMES) + tuple(self.extra)

    def channel(self, name: str) -> np.ndarray:
        """The (H, W) plane of channel ``name``; eventTime / sourceTime absolute float64.

        R, G, B, A are views into ``rgba``; an extra channel is returned as stored.
        """
        if name in self.extra:
            return self.extra[name]
        spec = channel_spec(name)
        value = getattr(self, spec.attribute)
        return value[..., spec.component] if spec.component is not None else value

    # --- Jupyter ----------------------------------------------------------------------------

    def _repr_png_(self) -> bytes:
        """Jupyter shows an Image as its beauty (8-bit sRGB, ``warp_st.output.plot``)."""
        from warp_st.output.plot import beauty_png

        return beauty_png(self)

    def show(self, channel: str | None = None):
        """A Jupyter view of ``channel`` in false colour with a colour bar labelled with its
        units (None: the beauty); ``.figure()`` gives the matplotlib figure."""
        from warp_st.output.plot import ChannelView

        return ChannelView(self, channel)

    # --- the file form (used by warp_st.output.exr; no OpenEXR here) ----------------------

    def file_channel(self, name: str) -> np.ndarray:
        """Channel ``name`` as stored in the EXR: float32 or uint32, contiguous (H, W).

        eventTime / sourceTime become :func:`relative_f32` of the time origin; an extra
        channel is returned as stored.
        """
        if name in self.extra:
            return self.extra[name]
        spec = channel_spec(name)
        value = self.channel(name)
        if spec.relative_time:
            value = relative_f32(value, self.time_origin)
        return np.ascontiguousarray(value, dtype=spec.file_dtype)

    @classmethod
    def from_file_channels(
        cls,
        planes: Mapping[str, np.ndarray],
        *,
        time_origin: float,
        extra: Mapping[str, np.ndarray] | None = None,
        **header,
    ) -> "Image":
        """Inverse of :meth:`file_channel`: build an Image from stored planes.

        planes: SPEC channel name -> (H, W) stored array; extra: the file's other
        channels; at least one in all. Channels of docs/spec.md §4 that are absent are filled
        with their background values (R, G, B, A with 0) and ``channels`` records
        which were present (None when all were).
        """
        extra = dict(extra or {})
        if not planes and not extra:
            raise KeyError("no channels")
        shape = np.shape(next(iter({**planes, **extra}.values())))
        rgba = np.stack([np.asarray(planes[n], dtype=np.float32) if n in planes else np.zeros(shape, np.float32)
                         for n in ("R", "G", "B", "A")], axis=-1)
        fields = {}
        for spec in CHANNELS:
            if spec.component is not None or spec.name not in planes:
                continue
            stored = np.asarray(planes[spec.name], dtype=spec.file_dtype)
            low = extra.get(LOW_TIME_CHANNELS.get(spec.name, ""))
            if low is not None and low.dtype == np.float32 and low.shape == stored.shape:
                fields[spec.attribute] = join_time(stored, low, time_origin)  # a float64 render's times
            else:
                fields[spec.attribute] = absolute_time(stored, time_origin) if spec.relative_time else stored
        present = tuple(n for n in CHANNEL_NAMES if n in planes)
        channels = None if present == CHANNEL_NAMES else present
        return cls(rgba=rgba, time_origin=time_origin, channels=channels, extra=extra, **fields, **header)

    # --- convenience ------------------------------------------------------------

    def write_exr(self, path, channels=None) -> None:
        """Write this frame to ``path`` atomically: every channel, or the
        :class:`OutputChannel` list ``channels`` (see :func:`warp_st.output.exr.write_exr`)."""
        from warp_st.output.exr import write_exr

        write_exr(self, path, channels)

    def replace(self, **changes) -> "Image":
        """A copy with some fields replaced (arrays are shared, not copied)."""
        return dataclasses.replace(self, **changes)


def read_exr(path) -> Image:
    """Read an EXR written by warp_st (or any other scanline EXR) into an :class:`Image`.

    eventTime / sourceTime come back absolute, float64 (channel + spacetime:timeOrigin).
    SPEC channels absent from the file are filled with their background values and
    ``Image.channels`` lists those present; channels with other names (renamed
    RenderVars) are kept as stored in ``Image.extra``. A missing, corrupt or non-EXR
    file raises :class:`warp_st.SceneError` naming the file.
    """
    from warp_st.core.scene import SceneError
    from warp_st.output.exr import read_file

    decoded = read_file(path)
    try:
        return Image.from_file_channels(decoded.pop("planes"), **decoded)
    except (KeyError, ValueError, TypeError) as exc:  # a damaged or foreign header
        raise SceneError(f"{path}: {exc}") from None
