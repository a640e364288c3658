"""A stage's speed of light in stage units per time code (docs/spec.md §1.1).

First that applies: the caller's (``--light-speed``), the render settings'
``spacetime:lightSpeedMetersPerSecond`` / ``spacetime:lightSpeedUnitsPerTimeCode``, 1 when
the stage uses our schemas, else the physical speed of light in the stage's
``metersPerUnit`` and ``timeCodesPerSecond`` (a non-positive one is a warning and USD's
fallback).
"""
from __future__ import annotations

import math

from pxr import Usd, UsdGeom, UsdRender

from warp_st.core.light_speed import (
    METRES_PER_SECOND,
    PHYSICAL,
    PHYSICAL_LIGHT_SPEED,
    UNITS_PER_TIME_CODE,
    LightSpeedSetting,
)
from warp_st.usd import attributes as A
from warp_st.usd.attributes import SPACETIME_BODY_API, SPACETIME_CAMERA_API, has_api

__all__ = ["SCHEMA_LIGHT_SPEED", "SETTINGS_LIGHT_SPEED", "settings_and_schema_use", "stage_light_speed"]

#: Where the light speed of a stage that uses our schemas comes from (no information line).
SCHEMA_LIGHT_SPEED = "the stage applies the spacetime schemas: 1 stage unit per time code"
#: The render settings' light speed: metres per second, or stage units per time code.
SETTINGS_LIGHT_SPEED = ("spacetime:lightSpeedMetersPerSecond", "spacetime:lightSpeedUnitsPerTimeCode")
_APIS = (SPACETIME_BODY_API, SPACETIME_CAMERA_API)
_PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


def settings_and_schema_use(stage: Usd.Stage) -> tuple[list, bool]:
    """(the stage's UsdRender.Settings prims in stage order, whether it uses our schemas: a
    prim applies SpacetimeBodyAPI or SpacetimeCameraAPI, or a camera or render settings
    prim authors a ``spacetime:`` attribute)."""
    ours, settings = False, []
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), _PREDICATE):
        is_settings = prim.IsA(UsdRender.Settings)
        if is_settings:
            settings.append(prim)
        if not ours and (any(has_api(prim, a) for a in _APIS)
                         or (is_settings or prim.IsA(UsdGeom.Camera))
                         and any(n.startswith("spacetime:") for n in prim.GetAuthoredPropertyNames())):
            ours = True
    return settings, ours


def _units(stage: Usd.Stage, notes) -> tuple[float, float]:
    mpu, tcps = float(UsdGeom.GetStageMetersPerUnit(stage)), float(stage.GetTimeCodesPerSecond())
    if not (math.isfinite(mpu) and mpu > 0.0):
        notes.warn(None, "metersPerUnit", f"is {mpu:g}, not positive: the light speed takes USD's fallback, 0.01",
                   "StageMetadata")
        mpu = 0.01
    if not (math.isfinite(tcps) and tcps > 0.0):
        notes.warn(None, "timeCodesPerSecond", f"is {tcps:g}, not positive: the light speed takes USD's fallback, 24",
                   "StageMetadata")
        tcps = 24.0
    return mpu, tcps


def _converted(stage, notes, setting: LightSpeedSetting, origin: str) -> tuple[float, str]:
    if setting.unit == UNITS_PER_TIME_CODE:
        return setting.value, origin
    mpu, tcps = _units(stage, notes)
    return setting.units_per_time_code(mpu, tcps), f"{origin} (at metersPerUnit {mpu:g} and {tcps:g} time codes " \
                                                   "per second)"


def stage_light_speed(stage: Usd.Stage, where, notes, requested: LightSpeedSetting | None, settings_prim,
                      ours: bool) -> tuple[float, str]:
    """(c_s in stage units per time code, where it came from) for ``stage``."""
    if requested is not None:
        return _converted(stage, notes, requested, f"--light-speed {requested}")
    if settings_prim is not None:
        given = [(name, A.real(where, settings_prim, name, None, positive=True)) for name in SETTINGS_LIGHT_SPEED]
        given = [(name, value) for name, value in given if value is not None]
        if len(given) > 1:
            raise where.error(settings_prim, given[1][0], f"conflicts with {given[0][0]}: author one light speed")
        if given:
            name, value = given[0]
            setting = LightSpeedSetting(value, METRES_PER_SECOND if name == SETTINGS_LIGHT_SPEED[0]
                                        else UNITS_PER_TIME_CODE)
            return _converted(stage, notes, setting, f"{settings_prim.GetPath()}.{name} = {setting}")
    if ours:
        return 1.0, SCHEMA_LIGHT_SPEED
    mpu, tcps = _units(stage, notes)
    return PHYSICAL.units_per_time_code(mpu, tcps), (f"the physical speed of light, {PHYSICAL_LIGHT_SPEED:.9g} m/s "
                                                     f"at metersPerUnit {mpu:g} and {tcps:g} time codes per second")
