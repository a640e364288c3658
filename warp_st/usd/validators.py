"""warp_st's ``pxr.UsdValidation`` validators and :func:`validate_stage` (``warp-st validate``).

The rules are the reader's own, not a second copy: each validator runs the reader
function for one prim (``body_kinematics``, ``GprimReader.surface``, the light and
render-settings readers, ``CameraEvaluator`` at the stage's time codes) and turns
the :class:`SceneError` it raises into a ``UsdValidation.ValidationError``. After a
problem the function runs again with the attribute it named read as unauthored
(``attributes.MASKED``), so every problem of a prim is listed, not only the first
(for a gprim only the first: a mesh's points, counts and indices depend on each other).

Registered with ``UsdValidation.ValidationRegistry`` (Python registration, keyword
``warpSt``; no ``schemaTypes``, because a stage authored without the schemas
loaded must validate the same, docs/spec.md §2), they report errors only:

- ``warpSt:SpacetimeBody``: SpacetimeBodyAPI values (types, |v| >= 1 on a coupled
  body, t <= 0, lifetime order, NaN / inf) and the body's pivot transform.
- ``warpSt:Geometry``: the data and transforms of the gprims and PointInstancers read.
- ``warpSt:Light``: SphereLight / DistantLight values.
- ``warpSt:Stage``: the render settings and their products, each camera at the stage's
  start and end time codes and its own time samples.

Warnings and information are the reader's diagnostics (``Scene.diagnostics``, the list
``render`` prints): :func:`validate_stage` reads the stage with every erroneous
attribute masked and lists them, so the two commands cannot disagree. Built-in
validators run beside them (:data:`BUILTIN`) as advice: material bindings without
MaterialBindingAPI, a missing upAxis. ``AttributeTypeMismatch`` is not used: it requires
the schema's exact type (double4) where docs/spec.md §2 accepts float variants, and it
knows nothing of a stage read without the schemas.
"""
from __future__ import annotations

import threading
import warnings
from dataclasses import asdict, dataclass

from pxr import Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdValidation

from warp_st.core.scene import SceneError
from warp_st.usd.attributes import MASKED, SPACETIME_BODY_API, Where, body_kinematics, has_api, static_time
from warp_st.usd.camera import CameraEvaluator
from warp_st.usd.geometry import SUPPORTED_GPRIMS, GprimReader, is_hidden, world_transform
from warp_st.usd.lights import SUPPORTED
from warp_st.usd.materials import preview_defaults
from warp_st.usd.rest_frame_motion import animation_frame
from warp_st.usd.stage import tf_message

__all__ = ["Problem", "KEYWORD", "BUILTIN", "register", "validate_stage", "counts"]

KEYWORD = "warpSt"

#: Built-in validators run by :func:`validate_stage`: name -> (severity override or
#: None to keep USD's, the error names reported or None for all).
BUILTIN = {
    "usdShadeValidators:MaterialBindingApiAppliedValidator": ("warning", None),
    "usdGeomValidators:StageMetadataChecker": ("warning", {"MissingUpAxisMetadata"}),
}

#: What the reader traverses (docs/spec.md §2: instancing included).
PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)

_SEVERITY = {
    UsdValidation.ValidationErrorType.Error: "error",
    UsdValidation.ValidationErrorType.Warn: "warning",
    UsdValidation.ValidationErrorType.Info: "info",
}
_TYPE = {"error": UsdValidation.ValidationErrorType.Error, "warning": UsdValidation.ValidationErrorType.Warn}


@dataclass(frozen=True)
class Problem:
    """One problem: severity ``error`` / ``warning`` / ``info``, where, what, and which validator."""

    severity: str
    file: str
    prim: str | None
    attribute: str | None
    message: str
    validator: str

    @property
    def location(self) -> str:
        """``file``, ``file:/prim`` or ``file:/prim.attribute``."""
        where = self.file
        if self.prim:
            where += f":{self.prim}"
            if self.attribute:
                where += f".{self.attribute}"
        elif self.attribute:
            where += f":{self.attribute}"
        return where

    def line(self) -> str:
        return f"{self.severity.upper()} {self.location}: {self.message}"

    def as_dict(self) -> dict:
        return asdict(self)


