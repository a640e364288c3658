"""The speed of light of a stage, in stage units per time code (docs/spec.md §3.1).

The renderer works with c = 1: lab time is measured in stage units of light travel. A
stage's light speed ``c`` (stage units per time code) is therefore the lab time of one time
code: lab time t = c x time code. Stages that apply our spacetime schemas have c = 1 (lab
time = time code, as since 0.1); a stage without them gets the physical speed of light in
its own units (``metersPerUnit``, ``timeCodesPerSecond``), so an ordinary asset renders as
any renderer shows it. ``--light-speed`` and the render settings' ``spacetime:lightSpeed*``
attributes set it in physical terms (metres per second) or in stage units per time code.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["PHYSICAL_LIGHT_SPEED", "LightSpeedSetting", "parse_light_speed", "PHYSICAL"]

#: The speed of light in vacuum, metres per second (exact by the SI definition of the metre).
PHYSICAL_LIGHT_SPEED = 299_792_458.0

#: The two ways to give a light speed: metres per second, or stage units per time code.
METRES_PER_SECOND = "m/s"
UNITS_PER_TIME_CODE = "units/timecode"

_PATTERN = re.compile(r"^\s*(?P<value>[-+0-9.eE]+)\s*(?P<unit>m/s|units/timecode|u/tc)\s*$")


@dataclass(frozen=True)
class LightSpeedSetting:
    """A light speed as the user gave it: ``value`` in ``unit`` (m/s or units/timecode)."""

    value: float
    unit: str

    def units_per_time_code(self, meters_per_unit: float, time_codes_per_second: float) -> float:
        if self.unit == UNITS_PER_TIME_CODE:
            return self.value
        return self.value / meters_per_unit / time_codes_per_second

    def __str__(self) -> str:
        return f"{self.value:g} {self.unit}"


#: The physical speed of light as a setting.
PHYSICAL = LightSpeedSetting(PHYSICAL_LIGHT_SPEED, METRES_PER_SECOND)


def parse_light_speed(text: str) -> LightSpeedSetting:
    """``"299792458m/s"``, ``"3e8 m/s"``, ``"2units/timecode"`` (or ``"2u/tc"``), or
    ``"physical"`` (the speed of light in m/s); ValueError (one line) otherwise."""
    if text.strip().lower() in ("physical", "c"):
        return PHYSICAL
    m = _PATTERN.match(text)
    try:
        value = float(m.group("value")) if m else math.nan
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"light speed must be a positive number with a unit, e.g. 299792458m/s or 1units/timecode "
                         f"(or 'physical'), got {text!r}")
    unit = METRES_PER_SECOND if m.group("unit") == "m/s" else UNITS_PER_TIME_CODE
    return LightSpeedSetting(value, unit)

