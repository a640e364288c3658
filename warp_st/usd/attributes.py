"""Typed, validated attribute reads for the USD reader.

Every getter either returns a plain Python / NumPy value or raises
:class:`warp_st.core.scene.SceneError` naming the file, the prim and the attribute, so
the reader never hands a NaN or a wrong-shaped value to later steps.

Types are checked by the value's C++ type, not its role: ``float3``, ``color3f``,
``point3f`` and ``vector3f`` are all "a 3-vector of floats"; half, float and
double precision are all accepted where a real number is asked for (docs/spec.md §2:
"float or double variants").
"""
from __future__ import annotations

import contextvars
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Sdf, Usd

from warp_st.core.limits import MAX_MAGNITUDE
from warp_st.core.scene import SceneError

__all__ = [
    "SPACETIME_BODY_API",
    "SPACETIME_CAMERA_API",
    "DEFAULT_TIME",
    "static_time",
    "Where",
    "has_api",
    "real",
    "vector",
    "integer",
    "boolean",
    "token",
    "int_array",
    "vec3_array",
    "int2",
    "body_kinematics",
]

SPACETIME_BODY_API = "SpacetimeBodyAPI"
SPACETIME_CAMERA_API = "SpacetimeCameraAPI"

#: (prim path, attribute name) pairs read as if unauthored. Set only by
#: ``warp_st.usd.validators``, which reads a prim again with each attribute it has
#: reported masked, so that one run lists every problem rather than the first.
MASKED: contextvars.ContextVar[frozenset] = contextvars.ContextVar("warp_st_masked_attributes", default=frozenset())

#: Our own ``spacetime:`` attributes are read here (they are static: a time-sampled one is
#: an error). Everything else of the 4D database is read once at the stage's static time
#: (:func:`static_time`); only the camera is evaluated per time code.
DEFAULT_TIME = Usd.TimeCode.Default()


def static_time(stage: Usd.Stage) -> float:
    """The time code geometry, lights and settings are read at: the stage's start time code
    (0 when unauthored), the frame rendered when none is asked for. An attribute without
    time samples reads its default value there, as at the default time code."""
    return float(stage.GetStartTimeCode())


def _tf_types(*names) -> frozenset[str]:
    return frozenset(getattr(Sdf.ValueTypeNames, n).type.typeName for n in names)


_REAL = _tf_types("Double", "Float", "Half")
_VEC = {
    2: _tf_types("Double2", "Float2", "Half2"),
    3: _tf_types("Double3", "Float3", "Half3"),
    4: _tf_types("Double4", "Float4", "Half4"),
}
_INT = _tf_types("Int", "UInt", "Int64", "UInt64", "UChar")
_BOOL = _tf_types("Bool")
_TOKEN = _tf_types("Token", "String")


@dataclass(frozen=True)
class Where:
    """The file an error is reported against (the root layer the user gave), and the time
    code real-world attributes are read at (``static``, from :func:`static_time`;
    ``spacetime:`` ones are read at the default time code)."""

    file: str
    static: float | None = None  # the static time code (None: the default time code)
    lab_per_code: float = 1.0  # lab time of one time code: the stage's light speed (core/light_speed.py)

    @property
    def time(self) -> Usd.TimeCode:
        return DEFAULT_TIME if self.static is None else Usd.TimeCode(self.static)

    def error(self, prim, attribute: str | None, problem: str) -> SceneError:
        """A one-line SceneError naming file, prim path and attribute.

        When the offending opinion lives in another layer (a reference, a
        sublayer) that layer is named too, so the user knows which file to fix.
        """
        prim_path = _text(prim.GetPath()) if hasattr(prim, "GetPath") else (_text(prim) if prim else None)
        if attribute and hasattr(prim, "GetAttribute"):
            other = _authoring_layer(prim, attribute)
            if other and Path(other).name != Path(self.file).name:
                problem = f"{problem} (authored in {other})"
        return SceneError.at(self.file, prim_path, attribute, " ".join(problem.split()))


def _text(obj) -> str:
    """str(obj), or a placeholder when a damaged file gave it bytes that are not UTF-8."""
    try:
        return str(obj)
    except UnicodeDecodeError:
        return "<text that is not UTF-8>"


def _authoring_layer(prim, attribute: str) -> str | None:
    try:
        prop = prim.GetProperty(attribute)
        stack = prop.GetPropertyStack(DEFAULT_TIME) if prop else []
        if stack:
            layer = stack[0].layer
            return layer.realPath or layer.identifier
    except Exception:  # pragma: no cover - diagnostics only
        pass
    return None


def has_api(prim, name: str) -> bool:
    """True when ``name`` is applied to ``prim``, with or without the plugin loaded.

    ``HasAPI`` / ``GetAppliedSchemas`` only know registered schemas, so the
    composed ``apiSchemas`` list op is read directly as well (docs/spec.md §2: a stage
    authored without the schemas loaded must read the same).
    """
    if name in prim.GetAppliedSchemas():
        return True
    op = prim.GetMetadata("apiSchemas")
    if op is None:
        return False
    try:
        return name in op.ApplyOperations([])
    except Exception:  # pragma: no cover - malformed metadata
        return name in op.GetAddedOrExplicitItems()