# --- the reader's errors, one problem each, every problem of a prim ---------------------


def _is_name(text: str) -> bool:
    return Sdf.Path.IsValidNamespacedIdentifier(text)


def _parse(text: str, *files: str) -> tuple[str | None, str | None, str]:
    """(prim, attribute, problem) of a SceneError's ``file: prim: attribute: problem``
    (``file`` one of ``files``)."""
    rest = text
    for file in files:
        if file and text.startswith(file + ": "):
            rest = text[len(file) + 2:]
            break
    prim = attribute = None
    head, sep, tail = rest.partition(": ")
    if sep and head.startswith("/") and Sdf.Path.IsValidPathString(head):
        prim, rest = head, tail
        head, sep, tail = rest.partition(": ")
    if sep and _is_name(head):
        attribute, rest = head, tail
    return prim, attribute, rest


def _every_problem(call, file: str, limit: int = 64, masked=()) -> list[tuple[str | None, str | None, str]]:
    """Run ``call()`` until it succeeds; after each SceneError naming an attribute,
    again with that attribute masked too. Returns the (prim, attribute, problem) found."""
    masked = set(masked)
    found = []
    for _ in range(limit):
        token = MASKED.set(frozenset(masked))
        try:
            call()
            return found
        except SceneError as exc:
            prim, attribute, problem = _parse(str(exc), file)
        except (Tf.ErrorException, UnicodeDecodeError) as exc:  # a value USD cannot unpack
            found.append((None, None, f"cannot be read: {tf_message(exc)}"))
            return found
        finally:
            MASKED.reset(token)
        key = (prim, attribute)
        if key in masked:
            return found
        found.append((prim, attribute, problem))
        if prim is None or attribute is None:
            return found
        masked.add(key)
    return found


# --- run state: which file name to report, internal failures -----------------------------

_lock = threading.Lock()
_active: dict = {}  # {"stage": Usd.Stage, "file": label, "failures": [exceptions]}


def _file_of(stage: Usd.Stage) -> str:
    if _active and _active["stage"] == stage:
        return _active["file"]
    root = stage.GetRootLayer()
    return root.realPath or root.identifier


def _site(stage, prim: str | None, attribute: str | None):
    path = Sdf.Path(prim) if prim else Sdf.Path.absoluteRootPath
    if attribute and prim and _is_name(attribute):
        path = path.AppendProperty(attribute)
    return UsdValidation.ValidationErrorSite(stage, path)


def _error(stage, severity: str, prim, attribute, message: str, name: str = "SceneError"):
    """A ValidationError at ``prim[.attribute]``; an attribute that is no property name
    (a stage metadatum, a formula) is kept in the message."""
    if attribute and not (prim and _is_name(attribute)):
        message = f"{attribute}: {message}"
    return UsdValidation.ValidationError(name, _TYPE[severity], [_site(stage, prim, attribute)], message)


def _errors(stage, call, *, every: bool = True) -> list:
    """The errors of ``call()``: every problem, or (``every=False``, for values that depend
    on each other such as a mesh's points and indices) only the first."""
    file = _file_of(stage)
    found = _every_problem(call, file, limit=64 if every else 1)
    return [_error(stage, "error", p, a, m) for p, a, m in found]


def _guarded(name: str, fn):
    """``fn`` with any unexpected exception recorded for :func:`validate_stage` to raise
    (exit 1), or reported as an error when run from elsewhere."""

    def task(obj, *_time_range):  # USD passes the time range; the checks read every time themselves
        try:
            return fn(obj)
        except Exception as exc:  # noqa: BLE001 - a bug must not vanish inside USD's traversal
            if _active:
                _active["failures"].append(exc)
                return []
            stage = obj if isinstance(obj, Usd.Stage) else obj.GetStage()
            path = None if isinstance(obj, Usd.Stage) else str(obj.GetPath())
            return [_error(stage, "error", path, None, f"internal error in {name}: {type(exc).__name__}: {exc}",
                           "InternalError")]

    return task


# --- which prims the reader reads ---------------------------------------------------------


