"""One rendered frame and the AOV registry (SPEC §4).

:data:`CHANNELS` is the single table of EXR channels: name, pixel type, which
:class:`Image` attribute holds it, the background value and the units. The EXR
writer and reader (``warp_st.exr``), the ``inspect`` command and
:meth:`Image.channel` all go through it, so a channel is added in one place.

Times. ``spacetime.eventTime`` and ``spacetime.sourceTime`` are lab times. In
memory they are absolute float64; in the file they are float32 *relative* to the
header's ``spacetime:timeOrigin`` (the renderer sets it to the camera time), so a
frame at t = 1e9 keeps float32's ~7 significant digits on the lookback rather
than on the absolute time. :func:`relative_f32` is the one conversion the writer
uses; :func:`quantize_time` is what the renderer applies to its absolute times so
that the in-memory image already equals what a round trip through the file gives
back (write -> read is then bitwise exact, see :func:`quantize_time`).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Mapping, NamedTuple

import numpy as np

__all__ = [
    "ChannelSpec",
    "CHANNELS",
    "CHANNEL_NAMES",
    "REQUIRED_CHANNELS",
    "channel_spec",
    "relative_f32",
    "absolute_time",
    "quantize_time",
    "OutputChannel",
    "Image",
]


@dataclass(frozen=True)
class ChannelSpec:
    """One EXR channel of SPEC §4.

    name: the EXR channel name.
    pixel_type: "FLOAT" (stored float32) or "UINT" (stored uint32).
    attribute: the :class:`Image` field holding it.
    component: index into the last axis of that field (R, G, B, A of ``rgba``),
        or None for a (H, W) field.
    background: the value of a pixel whose primary ray hits nothing; also the
        fill value for a channel absent from a file. (R, G, B carry the
        background colour on such pixels; 0 is only their fill value.)
    relative_time: stored as float32 (absolute - spacetime:timeOrigin).
    units: label for plots and ``inspect``.
    required: a file written with every channel that lacks it is incomplete
        (``--resume`` renders it again); RenderVar files may hold any subset.
    """

    name: str
    pixel_type: str
    attribute: str
    component: int | None
    background: float
    relative_time: bool = False
    units: str = ""
    required: bool = False

    @property
    def file_dtype(self) -> np.dtype:
        """dtype of the array stored in the EXR file."""
        return np.dtype(np.uint32) if self.pixel_type == "UINT" else np.dtype(np.float32)


#: SPEC §4, in the order of the table. The single source of truth for channel names.
CHANNELS: tuple[ChannelSpec, ...] = (
    ChannelSpec("R", "FLOAT", "rgba", 0, 0.0, units="linear radiance", required=True),
    ChannelSpec("G", "FLOAT", "rgba", 1, 0.0, units="linear radiance", required=True),
    ChannelSpec("B", "FLOAT", "rgba", 2, 0.0, units="linear radiance", required=True),
    ChannelSpec("A", "FLOAT", "rgba", 3, 0.0, units="coverage (ratio)", required=True),
    ChannelSpec("Z", "FLOAT", "depth", None, math.inf, units="length units (camera rest frame)"),
    ChannelSpec(
        "spacetime.eventTime", "FLOAT", "event_time", None, math.nan,
        relative_time=True, units="time units (lab, c = 1)",
    ),
    ChannelSpec("spacetime.properTime", "FLOAT", "proper_time", None, math.nan, units="time units (proper)"),
    ChannelSpec("spacetime.doppler", "FLOAT", "doppler", None, math.nan, units="ratio (received / emitted)"),
    ChannelSpec("objectId", "UINT", "object_id", None, 0, units="objectId (1 + body index)"),
    ChannelSpec(
        "spacetime.sourceTime", "FLOAT", "source_time", None, math.nan,
        relative_time=True, units="time units (lab, c = 1)",
    ),
    ChannelSpec("spacetime.bounces", "UINT", "bounces", None, 0, units="count (mirror reflections)"),
)

CHANNEL_NAMES: tuple[str, ...] = tuple(c.name for c in CHANNELS)
REQUIRED_CHANNELS: tuple[str, ...] = tuple(c.name for c in CHANNELS if c.required)
_BY_NAME = {c.name: c for c in CHANNELS}

#: In-memory dtype of each (H, W) Image field; rgba is (H, W, 4) float32.
_FIELD_DTYPES: dict[str, np.dtype] = {
    "rgba": np.dtype(np.float32),
    "depth": np.dtype(np.float32),
    "event_time": np.dtype(np.float64),
    "proper_time": np.dtype(np.float32),
    "doppler": np.dtype(np.float32),
    "object_id": np.dtype(np.uint32),
    "source_time": np.dtype(np.float64),
    "bounces": np.dtype(np.uint32),
}


def channel_spec(name: str) -> ChannelSpec:
    """The registry entry for ``name``; KeyError listing the known names otherwise."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(f"unknown channel {name!r}; known: {', '.join(CHANNEL_NAMES)}") from None