def _authored_type(attr) -> Sdf.ValueTypeName | None:
    """The type the strongest opinion was authored with; None when that opinion is not
    an attribute's (a damaged .usdc can hold a relationship spec under an attribute's
    name).

    With the schema registered, ``GetTypeName`` reports the schema's type (double4)
    even when a layer authored another (``custom double3 ...``), and ``Get`` then
    returns the authored value unconverted; so the authored spec is what is checked.
    """
    for spec in attr.GetPropertyStack(DEFAULT_TIME):
        return spec.typeName if isinstance(spec, Sdf.AttributeSpec) else None
    return attr.GetTypeName()


def _raw(where: Where, prim, name: str, kinds: frozenset[str], what: str, time, *, array: bool = False):
    """(value, found): the attribute's value at ``time`` after a type check.

    found is False when the attribute has no value (neither authored nor a schema
    fallback). ``time`` None: the default time code for a ``spacetime:`` attribute, where
    one authored only as time samples is an error (bodies are static 4D objects), else
    ``where.time``.
    """
    if time is None:
        time = DEFAULT_TIME if name.startswith("spacetime:") else where.time
    masked = MASKED.get()
    if masked and (str(prim.GetPath()), name) in masked:
        return None, False
    attr = prim.GetAttribute(name)
    if not attr or not attr.IsValid():
        return None, False
    type_name = _authored_type(attr)
    if type_name is None:
        raise where.error(prim, name, f"must be {what}, not a relationship")
    if type_name.isArray != array or type_name.type.typeName not in kinds:
        raise where.error(prim, name, f"must be {what}, not {_text(type_name)}")
    if (time == DEFAULT_TIME and name.startswith("spacetime:") and attr.GetNumTimeSamples() > 0
            and attr.GetResolveInfo(DEFAULT_TIME).GetSource() != Usd.ResolveInfoSourceDefault):
        raise where.error(
            prim, name, "is only time-sampled; author a default value (bodies are static 4D objects: "
            "only the camera is evaluated per time code)"
        )
    value = attr.Get(time)
    if value is None:
        return None, False
    # A damaged file can hold a value of another type than the declared one (a flipped
    # byte in a .usdc made a point3f[] a float[] of 4, a float3 a float).
    held = Sdf.GetValueTypeNameForValue(value)
    if held.type.typeName not in kinds:
        raise where.error(prim, name, f"must be {what}; its value is {_text(held)}")
    return value, True


def real(where: Where, prim, name: str, fallback: float | None = None, *, time=None,
         finite: bool = True, minimum: float | None = None, positive: bool = False) -> float | None:
    """A real scalar (half, float or double), validated."""
    value, found = _raw(where, prim, name, _REAL, "a real number (double or float)", time)
    if not found:
        return fallback
    x = float(value)
    if math.isnan(x) or (finite and math.isinf(x)):
        raise where.error(prim, name, f"must be finite, got {x}")
    if finite and abs(x) > MAX_MAGNITUDE:
        raise where.error(prim, name, f"magnitude must be <= {MAX_MAGNITUDE:g}, got {x}")
    if positive and not x > 0.0:
        raise where.error(prim, name, f"must be > 0, got {x}")
    if minimum is not None and x < minimum:
        raise where.error(prim, name, f"must be >= {minimum}, got {x}")
    return x


def vector(where: Where, prim, name: str, size: int, fallback=None, *, time=None,
           finite: bool = True) -> np.ndarray | None:
    """A fixed-size real vector (double/float/half, any role) as float64, shape (size,).

    ``finite=False`` still rejects NaN (infinities are allowed, e.g. a lifetime).
    """
    value, found = _raw(where, prim, name, _VEC[size], f"a {size}-vector (double{size} or float{size})", time)
    if not found:
        return None if fallback is None else np.array(fallback, dtype=np.float64)
    if len(value) != size:
        raise where.error(prim, name, f"must have {size} components, got {len(value)}")
    v = np.array([float(c) for c in value], dtype=np.float64)
    if np.isnan(v).any() or (finite and not np.isfinite(v).all()):
        raise where.error(prim, name, f"must be {'finite' if finite else 'free of NaN'}, got {tuple(v.tolist())}")
    if finite and (np.abs(v) > MAX_MAGNITUDE).any():
        raise where.error(prim, name, f"magnitude must be <= {MAX_MAGNITUDE:g}, got {tuple(v.tolist())}")
    return v