def _pruned(prim) -> bool:
    """True below a PointInstancer (prototypes are drawn through it) or a RenderSettings prim."""
    parent = prim.GetParent()
    while parent and not parent.IsPseudoRoot():
        if parent.IsA(UsdGeom.PointInstancer) or parent.IsA(UsdRender.Settings):
            return True
        parent = parent.GetParent()
    return False


def _hidden(prim) -> bool:
    """The prim or an ancestor is invisible or has the guide / proxy purpose (at the
    stage's static time, as the reader reads it)."""
    time = _where(prim.GetStage()).time
    while prim and not prim.IsPseudoRoot():
        if is_hidden(prim, time):
            return True
        prim = prim.GetParent()
    return False


def _where(stage) -> Where:
    return Where(_file_of(stage), static_time(stage))


# --- the validators -----------------------------------------------------------------------


def _spacetime_body(prim) -> list:
    if prim.IsPseudoRoot() or _pruned(prim) or prim.IsA(UsdRender.Settings) or not has_api(prim, SPACETIME_BODY_API):
        return []
    stage = prim.GetStage()
    where = _where(stage)
    errors = _errors(stage, lambda: body_kinematics(where, prim))
    if prim.IsA(UsdGeom.Camera):
        return errors
    errors += _errors(stage, lambda: animation_frame(where, prim, _decoupled(where, prim)))
    xf = UsdGeom.XformCache(where.time)  # its pivot o (docs/spec.md §2), as the reader reads it
    errors += _errors(stage, lambda: world_transform(where, prim, lambda: xf.GetLocalToWorldTransform(prim),
                                                     where.time), every=False)
    return errors


def _decoupled(where: Where, prim) -> bool:
    """``spacetime:lorentzDecoupled`` as the reader reads it (False when bad: listed already)."""
    try:
        return bool(body_kinematics(where, prim)[3])
    except SceneError:
        return False


def _geometry(prim) -> list:
    is_instancer = prim.IsA(UsdGeom.PointInstancer)
    if not (is_instancer or prim.IsA(UsdGeom.Gprim)) or _pruned(prim) or _hidden(prim):
        return []
    stage = prim.GetStage()
    if not (is_instancer or any(prim.IsA(t) for t in SUPPORTED_GPRIMS)):
        return []  # not rendered: a warning of the reader's
    where = _where(stage)
    reader = GprimReader(where, UsdGeom.XformCache(where.time))
    call = (lambda: reader.instancer_surfaces(prim)) if is_instancer else (lambda: reader.surface(prim))
    return _errors(stage, call, every=False)


def _light(prim) -> list:
    if not (prim.IsA(UsdLux.BoundableLightBase) or prim.IsA(UsdLux.NonboundableLightBase)):
        return []
    if _pruned(prim) or _hidden(prim):
        return []
    stage = prim.GetStage()
    if str(prim.GetTypeName()) not in SUPPORTED:
        return []  # ignored: a warning of the reader's
    from warp_st.usd.reader import _StageReader

    return _errors(stage, lambda: _StageReader(stage, Where(_file_of(stage)))._light(prim))


_BODY_ATTRIBUTES = ("spacetime:fourVelocity", "spacetime:lifetime", "spacetime:referenceTime",
                    "spacetime:lorentzDecoupled")


def _camera_frames(stage, prim, limit: int = 64) -> list[float]:
    """The start and end time codes (0 without a range) and the camera's own time samples."""
    if stage.HasAuthoredTimeCodeRange():
        frames = {float(stage.GetStartTimeCode()), float(stage.GetEndTimeCode())}
    else:
        frames = {0.0}
    samples = sorted({float(t) for attr in prim.GetAttributes() for t in attr.GetTimeSamples()})
    if len(samples) > limit:
        step = len(samples) / limit
        samples = [samples[int(i * step)] for i in range(limit)]
    return sorted(frames.union(samples))


