"""USD stage → :class:`warp_st.core.scene.Scene` (docs/spec.md §2 and §3).

One traversal in stage order (instance proxies included) collects:

- bodies: each prim with ``SpacetimeBodyAPI`` owns every gprim below it (the
  nearest such ancestor wins); a gprim with no such ancestor is a body of its own,
  at rest, with unbounded lifetime. Bodies with no visible geometry are dropped,
  so objectId = 1 + index counts only what can be seen. A camera is never a body.
- cameras (UsdGeom.Camera), lights (UsdLux Sphere, Distant, Rect and DiskLight) and the
  render settings (UsdRender.Settings) with their products and vars
  (``products``).

Everything but the camera is read once, at the stage's start time code (our
``spacetime:`` attributes at the default time code): the 4D database is static and
animation comes only from advancing the camera's time. The camera is evaluated per
frame by :class:`~warp_st.usd.camera.CameraEvaluator` (``Scene.camera_state``); a
stage without one is seen through a default camera framing its bounds.

What the stage says and the renderer does not honour is listed in
``Scene.diagnostics`` (``diagnostics``): warnings that ``render`` prints and
``validate`` lists, the same list. Real-world USD problems (an arc that does not
compose, a bad primvar) are warnings; our own ``spacetime:`` attributes are strict.

Module map: ``stage`` opens files, ``attributes`` reads typed and validated
values, ``geometry`` turns gprims into world-space triangles, ``materials`` reads
their materials, ``camera`` evaluates the camera per frame, ``diagnostics`` says
what is not honoured.
"""
from __future__ import annotations

import dataclasses
import math
import os
import warnings
from dataclasses import dataclass, field

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdSkel

from warp_st.core.conventions import DEFAULT_RESOLUTION, Precision
from warp_st.core.light_speed import LightSpeedSetting, parse_light_speed
from warp_st.core.limits import MAX_BOUNCES, MAX_PIXELS, MAX_SAMPLES
from warp_st.core.scene import (
    DEFAULT_CAMERA,
    Body,
    Light,
    RenderSettings,
    Scene,
    SceneError,
    Surface,
)
from warp_st.usd import attributes as A
from warp_st.usd.animation import animated_op, sample_motion, xform_sample_times
from warp_st.usd.attributes import (
    SPACETIME_BODY_API,
    Where,
    body_kinematics,
    has_api,
    static_time,
)
from warp_st.usd.camera import CameraEvaluator, frame_bounds
from warp_st.usd.deform import (
    SkinnedStage,
    is_skinned,
    points_sample_times,
    posed_points,
    sample_surface,
)
from warp_st.usd.diagnostics import (
    Notes,
    check_prim,
    composition,
    samples_listable,
    unknown_type,
)
from warp_st.usd.dome import read_dome
from warp_st.usd.geometry import GprimReader, is_hidden, world_transform
from warp_st.usd.light_motion import light_in_motion
from warp_st.usd.light_speed import (
    SCHEMA_LIGHT_SPEED,
    settings_and_schema_use,
    stage_light_speed,
)
from warp_st.usd.lights import SUPPORTED, read_light
from warp_st.usd.products import read_products
from warp_st.usd.rest_frame_motion import animation_frame, rest_frame_surfaces
from warp_st.usd.scene_bounds import scene_bounds
from warp_st.usd.stage import open_stage, tf_message

__all__ = ["load_scene", "read_stage", "open_stage", "CameraEvaluator", "body_kinematics"]

_PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


# -- bodies ---------------------------------------------------------------------------

@dataclass
class _BodyBuilder:
    prim_path: str
    origin: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference_time: float = 0.0
    lifetime: tuple[float, float] = (-math.inf, math.inf)
    decoupled: bool = False
    surfaces: list[Surface] = field(default_factory=list)
    api: bool = False  # carries SpacetimeBodyAPI (else: a gprim at rest, a body of its own)
    motion: object = None  # BodyMotion when USD animates it (docs/spec.md §2.1)
    rest_frame: bool = False  # spacetime:animationFrame = "rest" (usd/rest_frame_motion.py)

    def build(self) -> Body:
        return Body(self.prim_path, tuple(self.surfaces), self.origin, self.velocity,
                    self.reference_time, self.lifetime, self.decoupled, self.motion, rest_frame=self.rest_frame)