def relative_f32(absolute, origin: float) -> np.ndarray:
    """float32 (absolute - origin), the subtraction done in float64.

    absolute: lab times, float64, any shape; NaN stays NaN, +-inf stays +-inf.
    This is how eventTime / sourceTime are stored in the EXR.
    """
    return (np.asarray(absolute, dtype=np.float64) - np.float64(origin)).astype(np.float32)


def absolute_time(relative, origin: float) -> np.ndarray:
    """float64(relative) + origin: the absolute lab times read back from a file."""
    return np.asarray(relative, dtype=np.float32).astype(np.float64) + np.float64(origin)


def quantize_time(absolute, origin: float) -> np.ndarray:
    """``absolute_time(relative_f32(absolute, origin), origin)``.

    The renderer stores its event / source times through this so that the Image it
    returns equals what reading its EXR back gives, bit for bit. The map is
    idempotent: if a = q(x) then a - origin is exact in float64 (Sterbenz, or
    ``a`` is an exact sum) and representable in float32 (its granularity is the
    coarser of the float32 ulp of the relative time and the float64 ulp of ``a``),
    so q(a) = a.
    """
    return absolute_time(relative_f32(absolute, origin), origin)


class OutputChannel(NamedTuple):
    """One channel of a written file: its EXR name, the channel it holds (a SPEC §4
    name, or an extra channel of the image) and whether a FLOAT is stored as HALF."""

    name: str
    source: str
    half: bool = False


#: dtypes an extra (non-SPEC) channel may have: what EXR stores (HALF, FLOAT, UINT).
_EXTRA_DTYPES = (np.dtype(np.float16), np.dtype(np.float32), np.dtype(np.uint32))


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
    channels: the SPEC §4 channels held (None = all; a file read back lists those
    it had), and extra: channels outside SPEC §4 read from a file (renamed
    RenderVar outputs such as ``beauty.R``), name -> (H, W) array as stored
    (float16, float32 or uint32; a renamed eventTime is relative to time_origin).
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

    # --- the file form (used by warp_st.exr; no OpenEXR here) ----------------------

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
        channels; at least one in all. Channels of SPEC §4 that are absent are filled
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
            fields[spec.attribute] = absolute_time(stored, time_origin) if spec.relative_time else stored
        present = tuple(n for n in CHANNEL_NAMES if n in planes)
        channels = None if present == CHANNEL_NAMES else present
        return cls(rgba=rgba, time_origin=time_origin, channels=channels, extra=extra, **fields, **header)

    # --- convenience ------------------------------------------------------------

    def write_exr(self, path, channels=None) -> None:
        """Write this frame to ``path`` atomically: every channel, or the
        :class:`OutputChannel` list ``channels`` (see :func:`warp_st.exr.write_exr`)."""
        from .exr import write_exr

        write_exr(self, path, channels)

    def replace(self, **changes) -> "Image":
        """A copy with some fields replaced (arrays are shared, not copied)."""
        return dataclasses.replace(self, **changes)
