"""What a stage holds that the renderer does not honour: the one list ``render`` and
``validate`` print (``Scene.diagnostics``).

The reader adds to a :class:`Notes` while it reads; nothing it leaves out goes unsaid:

- composition arcs that could not be composed (a missing reference, payload or sublayer,
  a ``.mtlx`` asset), one line each naming the layer and the asset (:func:`composition`);
- authored schema attributes and relationships the renderer does not use, when their
  value differs from the schema's fallback (:func:`check_prim`), and time samples the
  renderer does not follow (it follows xformOps that move bodies, docs/spec.md §2.1, and
  the points of deforming meshes, §2.2);
- prims it does not render (their types), and values it could not use (a bad primvar,
  normal or material input), with what it used instead.

Our own ``spacetime:`` attributes are not judged here: their readers are strict
(docs/spec.md §6).
"""
from __future__ import annotations

import os
import re

from pxr import Usd, UsdGeom, UsdLux, UsdSkel

from warp_st.core.scene import Diagnostic, SceneError
from warp_st.usd.attributes import MASKED

__all__ = ["Notes", "composition", "check_prim", "samples_listable", "unknown_type", "same_value"]


class Notes:
    """An ordered, duplicate-free list of :class:`Diagnostic` for one stage."""

    def __init__(self, file: str):
        self.file = file
        self._items: dict[tuple, Diagnostic] = {}
        #: False on a stage whose time samples USD cannot list (see :func:`samples_listable`)
        self.count_samples = True
        #: prims whose time-sampled xformOps move a body (docs/spec.md §2.1): not warned
        self.animated: set[str] = set()
        #: deforming gprims (docs/spec.md §2.2): their points (and extent) samples and
        #: UsdSkel bindings are honoured, not warned
        self.deformed: set[str] = set()

    def warn(self, prim, attribute: str | None, message: str, code: str) -> None:
        self._add("warning", prim, attribute, message, code)

    def info(self, prim, attribute: str | None, message: str, code: str) -> None:
        self._add("info", prim, attribute, message, code)

    def _add(self, severity, prim, attribute, message, code) -> None:
        if prim is not None and not isinstance(prim, str):
            prim = str(prim.GetPath())
        key = (prim, attribute, message)
        if key not in self._items:
            self._items[key] = Diagnostic(severity, self.file, prim, attribute, " ".join(message.split()), code)

    def value_error(self, exc: SceneError, instead: str, code: str = "BadValue") -> None:
        """A SceneError of a value the reader can do without: a warning saying what is used ``instead``."""
        _, prim, attribute, problem = exc.where
        self.warn(prim, attribute, f"{problem}; {instead}", code)

    def items(self) -> tuple[Diagnostic, ...]:
        return tuple(self._items.values())


# --- composition ---------------------------------------------------------------------------

_ARC = re.compile(r"Could not open asset @(?P<asset>[^@]*)@ for (?P<arc>reference|payload) introduced by "
                  r"@(?P<layer>[^@]*)@<(?P<prim>[^>]*)>(?P<why>.*)")
_SUBLAYER = re.compile(r"Could not load sublayer @(?P<asset>[^@]*)@ of layer @(?P<layer>[^@]*)@")
_PRIM_PATH = re.compile(r"Unresolved (?P<arc>reference|payload) prim path @(?P<layer>[^@]*)@<(?P<target>[^>]*)> "
                        r"introduced by @[^@]*@<(?P<prim>[^>]*)>")


def _short(path: str, root_dir: str) -> str:
    """``path`` relative to the root layer's folder when it lies inside it."""
    path = path.split(":SDF_FORMAT_ARGS:")[0]
    if os.path.isabs(path) and root_dir:
        rel = os.path.relpath(path, root_dir)
        if not rel.startswith(".."):
            return rel
    return path