def _translation(matrix: Gf.Matrix4d) -> np.ndarray:
    return np.array(matrix.ExtractTranslation(), dtype=np.float64)


# -- the stage reader -------------------------------------------------------------------
class _StageReader:
    def __init__(self, stage: Usd.Stage, where: Where):
        self.stage = stage
        self.where = Where(where.file, static_time(stage))
        self.notes = Notes(where.file)
        self.xf = UsdGeom.XformCache(self.where.time)
        self.gprims = GprimReader(self.where, self.xf, self.notes)
        self.bodies: list[_BodyBuilder] = []
        self.lights: list[Light] = []
        self.domes: list = []  # DomeLight prims: the first is the sky (usd/dome.py)
        self.cameras: list[str] = []
        self.settings_prims: list = []
        self._current = None
        self.skinned = SkinnedStage(stage)  # UsdSkel.BakeSkinning on a copy, made on first use

    def read(self, *, reopen: str | None = None, no_references: bool = False,
             light_speed: LightSpeedSetting | None = None) -> Scene:
        # (not in __init__: validators build readers inside USD's worker threads, where
        # GetUsedLayers can wait on a lock a thread waiting for the GIL holds)
        self.notes.count_samples = samples_listable(self.stage)
        composition(self.notes, self.stage)
        self.light_speed, self.light_speed_origin = self._light_speed(light_speed)
        self.where = dataclasses.replace(self.where, lab_per_code=self.light_speed)
        self._traverse()
        dome = read_dome(self.where, self.notes, self.domes, self._world)  # the sky (usd/dome.py)
        settings_prim = self._settings_prim()
        settings = self._render_settings(settings_prim)
        products = () if settings_prim is None else read_products(self.where, self.stage, settings_prim,
                                                                   self._resolution)
        if settings_prim is not None:
            check_prim(self.notes, settings_prim, self.where.time)
        for body in self.bodies:
            if body.rest_frame and body.surfaces:  # lab samples boosted from its rest frame (§2.1, 0.7.0)
                body.surfaces = rest_frame_surfaces(self.where, self.stage, body, self.notes)
            self._deforming_body(body)
            self._check_points(body)
        bodies = tuple(b.build() for b in self.bodies if b.surfaces)
        cameras = tuple(self.cameras)
        framing = None
        if bodies:
            framing = dataclasses.replace(frame_bounds(*scene_bounds(bodies, self.stage), str(UsdGeom.GetStageUpAxis(
                self.stage)), _aspect(settings.resolution)), lab_per_code=self.light_speed)
        self._closing_notes(cameras, framing)
        default_camera = settings.camera or (cameras[0] if cameras else DEFAULT_CAMERA)
        frame_range = None
        if self.stage.HasAuthoredTimeCodeRange():
            frame_range = (float(self.stage.GetStartTimeCode()), float(self.stage.GetEndTimeCode()))
        return Scene(
            source=self.where.file,
            bodies=bodies,
            lights=tuple(self.lights),
            cameras=cameras,
            settings=settings,
            camera_state=CameraEvaluator(self.stage, self.where, cameras, default_camera,
                                         reopen=reopen, no_references=no_references, framing=framing),
            up_axis=str(UsdGeom.GetStageUpAxis(self.stage)),
            frame_range=frame_range,
            default_camera=default_camera,
            products=products,
            diagnostics=self.notes.items(),
            meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(self.stage)),
            time_codes_per_second=float(self.stage.GetTimeCodesPerSecond()),
            dome=dome,
            light_speed=self.light_speed,
            light_speed_origin=self.light_speed_origin,
        )

    def _closing_notes(self, cameras, framing) -> None:
        """What only the whole stage tells: subdivision (one line), bodies with nothing to
        draw, the light speed and the default camera (information) or nothing to render at all."""
        if self.gprims.subdivided:
            first, more = self.gprims.subdivided[0], len(self.gprims.subdivided) - 1
            others = f" (and {more} more mesh{'es' if more > 1 else ''})" if more else ""
            self.notes.warn(first, "subdivisionScheme", f"subdivision surfaces are not refined{others}: they render "
                                                         "their control cage (the authored polygons)", "Subdivision")
        for body in self.bodies:
            if not body.surfaces and body.api:
                self.notes.warn(body.prim_path, None, "has SpacetimeBodyAPI but no visible supported geometry of its "
                                                      "own: nothing of this body is rendered", "EmptyBody")
        if self.light_speed_origin != SCHEMA_LIGHT_SPEED:
            self.notes.info(None, None, f"light speed {self.light_speed:.9g} stage units per time code: "
                                        f"{self.light_speed_origin}", "LightSpeed")
        if not cameras and framing is None:
            self.notes.warn(None, None, "the stage has no camera and no supported visible geometry: there is nothing "
                                        "to render (as a layer to reference it is fine)", "NothingToRender")
        elif not cameras:
            self.notes.info(None, None, f"the stage has no camera (UsdGeom.Camera): it renders through the default "
                                        f"camera, {framing.describe()}, framing the stage's bounds", "DefaultCamera")

    def _traverse(self) -> None:
        """Depth-first, pre-order: a subtree is contiguous, so hidden subtrees and
        body ownership are tracked with a path prefix and a stack."""
        hidden: Sdf.Path | None = None
        owners: list[tuple[Sdf.Path, _BodyBuilder]] = []  # enclosing SpacetimeBodyAPI prims
        it = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), _PREDICATE))
        try:
            self._visit_all(it, hidden, owners)
        except (Tf.ErrorException, UnicodeDecodeError) as exc:  # a corrupt crate file fails when a value is unpacked
            raise self.where.error(self._current, None, f"cannot be read: {tf_message(exc)}") from None

    def _visit_all(self, it, hidden, owners) -> None:
        notes, time = self.notes, self.where.time
        skipped = {p for p, a in A.MASKED.get() if a is None}  # validate's masked reads skip these subtrees
        for prim in it:
            self._current = prim
            if prim.IsPseudoRoot():
                continue
            path = prim.GetPath()
            if skipped and str(path) in skipped:
                it.PruneChildren()
                continue
            if hidden is not None and not path.HasPrefix(hidden):
                hidden = None
            while owners and not path.HasPrefix(owners[-1][0]):
                owners.pop()
            if prim.IsA(UsdGeom.Camera):
                self.cameras.append(str(path))
                if has_api(prim, SPACETIME_BODY_API):
                    body_kinematics(self.where, prim)  # validated now, used per frame
                check_prim(notes, prim, time, samples=False)  # a camera is evaluated per frame
                continue
            if prim.IsA(UsdRender.Settings):
                if prim not in self.settings_prims:  # (the light-speed pass found it first)
                    self.settings_prims.append(prim)
                it.PruneChildren()
                continue
            if hidden is None and is_hidden(prim, time):
                hidden = path
            if has_api(prim, SPACETIME_BODY_API):
                v, t_ref, life, decoupled = body_kinematics(self.where, prim)
                body = _BodyBuilder(str(path), _translation(self._world(prim)), v, t_ref, life, decoupled, api=True)
                body.rest_frame = animation_frame(self.where, prim, decoupled) == "rest"
                if body.rest_frame:  # its motion is sampled per gprim, in its rest frame
                    self._animation_samples(prim)
                else:
                    self._animate(body, prim)
                owners.append((path, body))
                self.bodies.append(body)
            if hidden is not None:
                continue
            why = unknown_type(prim)
            if why:
                notes.warn(prim, None, why, "UnsupportedPrim")
            if prim.HasAPI(UsdLux.MeshLightAPI) or prim.HasAPI(UsdLux.VolumeLightAPI):
                notes.warn(prim, None, "MeshLightAPI / VolumeLightAPI is not honoured: the prim does not light "
                                       "the scene", "NotHonoured")
            if prim.IsA(UsdLux.BoundableLightBase) or prim.IsA(UsdLux.NonboundableLightBase):
                self._light(prim)
            elif prim.IsA(UsdGeom.PointInstancer):
                if not owners:  # a body of its own: its honoured samples are not warned by its checks
                    self._animation_samples(prim)
                self._owner(owners, prim).surfaces.extend(self.gprims.instancer_surfaces(prim))
                it.PruneChildren()  # prototypes are drawn only through their instances
            elif prim.IsA(UsdGeom.Gprim):
                if not owners or owners[-1][1].rest_frame:  # (a rest-frame body samples each gprim's own)
                    self._animation_samples(prim)
                surface = self._deformed(prim)
                if surface is not None:
                    self._owner(owners, prim).surfaces.append(surface)

    def _deformed(self, prim):
        """The gprim's surface; a mesh with time-sampled points or skinned by UsdSkel gets
        its world points at USD's sample times (docs/spec.md §2.2, ``usd/deform.py``)."""
        source = None
        if self.notes.count_samples and points_sample_times(prim):
            source = prim
        elif self.notes.count_samples and is_skinned(prim):
            source = self.skinned.prim(prim.GetPath())
            if source is None:
                self.notes.warn(prim, None, f"UsdSkel could not skin it ({self.skinned.why(prim)}); rendered as "
                                            "authored", "NotHonoured")
        elif prim.IsA(UsdGeom.Mesh) and UsdSkel.Root.Find(prim) and UsdSkel.BindingAPI(prim).GetInheritedSkeleton():
            self.notes.warn(prim, "primvars:skel:jointIndices", "the mesh is bound to a skeleton but has no joint "
                                                                "indices: UsdSkel does not skin it; rendered as "
                                                                "authored", "NotHonoured")
        if source is None:
            return self.gprims.surface(prim)
        p = prim
        self.notes.deformed.add(str(prim.GetPath()))
        while p and not p.IsPseudoRoot():  # its world points follow every xformOp above it
            self.notes.animated.add(str(p.GetPath()))
            p = p.GetParent()
        surface = self.gprims.surface(prim)
        samples = None if surface is None else sample_surface(self.where, prim, surface, source, self.notes)
        if samples is None:
            posed = None if surface is None or source == prim else posed_points(self.where, source, surface)
            return surface if posed is None else dataclasses.replace(surface, points=posed)
        return dataclasses.replace(surface, samples=samples, points=samples.at(self.where.lab_per_code * self.where.time.GetValue()),
                                   sphere=None, quadric=None)

    def _deforming_body(self, body: _BodyBuilder) -> None:
        """A body with a deforming surface (docs/spec.md §2.2): Lorentz-decoupled (its points
        are lab positions), its other surfaces sampled through their world transforms when
        USD animates it (then it has no rigid motion of its own)."""
        deforming = [s for s in body.surfaces if s.samples is not None]
        if not deforming:
            return
        if body.motion is not None:
            for i, surface in enumerate(body.surfaces):
                prim = self.stage.GetPrimAtPath(surface.prim_path) if surface.samples is None else None
                samples = sample_surface(self.where, prim, surface) if prim and prim.IsA(UsdGeom.Gprim) else None
                if samples is not None:
                    body.surfaces[i] = dataclasses.replace(surface, samples=samples, sphere=None, quadric=None)
                elif surface.samples is None:
                    self.notes.warn(surface.prim_path, None, "an instance in a deforming body: it does not follow the "
                                                             "body's animation (rendered where it is at the start "
                                                             "time code)", "NotHonoured")
            body.motion = None
        times = np.concatenate([s.samples.times for s in deforming]) / self.where.lab_per_code  # time codes
        how = "Lorentz-decoupled: its points are lab positions" + ("" if body.decoupled or not body.api else
                                                                     " (spacetime:lorentzDecoupled is not set)")
        if body.rest_frame:
            how = "animated in its rest frame: its points are lab positions boosted from it (§2.1)"
        self.notes.info(body.prim_path, None, f"deforming: {len(deforming)} surface(s) sampled at "
                                              f"{len(np.unique(times))} time codes ({times.min():g} to {times.max():g}); "
                                              f"{how}; the scene renders on the tetrahedral path", "Deforming")
        body.decoupled = True

    def _world(self, prim) -> Gf.Matrix4d:
        """The prim's world transform, finite and within MAX_MAGNITUDE (else SceneError naming the op)."""
        return world_transform(self.where, prim, lambda: self.xf.GetLocalToWorldTransform(prim), self.where.time)

    def _owner(self, owners: list[tuple[Sdf.Path, _BodyBuilder]], prim) -> _BodyBuilder:
        """The nearest enclosing body, else a new body at rest at the prim's world origin."""
        if owners:
            return owners[-1][1]
        body = _BodyBuilder(str(prim.GetPath()), _translation(self._world(prim)))
        self._animate(body, prim)
        self.bodies.append(body)
        return body

    def _animation_samples(self, prim) -> tuple[float, ...]:
        """USD's sample times of the xformOps moving ``prim`` (none: not animated, or a
        stage whose samples cannot be listed); their prims' xformOp samples are honoured."""
        if not self.notes.count_samples:
            return ()
        samples = xform_sample_times(prim)
        if len(samples) < 2:
            return ()
        p = prim
        while p and not p.IsPseudoRoot():
            self.notes.animated.add(str(p.GetPath()))
            p = p.GetParent()
        return samples

    def _animate(self, body: _BodyBuilder, prim) -> None:
        """Sample ``prim``'s animation into ``body.motion`` (docs/spec.md §2.1): a coupled
        SpacetimeBodyAPI body at >= c is bad input; a body of its own turns decoupled."""
        samples = self._animation_samples(prim)
        if not samples:
            return
        body.motion = sample_motion(self.where, prim, body.velocity, body.reference_time, samples)
        if not body.decoupled:
            self._superluminal(body, prim, samples, np.linalg.norm(body.motion.chord_velocities(), axis=1),
                               "the animated pivot")

    def _check_points(self, body: _BodyBuilder) -> None:
        """A turning coupled body whose points (its vertices) move at >= c is treated as a
        pivot at >= c is (``_animate``): the velocity of a point is its own (§2.1, Doppler)."""
        if body.decoupled or body.motion is None or not body.surfaces:
            return
        prim = self.stage.GetPrimAtPath(body.prim_path)
        points = np.concatenate([np.asarray(s.points, dtype=np.float64).reshape(-1, 3) for s in body.surfaces])
        self._superluminal(body, prim, xform_sample_times(prim), body.motion.point_speeds(points, False),
                           "a point of the animated body")

    def _superluminal(self, body: _BodyBuilder, prim, samples, speeds: np.ndarray, what: str) -> None:
        """Bad input (SpacetimeBodyAPI) or a warning and decoupled (a body of its own) when
        ``speeds`` (per probe interval) reach c."""
        if not speeds.size or not float(speeds.max()) >= 1.0:
            return
        k = int(np.argmax(speeds))
        t = body.motion.times / self.where.lab_per_code  # time codes
        lo = max(s for s in samples if s <= t[k])
        hi = min(s for s in samples if s >= t[k + 1])
        owner, op = animated_op(prim)  # the attribute at fault: the xformOp that moves the body
        whose = "" if owner == prim else f" of {prim.GetPath()}"
        message = (f"{what}{whose} moves at {float(speeds[k]):.6g} c between time codes {lo:g} and "
                   f"{hi:g} (>= the speed of light)")
        if body.api:
            raise self.where.error(owner, op, f"{message} on a Lorentz-coupled body; slow the animation "
                                              "or set spacetime:lorentzDecoupled = true")
        body.decoupled = True
        self.notes.warn(owner, op, f"{message}: rendered Lorentz-decoupled", "Superluminal")

    # -- lights ---------------------------------------------------------------------
    def _light(self, prim) -> None:
        """A UsdLux light as UsdLux defines it (docs/spec.md §3; ``warp_st.usd.lights``); a
        DomeLight is the sky (``warp_st.usd.dome``)."""
        if prim.IsA(UsdLux.DomeLight):
            self.gprims.check(prim)
            self.domes.append(prim)
            return
        samples = self._animation_samples(prim) if str(prim.GetTypeName()) in SUPPORTED else ()
        if str(prim.GetTypeName()) in SUPPORTED:
            self.gprims.check(prim)  # after the samples: an animated light's xformOp samples are honoured
        light = read_light(self.where, prim, self._world(prim), self.notes)
        if light is not None:
            self.lights.append(light_in_motion(self.where, prim, light, samples, self.notes))

    # -- render settings ------------------------------------------------------------
    def _light_speed(self, requested: LightSpeedSetting | None) -> tuple[float, str]:
        """The stage's light speed and where it comes from (``warp_st.usd.light_speed``)."""
        if requested is not None:
            return stage_light_speed(self.stage, self.where, self.notes, requested, None, False)
        self.settings_prims, ours = settings_and_schema_use(self.stage)
        return stage_light_speed(self.stage, self.where, self.notes, None, self._settings_prim(), ours)

    def _settings_prim(self):
        """The stage's renderSettingsPrimPath, else the first RenderSettings prim, else None."""
        chosen = self.stage.GetMetadata("renderSettingsPrimPath") or ""
        if chosen:
            prim = self.stage.GetPrimAtPath(chosen)
            if not prim or not prim.IsA(UsdRender.Settings):
                raise SceneError.at(self.where.file, None, "renderSettingsPrimPath",
                                    f"{chosen} is not a UsdRender.Settings prim")
            return prim
        return self.settings_prims[0] if self.settings_prims else None

    def _resolution(self, prim) -> tuple[int, int] | None:
        """The authored ``resolution`` of a settings or product prim, validated."""
        w = self.where
        resolution = A.int2(w, prim, "resolution")
        if resolution is not None and min(resolution) <= 0:
            raise w.error(prim, "resolution", f"must be positive, got {resolution}")
        if resolution is not None and resolution[0] * resolution[1] > MAX_PIXELS:
            raise w.error(prim, "resolution", f"{resolution[0]} x {resolution[1]} is more than {MAX_PIXELS} pixels")
        return resolution

    def _render_settings(self, prim) -> RenderSettings:
        w = self.where
        if prim is None:
            return RenderSettings()
        resolution = self._resolution(prim)
        camera = None
        targets = UsdRender.Settings(prim).GetCameraRel().GetForwardedTargets()
        if targets:
            target = self.stage.GetPrimAtPath(targets[0])
            if not target or not target.IsA(UsdGeom.Camera):
                raise w.error(prim, "camera", f"{targets[0]} is not a UsdGeom.Camera")
            camera = str(targets[0])
        precision = A.token(w, prim, "spacetime:precision", tuple(p.value for p in Precision))
        return RenderSettings(
            resolution=resolution,
            camera=camera,
            max_depth=A.integer(w, prim, "spacetime:maxDepth", minimum=0, maximum=MAX_BOUNCES),
            samples=A.integer(w, prim, "spacetime:samples", minimum=1, maximum=MAX_SAMPLES),
            shutter=A.real(w, prim, "spacetime:shutter", minimum=0.0),
            precision=Precision(precision) if precision else None,
            background=_tuple(A.vector(w, prim, "spacetime:background", 3)),
            doppler_color=A.boolean(w, prim, "spacetime:dopplerColor"),
            searchlight=A.boolean(w, prim, "spacetime:searchlight"),
            prim_path=str(prim.GetPath()),
        )