def integer(where: Where, prim, name: str, fallback: int | None = None, *, minimum: int | None = None,
            maximum: int | None = None, time=None) -> int | None:
    """An integer scalar (int, uint, int64, uint64, uchar)."""
    value, found = _raw(where, prim, name, _INT, "an integer (int)", time)
    if not found:
        return fallback
    n = int(value)
    if minimum is not None and n < minimum:
        raise where.error(prim, name, f"must be >= {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise where.error(prim, name, f"must be <= {maximum}, got {n}")
    return n


def boolean(where: Where, prim, name: str, fallback: bool | None = None, *, time=None) -> bool | None:
    value, found = _raw(where, prim, name, _BOOL, "a bool", time)
    return bool(value) if found else fallback


def token(where: Where, prim, name: str, allowed: tuple[str, ...], fallback: str | None = None, *,
          time=None) -> str | None:
    """A token (or string) restricted to ``allowed``."""
    value, found = _raw(where, prim, name, _TOKEN, "a token", time)
    if not found:
        return fallback
    s = str(value)
    if s not in allowed:
        raise where.error(prim, name, f"must be one of {', '.join(allowed)}; got {s!r}")
    return s


_INT_ARRAY = _tf_types("IntArray", "UIntArray", "Int64Array", "UInt64Array")
_VEC3_ARRAY = _tf_types("Point3fArray", "Point3dArray", "Point3hArray")
_INT2 = _tf_types("Int2")


def int_array(where: Where, prim, name: str) -> np.ndarray | None:
    """An integer array (int[], uint[], int64[]) as int64, shape (N,); None when it has no value."""
    return _array(where, prim, name, _INT_ARRAY, "an int[] array", np.int64, (-1,))


def vec3_array(where: Where, prim, name: str) -> np.ndarray | None:
    """A 3-vector array (point3f[], float3[], double3[], any role) as float64, shape (N, 3), finite."""
    values = _array(where, prim, name, _VEC3_ARRAY, "a 3-vector array (point3f[], color3f[], float3[] or double3[])", np.float64, (-1, 3))
    if values is not None and not np.isfinite(values).all():
        bad = int(np.argwhere(~np.isfinite(values))[0][0])
        raise where.error(prim, name, f"element {bad} is not finite: {tuple(values[bad].tolist())}")
    if values is not None and (np.abs(values) > MAX_MAGNITUDE).any():
        bad = int(np.argwhere(np.abs(values) > MAX_MAGNITUDE)[0][0])
        raise where.error(prim, name, f"element {bad} has a magnitude > {MAX_MAGNITUDE:g}: {tuple(values[bad].tolist())}")
    return values


def int2(where: Where, prim, name: str, *, authored_only: bool = True) -> tuple[int, int] | None:
    """An int2 (e.g. a resolution); with ``authored_only`` a schema fallback counts as absent."""
    attr = prim.GetAttribute(name)
    if authored_only and (not attr or not attr.HasAuthoredValue()):
        return None
    value, found = _raw(where, prim, name, _INT2, "an int2", None)
    return (int(value[0]), int(value[1])) if found else None


def _array(where: Where, prim, name: str, kinds: frozenset[str], what: str, dtype, shape):
    value, found = _raw(where, prim, name, kinds, what, None, array=True)
    if not found:
        return None
    return np.asarray(value, dtype=dtype).reshape(shape)


def body_kinematics(where: Where, prim) -> tuple[np.ndarray, float, tuple[float, float], bool]:
    """Validated ``SpacetimeBodyAPI`` values: (velocity v, t_ref, lifetime, decoupled), the
    times lab times (time codes x ``where.lab_per_code``).

    v = (x, y, z) / t of ``spacetime:fourVelocity`` (t > 0); a Lorentz-coupled body
    needs |v| < 1, a decoupled one any finite v (docs/spec.md §2).
    """
    u = vector(where, prim, "spacetime:fourVelocity", 4, (1.0, 0.0, 0.0, 0.0))
    if not u[0] > 0.0:
        raise where.error(prim, "spacetime:fourVelocity", f"time component must be > 0, got {u[0]}")
    with np.errstate(over="ignore"):
        velocity = u[1:] / u[0]
    reference_time = real(where, prim, "spacetime:referenceTime", 0.0)
    begin, end = vector(where, prim, "spacetime:lifetime", 2, (-math.inf, math.inf), finite=False)
    if not begin < end:
        raise where.error(prim, "spacetime:lifetime", f"tBegin must be < tEnd, got ({begin}, {end})")
    k = where.lab_per_code  # the attributes are time codes; the renderer's times are lab times
    reference_time, begin, end = reference_time * k, begin * k, end * k
    decoupled = boolean(where, prim, "spacetime:lorentzDecoupled", False)
    with np.errstate(over="ignore"):
        speed = float(np.linalg.norm(velocity))
    if not math.isfinite(speed) or speed > MAX_MAGNITUDE:
        raise where.error(prim, "spacetime:fourVelocity",
                          f"velocity (x, y, z) / t is not finite or its magnitude exceeds {MAX_MAGNITUDE:g}")
    if not decoupled and speed >= 1.0:
        raise where.error(prim, "spacetime:fourVelocity",
                          f"speed |v| = {speed:.6g} >= 1 (the speed of light) on a Lorentz-coupled body; "
                          "use a slower velocity or spacetime:lorentzDecoupled = true")
    return velocity, reference_time, (float(begin), float(end)), decoupled
