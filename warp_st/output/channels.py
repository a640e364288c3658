"""The AOV registry (docs/spec.md §4): every EXR channel, its type, attribute, background and units.

:data:`CHANNELS` is the single table of EXR channels: name, pixel type, which
:class:`Image` attribute holds it, the background value and the units. The EXR
writer and reader (``warp_st.output.exr``), the ``inspect`` command and
:meth:`Image.channel` all go through it, so a channel is added in one place.

Times. ``spacetime.eventTime`` and ``spacetime.sourceTime`` are lab times. In
memory they are absolute float64; in the file they are float32 *relative* to the
header's ``spacetime:timeOrigin`` (the renderer sets it to the camera time), so a
frame at t = 1e9 keeps float32's ~7 significant digits on the lookback rather
than on the absolute time. :func:`relative_f32` is the one conversion the writer
uses; :func:`quantize_time` is what the renderer applies to its absolute times so
that the in-memory image already equals what a round trip through the file gives
back (write -> read is then bitwise exact, see :func:`quantize_time`).

Float64 renders keep more: each time channel gets a companion ``<name>Low`` (an extra
float32 channel, :data:`LOW_TIME_CHANNELS`) holding the rounding residual of the float32
relative time, so hi + lo carries ~48 bits of the lookback (:func:`split_time`,
:func:`join_time`; docs/spec.md §4).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

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
    "split_time",
    "join_time",
    "LOW_TIME_CHANNELS",
    "OutputChannel",
]


@dataclass(frozen=True)
class ChannelSpec:
    """One EXR channel of docs/spec.md §4.

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


#: docs/spec.md §4, in the order of the table. The single source of truth for channel names.
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
#: Time channel -> its float64 renders' residual channel (an Image extra, module docstring).
LOW_TIME_CHANNELS: dict[str, str] = {c.name: c.name + "Low" for c in CHANNELS if c.relative_time}
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


def split_time(absolute, origin: float) -> tuple[np.ndarray, np.ndarray]:
    """(hi, lo) float32: hi = float32(absolute - origin), lo = float32 of what hi missed."""
    rel = np.asarray(absolute, dtype=np.float64) - np.float64(origin)
    hi = rel.astype(np.float32)
    with np.errstate(invalid="ignore"):  # inf - inf: a lo of NaN beside an infinite hi
        lo = np.where(np.isfinite(hi), rel - hi.astype(np.float64), 0.0).astype(np.float32)
    return hi, lo


def join_time(hi, lo, origin: float) -> np.ndarray:
    """The absolute times of a (hi, lo) pair: (float64(hi) + float64(lo)) + origin."""
    return (np.asarray(hi, dtype=np.float32).astype(np.float64) + np.asarray(lo, dtype=np.float32)) + np.float64(
        origin)


class OutputChannel(NamedTuple):
    """One channel of a written file: its EXR name, the channel it holds (a docs/spec.md §4
    name, or an extra channel of the image) and whether a FLOAT is stored as HALF."""

    name: str
    source: str
    half: bool = False