def _tuple(v):
    return None if v is None else tuple(float(c) for c in v)


def _aspect(resolution) -> float:
    width, height = resolution or DEFAULT_RESOLUTION
    return width / height


def load_scene(source, *, no_references: bool = False, light_speed: str | LightSpeedSetting | None = None) -> Scene:
    """Read a USD stage (a path or a ``Usd.Stage``) into a :class:`Scene`.

    Raises :class:`SceneError` (one line naming the file, prim and attribute) for a
    stage that cannot be opened or holds nothing to render, and for bad values of our
    own ``spacetime:`` attributes (and geometry that cannot be built); what the reader
    leaves out is a Python warning each (``Scene.diagnostics``). ``no_references=True``
    composes only the file's own layers (see :func:`open_stage`). ``light_speed`` (e.g.
    ``"299792458m/s"``, ``"2units/timecode"``) overrides the stage's (docs/spec.md §3.1).
    """
    if isinstance(light_speed, str):
        light_speed = parse_light_speed(light_speed)
    stage, where = open_stage(source, no_references=no_references)
    reopen = None if isinstance(source, Usd.Stage) else os.path.abspath(os.fspath(source))
    scene = read_stage(stage, where, reopen=reopen, no_references=no_references, light_speed=light_speed)
    for note in scene.diagnostics:
        if note.severity == "warning":
            warnings.warn(note.text(), stacklevel=2)
    return scene


def read_stage(stage: Usd.Stage, where: Where, *, reopen: str | None = None, no_references: bool = False,
               light_speed: LightSpeedSetting | None = None) -> Scene:
    """The :class:`Scene` of an open stage, its diagnostics not emitted (``load_scene`` warns them)."""
    try:
        return _StageReader(stage, where).read(reopen=reopen, no_references=no_references, light_speed=light_speed)
    except (Tf.ErrorException, UnicodeDecodeError) as exc:  # a value USD cannot unpack outside the traversal
        raise SceneError.at(where.file, None, None, f"cannot be read: {tf_message(exc)}") from None