def composition(notes: Notes, stage: Usd.Stage) -> None:
    """One warning per composition error: what could not be composed, from which layer."""
    root = stage.GetRootLayer()
    root_dir = os.path.dirname(root.realPath) if root.realPath else ""
    for error in stage.GetCompositionErrors():
        try:
            text = " ".join(str(error).split())
        except UnicodeDecodeError:
            text = f"{type(error).__name__} (its text is not UTF-8)"
        if m := _ARC.match(text):
            asset, layer = _short(m["asset"], root_dir), _short(m["layer"], root_dir)
            why = "cannot be opened"
            if asset.lower().endswith(".mtlx"):
                why = "is MaterialX, which usd-core cannot open (no MaterialX file-format plugin)"
            notes.warn(m["prim"], None, f"{m['arc']} @{asset}@ (in {layer}) {why}: not composed", "Composition")
        elif m := _SUBLAYER.match(text):
            notes.warn(None, None, f"sublayer @{_short(m['asset'], root_dir)}@ of {_short(m['layer'], root_dir)} "
                                   "cannot be opened: not composed", "Composition")
        elif m := _PRIM_PATH.match(text):
            notes.warn(m["prim"], None, f"{m['arc']} to <{m['target']}> in {_short(m['layer'], root_dir)} names "
                                        "no prim: not composed", "Composition")
        else:
            notes.warn(None, None, f"composition error: {text}", "Composition")


# --- authored things the renderer does not use ---------------------------------------------

_XFORMABLE = frozenset({"visibility", "purpose", "xformOpOrder", "extent"})
_GPRIM = _XFORMABLE | {"primvars:displayColor", "doubleSided", "orientation"}
_SHAPE = {
    "Mesh": {"points", "faceVertexCounts", "faceVertexIndices", "normals", "holeIndices",
             # refinement controls: the subdivision warning covers them
             "subdivisionScheme", "cornerIndices", "cornerSharpnesses", "creaseIndices", "creaseLengths",
             "creaseSharpnesses", "interpolateBoundary", "faceVaryingLinearInterpolation",
             "triangleSubdivisionRule"},
    "Sphere": {"radius"},
    "Cube": {"size"},
    "Cylinder": {"radius", "height", "axis"},
    "Cone": {"radius", "height", "axis"},
    "Capsule": {"radius", "height", "axis"},
    "Cylinder_1": {"radiusTop", "radiusBottom", "height", "axis"},
    "Capsule_1": {"radiusTop", "radiusBottom", "height", "axis"},
    "Plane": {"width", "length", "axis"},
}
_LIGHT = _XFORMABLE | {"inputs:intensity", "inputs:exposure", "inputs:color", "inputs:enableColorTemperature",
                       "inputs:colorTemperature", "inputs:normalize", "inputs:diffuse"}
#: What each prim type's honoured attributes are (xformOp:* always are).
HONOURED = {
    **{kind: _GPRIM | names for kind, names in _SHAPE.items()},
    "SphereLight": _LIGHT | {"inputs:radius", "treatAsPoint"},
    "DistantLight": _LIGHT | {"inputs:angle"},
    "RectLight": _LIGHT | {"inputs:width", "inputs:height"},
    "DiskLight": _LIGHT | {"inputs:radius"},
    # the sky (usd/dome.py); guideRadius only draws a guide
    "DomeLight": _LIGHT | {"inputs:texture:file", "inputs:texture:format", "guideRadius"},
    # clippingRange / focusDistance / stereoRole change nothing a ray tracer without clipping,
    # depth of field or stereo would draw
    "Camera": _XFORMABLE | {"focalLength", "horizontalAperture", "verticalAperture", "horizontalApertureOffset",
                            "verticalApertureOffset", "projection", "clippingRange", "focusDistance", "stereoRole"},
    "PointInstancer": _XFORMABLE | {"positions", "orientations", "orientationsf", "scales", "protoIndices", "ids",
                                    "invisibleIds"},
    "RenderSettings": frozenset({"resolution"}),
}

_WHY = {
    "primvars:displayOpacity": "opacity is not rendered (surfaces are opaque)",
    "velocities": "motion from velocities is not rendered",
    "accelerations": "motion from accelerations is not rendered",
    "angularVelocities": "motion from angular velocities is not rendered",
    "inputs:texture:file": "a RectLight's texture is not honoured (it emits its colour)",
    "inputs:specular": "the light's specular multiplier is not honoured (surfaces are Lambert and mirrors)",
    "fStop": "depth of field is not rendered",
    "exposure": "camera exposure is not applied",
    "shutter:open": "the camera shutter is not used (spacetime:shutter on the render settings is)",
    "shutter:close": "the camera shutter is not used (spacetime:shutter on the render settings is)",
    "clippingPlanes": "clipping planes are not applied",
}
_WHY_PREFIX = {"inputs:shaping:": "light shaping is not supported",
               "inputs:shadow:": "shadow controls are not supported (every light casts shadows)",
               "exposure:": "camera exposure is not applied"}