def _stage(stage) -> list:
    from warp_st.output.plan import OutputPlanError, check_product_clashes, product_paths
    from warp_st.usd.products import read_products
    from warp_st.usd.reader import _StageReader

    file = _file_of(stage)
    where = Where(file)
    cameras, settings_prims = [], []
    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), PREDICATE))
    for prim in it:
        if prim.IsA(UsdGeom.Camera):
            cameras.append(str(prim.GetPath()))
        elif prim.IsA(UsdRender.Settings):
            settings_prims.append(prim)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()
    errors = []
    reader = _StageReader(stage, where)
    reader.settings_prims = settings_prims
    chosen = []

    def settings():  # as _StageReader.read does
        prim = reader._settings_prim()
        chosen.append(reader._render_settings(prim))
        if prim is not None:
            products = read_products(where, stage, prim, reader._resolution)
            frames = sorted({f for product in products for f in _camera_frames(stage, stage.GetPrimAtPath(product.prim_path))})
            try:  # two products writing one file at a frame (frames and folders: checked at render time)
                for job in product_paths(products, frames):
                    check_product_clashes(file, products, [job])
            except OutputPlanError as exc:
                raise SceneError(str(exc)) from None

    errors += _errors(stage, settings)
    default = (chosen[0].camera if chosen else None) or (cameras[0] if cameras else None)
    evaluate = CameraEvaluator(stage, where, tuple(cameras), default)
    seen = set()
    for path in cameras:
        static = {(path, name) for name in _BODY_ATTRIBUTES}  # reported by warpSt:SpacetimeBody
        for frame in _camera_frames(stage, stage.GetPrimAtPath(path)):
            for prim, attribute, problem in _every_problem(lambda: evaluate(path, frame), file, masked=static):
                if (prim, attribute, problem) not in seen:
                    seen.add((prim, attribute, problem))
                    errors.append(_error(stage, "error", prim, attribute, f"{problem} (time code {frame:g})"))
    return errors


_VALIDATORS = {
    "warpSt:SpacetimeBody": ("prim", _spacetime_body, "SpacetimeBodyAPI values are valid (docs/spec.md §2)."),
    "warpSt:Geometry": ("prim", _geometry, "The data of the gprims and PointInstancers read can be rendered."),
    "warpSt:Light": ("prim", _light, "SphereLight, DistantLight, RectLight and DiskLight values are valid."),
    "warpSt:Stage": ("stage", _stage, "Render settings and cameras (at the stage's time codes) are valid."),
}


def register() -> None:
    """Register warp_st's validators with ``UsdValidation.ValidationRegistry`` (once)."""
    registry = UsdValidation.ValidationRegistry()
    with _lock:
        for name, (kind, fn, doc) in _VALIDATORS.items():
            if registry.HasValidator(name):
                continue
            metadata = UsdValidation.ValidatorMetadata(name=name, doc=doc, keywords=[KEYWORD])
            if kind == "prim":
                registry.RegisterPrimValidator(metadata, _guarded(name, fn))
            else:
                registry.RegisterStageValidator(metadata, _guarded(name, fn))


# --- running them ----------------------------------------------------------------------------


def _location(site) -> tuple[str | None, str | None]:
    if site.IsProperty():
        path = site.GetProperty().GetPath()
    elif site.IsPrim():
        path = site.GetPrim().GetPath()
    elif site.GetPropertySpec():
        path = site.GetPropertySpec().path
    elif site.GetPrimSpec():
        path = site.GetPrimSpec().path
    else:
        return None, None
    if path.IsPropertyPath():
        return str(path.GetPrimPath()), path.name
    return (None if path == Sdf.Path.absoluteRootPath else str(path)), None


def _problems(errors, file: str) -> list[Problem]:
    out = []
    for error in errors:
        if error.HasNoError():
            continue
        validator = error.GetValidator()
        name = validator.GetMetadata().name if validator else ""
        severity, only = BUILTIN.get(name, (None, None))
        if only is not None and error.GetName() not in only:
            continue
        severity = severity or _SEVERITY.get(error.GetType(), "error")
        sites = error.GetSites()
        prim, attribute = _location(sites[0]) if sites else (None, None)
        out.append(Problem(severity, file, prim, attribute, " ".join(error.GetMessage().split()), name))
    return out


def _order(stage) -> dict[str, int]:
    return {str(p.GetPath()): i for i, p in enumerate(Usd.PrimRange(stage.GetPseudoRoot(), PREDICATE))}


