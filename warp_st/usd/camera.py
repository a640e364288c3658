"""The camera at a USD time code (docs/spec.md §3): ``Scene.camera_state``; and the
default camera of a stage without one (:class:`Framing`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom

from warp_st.core.conventions import LightSpeed
from warp_st.core.limits import MAX_MAGNITUDE
from warp_st.core.scene import DEFAULT_CAMERA, CameraState, SceneError
from warp_st.usd import attributes as A
from warp_st.usd.animation import animated_op, xform_sample_times
from warp_st.usd.attributes import SPACETIME_BODY_API, Where, body_kinematics, has_api
from warp_st.usd.geometry import world_transform
from warp_st.usd.stage import open_stage, tf_message

__all__ = ["CameraEvaluator", "Framing", "frame_bounds", "lab_from_camera"]

#: usdrecord's free camera is a default GfCamera: a 50 mm lens, 15.2908 mm vertical aperture.
FRAMING_FOCAL_LENGTH = 50.0
FRAMING_VERTICAL_APERTURE = 15.2908
#: Bounds whose extent along the up axis is at most this fraction of their width or depth
#: are framed from above (see :func:`frame_bounds`).
FLAT_FRACTION = 0.01


#: The one error line of a stage with no camera and nothing for the default camera to frame.
NOTHING_TO_RENDER = ("nothing to render: the stage has no camera and no supported visible geometry for the "
                     "default camera to frame")


@dataclass(frozen=True)
class Framing:
    """The default camera: at rest in the lab, its time the rendered time code."""

    position: tuple[float, float, float]
    rotation: tuple[tuple[float, ...], ...]  # lab_from_camera, rows
    horizontal_aperture: float
    vertical_aperture: float = FRAMING_VERTICAL_APERTURE
    focal_length: float = FRAMING_FOCAL_LENGTH
    lab_per_code: float = 1.0  # the stage's light speed (docs/spec.md §3.1)

    def state(self, frame: float) -> CameraState:
        return CameraState(prim_path=DEFAULT_CAMERA, time=self.lab_per_code * float(frame),
                           position=np.array(self.position),
                           rotation=np.array(self.rotation), focal_length=self.focal_length,
                           horizontal_aperture=self.horizontal_aperture, vertical_aperture=self.vertical_aperture)

    @property
    def view(self) -> np.ndarray:
        """The lab direction the camera looks along (its -Z)."""
        return -np.array(self.rotation)[:, 2]

    def describe(self) -> str:
        fov = math.degrees(2.0 * math.atan(0.5 * self.vertical_aperture / self.focal_length))
        p = ", ".join(f"{c:.6g}" for c in self.position)
        v = ", ".join(f"{c:.6g}" for c in self.view + 0.0)
        return f"at rest at ({p}) looking along ({v}), vertical field of view {fov:.4g} degrees"


def frame_bounds(lo, hi, up_axis: str, aspect: float) -> Framing:
    """usdrecord's free camera for the world bounds ``lo``..``hi``: a default (50 mm) lens
    looking along -Z (upAxis Y) or +Y (upAxis Z, +Z up) at the bounds' centre, backed off
    until the face of the bounds towards it fills the frame in both directions (the
    horizontal aperture gives ``aspect`` = width / height). Flat bounds, less than
    FLAT_FRACTION as high as they are wide or deep (a floor, decals, an asset on a large
    ground plane), are seen from above instead: edge-on they would show nothing."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    centre, size = 0.5 * (lo + hi), hi - lo
    up = 2 if up_axis == "Z" else 1
    across = max(size[i] for i in range(3) if i != up)
    if size[up] > FLAT_FRACTION * across or not size.any():
        # columns: camera +X, +Y, +Z in the lab; the camera looks down its -Z
        rotation = np.eye(3) if up == 1 else np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    else:  # look down the up axis, the image's top towards the depth axis
        rotation = (np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]) if up == 1 else np.eye(3))
    right, top, back = np.abs(rotation.T @ size) * 0.5
    h_ap = FRAMING_VERTICAL_APERTURE * float(aspect)
    tan_h = 0.5 * h_ap / FRAMING_FOCAL_LENGTH
    tan_v = 0.5 * FRAMING_VERTICAL_APERTURE / FRAMING_FOCAL_LENGTH
    front = max(right / tan_h, top / tan_v)
    if front == 0.0:  # a single point: stand one unit off
        front = 1.0
    position = centre + rotation[:, 2] * (front + back)
    return Framing(tuple(float(c) for c in position), tuple(tuple(float(c) for c in row) for row in rotation),
                   float(h_ap))