#: Relationships whose targets change the picture but are not honoured.
_RELATIONSHIP_WHY = {"light:filters": "light filters are not supported",
                     "collection:lightLink:includes": "light linking is not supported",
                     "collection:lightLink:excludes": "light linking is not supported",
                     "collection:shadowLink:includes": "shadow linking is not supported",
                     "collection:shadowLink:excludes": "shadow linking is not supported"}


def same_value(value, fallback) -> bool:
    """``value == fallback`` for USD values (False when they cannot be compared)."""
    try:
        return bool(value == fallback)
    except (TypeError, ValueError):
        return False


def _neutral(name: str, value) -> bool:
    """A value that changes nothing although the schema gives no fallback."""
    if value is None:
        return True
    if name == "primvars:displayOpacity":
        return all(float(x) >= 1.0 for x in value)
    try:
        return len(value) == 0
    except TypeError:
        return False


def _why(name: str) -> str:
    for prefix, why in _WHY_PREFIX.items():
        if name.startswith(prefix):
            return why
    return _WHY.get(name, "is not honoured by the renderer")


def check_prim(notes: Notes, prim, time, *, attributes: bool = True, samples: bool = True) -> None:
    """Warn about the prim's authored schema attributes (and relationships) that are not
    honoured and differ from the schema fallback (``attributes``), and about its time
    samples (``samples``): every frame uses the value at ``time``."""
    masked = MASKED.get()
    path = str(prim.GetPath())
    kind = str(prim.GetTypeName())
    honoured = HONOURED.get(kind, _XFORMABLE)
    definition = prim.GetPrimDefinition()
    schema = set(definition.GetPropertyNames()) if attributes else set()
    for attr in prim.GetAuthoredAttributes():
        name = attr.GetName()
        if masked and (path, name) in masked:
            continue
        honoured_samples = (name.startswith("xformOp:") and path in notes.animated  # docs/spec.md §2.1
                            or path in notes.deformed and name in ("points", "extent"))  # §2.2
        if samples and attr.ValueMightBeTimeVarying() and not honoured_samples:  # one sample is a constant
            at = "its default value" if name.startswith("spacetime:") else f"its value at time code {time.GetValue():g}"
            count = "time samples"
            if notes.count_samples:
                times = attr.GetTimeSamples()
                count = f"{len(times)} time samples ({times[0]:g} to {times[-1]:g})"
            notes.warn(path, name, f"has {count}; USD animation is not rendered yet: every frame uses {at}",
                       "TimeSampled")
        if (name not in schema or name in honoured or name.startswith(("xformOp:", "spacetime:"))
                or path in notes.deformed and name.startswith(("primvars:skel:", "skel:"))):
            continue
        value = attr.Get(time)
        fallback = definition.GetAttributeFallbackValue(name)
        if fallback is None and _neutral(name, value) or fallback is not None and same_value(value, fallback):
            continue
        notes.warn(path, name, f"{_why(name)}; ignored", "NotHonoured")
    if not attributes:
        return
    for rel in prim.GetAuthoredRelationships():
        name = rel.GetName()
        if name in _RELATIONSHIP_WHY and rel.GetTargets():
            notes.warn(path, name, f"{_RELATIONSHIP_WHY[name]}; ignored", "NotHonoured")


def samples_listable(stage: Usd.Stage) -> bool:
    """False when a layer of the stage has timeCodesPerSecond 0: USD then maps its time
    samples by an infinite or zero scale, and listing them does not return."""
    return all(layer.timeCodesPerSecond != 0 for layer in stage.GetUsedLayers() if layer)


def unknown_type(prim) -> str | None:
    """Why a prim of this type is not drawn, or None when the reader handles it (or it draws nothing)."""
    kind = str(prim.GetTypeName())
    if not kind:
        return None
    if not prim.IsA(Usd.Typed):
        return f"its type {kind!r} is not known to USD here (no schema is loaded for it); not rendered"
    if prim.IsA(UsdLux.BoundableLightBase) or prim.IsA(UsdLux.NonboundableLightBase):
        return None  # the light reader says which lights it supports
    drawn = (UsdGeom.Gprim, UsdGeom.PointInstancer, UsdSkel.Root, UsdSkel.Skeleton)  # skinning: a warning of its own
    if prim.IsA(UsdGeom.Boundable) and not any(prim.IsA(t) for t in drawn):
        return f"{kind} prims are not rendered; skipped"
    return None