def validate_stage(stage: Usd.Stage, file: str, *, no_references: bool = False, light_speed=None):
    """(problems, scene): every problem of ``stage`` in stage order (duplicates dropped),
    and the :class:`~warp_st.core.scene.Scene` the reader makes of it (None when it cannot).

    ``file`` names the stage in the problems; ``light_speed`` overrides its own
    (docs/spec.md §1.1). The validators give the errors; the
    reader's diagnostics (``Scene.diagnostics``, what ``render`` prints) give the
    warnings and information: when there is an error they come from reading the stage
    with each erroneous attribute masked. When the validators find no error the reader
    itself reads the stage, and a SceneError it raises is a problem, so a stage without
    errors always loads.
    """
    from warp_st.usd.reader import load_scene

    register()
    registry = UsdValidation.ValidationRegistry()
    validators = [registry.GetOrLoadValidatorByName(n) for n in (*_VALIDATORS, *BUILTIN)]
    preview_defaults()  # USD's shader registry read here, not first inside its worker threads
    with _lock:
        _active.update(stage=stage, file=file, failures=[])
        try:
            errors = UsdValidation.ValidationContext([v for v in validators if v]).Validate(stage, PREDICATE)
            failures = list(_active["failures"])
        finally:
            _active.clear()
    if failures:
        raise failures[0]
    problems = _problems(errors, file)
    scene, notes = None, None
    if not any(p.severity == "error" for p in problems):
        try:
            with warnings.catch_warnings():  # they are the scene's diagnostics, listed below
                warnings.simplefilter("ignore")
                scene = load_scene(stage, no_references=no_references, light_speed=light_speed)
            notes = scene.diagnostics
        except SceneError as exc:  # it names the stage by its real path
            root = stage.GetRootLayer()
            prim, attribute, message = _parse(str(exc), file, root.realPath, root.identifier)
            problems.append(Problem("error", file, prim, attribute, message, "warpSt:Reader"))
    if notes is None:
        notes = reader_diagnostics(stage, file, {(p.prim, p.attribute) for p in problems if p.severity == "error"},
                                   light_speed=light_speed)
    problems += [Problem(d.severity, file, d.prim, d.attribute, d.message, "warpSt:Reader") for d in notes]
    order = _order(stage)
    unique = {(p.severity, p.prim, p.attribute, p.message): p for p in reversed(problems)}  # the first of each
    problems = sorted(unique.values(), key=lambda p: (order.get(p.prim or "/", -1), p.severity != "error",
                                                      p.attribute or "", p.message))
    return problems, scene


def reader_diagnostics(stage: Usd.Stage, file: str, masked, limit: int = 64, light_speed=None) -> tuple:
    """The reader's diagnostics of a stage that has errors: it reads the stage with the
    ``masked`` (prim, attribute) pairs read as unauthored, and again after each SceneError
    with the attribute it names masked too (the prim's whole subtree skipped when that
    does not help, or the error names no attribute), until it reads through (an error
    that names no prim: the diagnostics found up to there)."""
    from warp_st.usd.reader import _StageReader

    masked = {key for key in masked if key[0] is not None}
    notes = ()
    for _ in range(limit):
        reader = _StageReader(stage, Where(file))
        token = MASKED.set(frozenset(masked))
        try:
            reader.read(light_speed=light_speed)
            return reader.notes.items()
        except SceneError as exc:
            notes = reader.notes.items()
            _, prim, attribute, _ = getattr(exc, "where", (None, None, None, None))
            if prim is None or (prim, None) in masked:
                return notes
            masked.add((prim, None) if attribute is None or (prim, attribute) in masked else (prim, attribute))
        except (Tf.ErrorException, UnicodeDecodeError):
            return reader.notes.items()
        finally:
            MASKED.reset(token)
    return notes


def counts(problems) -> dict[str, int]:
    """{"error": n, "warning": n, "info": n}."""
    out = {"error": 0, "warning": 0, "info": 0}
    for p in problems:
        out[p.severity] = out.get(p.severity, 0) + 1
    return out