class CameraEvaluator:
    """``camera_state(path, frame) -> CameraState``: a camera at a USD time code (docs/spec.md §3).

    path None selects the scene's default camera; DEFAULT_CAMERA the ``framing`` (a stage
    without a camera). Holds the open stage; pickling
    keeps only how to reopen it: the file path when the scene was loaded from a
    path (``reopen``), else the flattened text of the stage that was passed in
    (so in-memory edits survive). The stage is reopened on first use.
    """

    def __init__(self, stage: Usd.Stage, where: Where, cameras: tuple[str, ...],
                 default_camera: str | None, *, reopen: str | None = None, no_references: bool = False,
                 framing: Framing | None = None):
        self._stage = stage
        self.framing = framing
        self.where = where
        self.cameras = cameras
        self.default_camera = default_camera
        self.reopen = reopen
        self.no_references = no_references

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_stage"] = None
        if self.reopen is None and self._stage is not None:
            state["_text"] = self._stage.ExportToString()
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    def stage(self) -> Usd.Stage:
        if self._stage is None:
            if self.reopen is not None:
                self._stage, _ = open_stage(self.reopen, no_references=self.no_references)
            else:
                layer = Sdf.Layer.CreateAnonymous(".usda")
                layer.ImportFromString(self.__dict__.pop("_text"))
                self._stage = Usd.Stage.Open(layer)
        return self._stage

    def __call__(self, path: str | None = None, frame: float = 0.0) -> CameraState:
        try:
            return self._evaluate(path, frame)
        except (Tf.ErrorException, UnicodeDecodeError) as exc:  # a value a corrupt file cannot unpack
            raise SceneError.at(self.where.file, str(path or self.default_camera), None,
                                f"cannot be read: {tf_message(exc)}") from None

    def _evaluate(self, path: str | None, frame: float) -> CameraState:
        w = self.where
        path = path or self.default_camera or DEFAULT_CAMERA
        frame = float(frame)
        if not math.isfinite(frame) or abs(frame) > MAX_MAGNITUDE:
            raise SceneError.at(w.file, str(path), None, f"frame must be finite and within +-{MAX_MAGNITUDE:g}, got {frame}")
        if path == DEFAULT_CAMERA:
            if self.framing is None:
                raise SceneError.at(w.file, None, None, NOTHING_TO_RENDER)
            return self.framing.state(frame)
        prim = self.stage().GetPrimAtPath(str(path))
        if not prim or not prim.IsA(UsdGeom.Camera):
            known = ", ".join(self.cameras) or "none"
            raise SceneError.at(w.file, str(path), None, f"no such camera (cameras: {known})")
        tc = Usd.TimeCode(frame)
        projection = UsdGeom.Camera(prim).GetProjectionAttr().Get(tc)
        if projection != UsdGeom.Tokens.perspective:
            raise w.error(prim, "projection", f"must be perspective, got {projection!r}")

        world = world_transform(w, prim, lambda: UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(tc), tc)
        position = np.array(world.ExtractTranslation(), dtype=np.float64)
        rotation = lab_from_camera(world)
        if rotation is None:
            raise w.error(prim, "xformOpOrder", "the world transform is singular")

        # t_c: spacetime:time at this time code, else the time code itself (docs/spec.md §3), in
        # lab time (x the stage's light speed, docs/spec.md §3.1).
        time = A.real(w, prim, "spacetime:time", None, time=tc)
        time = w.lab_per_code * (frame if time is None else time)
        light_speed = A.token(w, prim, "spacetime:lightSpeed", tuple(s.value for s in LightSpeed),
                              LightSpeed.FINITE.value, time=tc)
        velocity, decoupled = self._animated_velocity(prim, frame, position, time), False
        if has_api(prim, SPACETIME_BODY_API):
            # A moving camera: its world position o holds at t_ref; at t_c it is o + v (t_c - t_ref).
            uniform, t_ref, _, decoupled = body_kinematics(w, prim)
            position = position + uniform * (time - t_ref)
            velocity = velocity + uniform  # composed with its animation (docs/spec.md §2.1)
        if not decoupled and not float(np.linalg.norm(velocity)) < 1.0:
            raise w.error(prim, "xformOpOrder", f"the animated camera moves at {float(np.linalg.norm(velocity)):.6g} c "
                                                f"at time code {frame:g} (>= the speed of light); slow the animation "
                                                "or set spacetime:lorentzDecoupled = true")

        def positive(name, fallback):
            return A.real(w, prim, name, fallback, time=tc, positive=True)

        return CameraState(
            prim_path=str(prim.GetPath()),
            time=float(time),
            position=position,
            rotation=rotation,
            focal_length=positive("focalLength", 50.0),
            horizontal_aperture=positive("horizontalAperture", 20.955),
            vertical_aperture=positive("verticalAperture", 15.2908),
            horizontal_aperture_offset=A.real(w, prim, "horizontalApertureOffset", 0.0, time=tc),
            vertical_aperture_offset=A.real(w, prim, "verticalApertureOffset", 0.0, time=tc),
            light_speed=LightSpeed(light_speed),
            velocity=velocity,
            decoupled=decoupled,
        )


    def _animated_velocity(self, prim, frame: float, position: np.ndarray, time: float) -> np.ndarray:
        """d(position)/d(t_c) of USD's interpolation at ``frame`` (docs/spec.md §2.1): a
        forward difference (the motion from the camera event on; exact between linear
        samples), zero when no xformOp of the camera or its ancestors is time-sampled or the
        camera does not move there."""
        if len(xform_sample_times(prim)) < 2:
            return np.zeros(3)
        w = self.where
        step = ANIMATION_STEP * max(1.0, abs(frame))
        tc = Usd.TimeCode(frame + step)
        later = world_transform(w, prim, lambda: UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(tc), tc)
        moved = np.array(later.ExtractTranslation(), dtype=np.float64) - position
        if not moved.any():  # time-sampled but still here (equal samples, or a hold): at rest
            return np.zeros(3)
        t_later = A.real(w, prim, "spacetime:time", None, time=tc)
        dt = w.lab_per_code * step if t_later is None else w.lab_per_code * t_later - time
        if not dt > 0.0:  # the fault is the motion authored where the camera's time stands still
            owner, op = animated_op(prim)
            raise w.error(owner, op, f"moves the camera at time code {frame:g}, where its spacetime:time does not "
                                     "increase (a camera cannot move in no lab time)")
        return moved / dt


#: The time-code step of an animated camera's finite-difference velocity, relative to max(1, |frame|).
ANIMATION_STEP = 1.0e-6


def lab_from_camera(world: Gf.Matrix4d) -> np.ndarray | None:
    """Orthonormal lab_from_camera (columns = camera +X, +Y, +Z in the lab).

    USD matrices act on row vectors, so rows 0..2 are the images of the local axes.
    Scale and shear are removed by Gram-Schmidt that keeps the view axis (Z) exact
    and the up axis (Y) in its authored plane.
    """
    m = np.array(world, dtype=np.float64).reshape(4, 4)
    z = m[2, :3]
    if not np.linalg.norm(z) > 0.0:
        return None
    z = z / np.linalg.norm(z)
    y = m[1, :3] - np.dot(m[1, :3], z) * z
    if not np.linalg.norm(y) > 1e-12:
        return None
    y = y / np.linalg.norm(y)
    x = np.cross(y, z)
    return np.column_stack([x, y, z])
