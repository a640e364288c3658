"""The host scene model: what a stage says, in the lab frame, float64, backend-free.

The USD reader (``warp_st.usd.reader``) produces a :class:`Scene`; the extrusion,
BVH and render steps consume it. Nothing here imports ``pxr`` or ``warp``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from warp_st.core.conventions import LightSpeed, Precision

__all__ = [
    "SceneError",
    "surface_triangles",
    "Material",
    "Surface",
    "Body",
    "Light",
    "CameraState",
    "RenderSettings",
    "RenderVar",
    "RenderProduct",
    "Scene",
    "Diagnostic",
    "DEFAULT_CAMERA",
]

#: ``Scene.default_camera`` (and the header's ``spacetime:camera``) of a stage without a
#: UsdGeom.Camera: a camera at rest framing the stage's bounds (``warp_st.usd.camera``).
DEFAULT_CAMERA = "default"


class SceneError(ValueError):
    """Bad input: the message names the file, the prim and the attribute."""

    @classmethod
    def at(cls, file: str | None, prim: str | None, attribute: str | None, problem: str) -> "SceneError":
        where = ": ".join(p for p in (file, prim, attribute) if p)
        error = cls(f"{where}: {problem}" if where else problem)
        error.where = (file, prim, attribute, problem)  # the parts, for a reader that only warns
        return error


@dataclass(frozen=True)
class Diagnostic:
    """One thing of a stage the renderer does not honour (severity "warning"), or a
    choice it made for the stage (severity "info", e.g. the default camera).

    The reader makes the one list (``Scene.diagnostics``) that ``render`` prints and
    ``validate`` lists. ``code`` names the class (e.g. "TimeSampled", "Composition").
    """

    severity: str
    file: str
    prim: str | None
    attribute: str | None
    message: str
    code: str

    def text(self) -> str:
        """``file: /prim: attribute: message``, as a SceneError reads."""
        return str(SceneError.at(self.file, self.prim, self.attribute, self.message))


@dataclass(frozen=True)
class Material:
    """UsdPreviewSurface subset. Colours are linear RGB.

    ``metallic`` is the weight of a perfect mirror (docs/spec.md §2).
    """

    diffuse: tuple[float, float, float] = (0.18, 0.18, 0.18)
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)
    metallic: float = 0.0


@dataclass(frozen=True, eq=False)
class Surface:
    """One gprim, triangulated, in world space at the body's reference time.

    points: authored world-space positions, shape (P, 3), float64 (not yet
        Lorentz contracted: extrusion does that).
    triangles: vertex indices into ``points``, shape (T, 3), int64.
    normals: optional per-point shading normals in world space, shape (P, 3),
        unit length (e.g. a tessellated sphere); None means flat shading.
    sphere: for a UsdGeom.Sphere, the analytic shape the triangles approximate:
        (radius, world_from_local 4x4 float64 in USD's row-vector convention,
        p_world = p_local @ M[:3, :3] + M[3, :3]); the renderer re-tessellates it
        for the resolution (``warp_st.spacetime.adaptive.adapt_sphere_tessellation``). None for
        every other surface (its triangles are exact).
    """

    prim_path: str
    points: np.ndarray
    triangles: np.ndarray
    material: Material = Material()
    normals: np.ndarray | None = None
    sphere: tuple[float, np.ndarray] | None = None


@dataclass(frozen=True, eq=False)
class Body:
    """A set of surfaces sharing one worldline (docs/spec.md §2).

    origin: world-space pivot o of the prim carrying ``SpacetimeBodyAPI``, (3,).
    velocity: lab velocity v = (x, y, z) / t of ``spacetime:fourVelocity``, (3,).
    lifetime: lab times (tBegin, tEnd); +-inf when unbounded.
    motion: a ``warp_st.core.motion.BodyMotion`` when USD animates the body (docs/spec.md
        §2.1; ``velocity`` is then only its held part), else None.
    """

    prim_path: str
    surfaces: tuple[Surface, ...]
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference_time: float = 0.0
    lifetime: tuple[float, float] = (-np.inf, np.inf)
    decoupled: bool = False
    motion: object = None

    @property
    def speed(self) -> float:
        return float(np.linalg.norm(self.velocity))

    @property
    def gamma(self) -> float:
        """Lorentz factor; 1 for decoupled (classical) bodies."""
        if self.decoupled:
            return 1.0
        return 1.0 / np.sqrt(1.0 - self.speed**2)

    @property
    def triangle_count(self) -> int:
        return int(sum(len(s.triangles) for s in self.surfaces))


@dataclass(frozen=True)
class Light:
    """A light at rest in the lab.

    kind: "sphere" (a point at ``position``) or "distant" (from ``direction``).
    direction: unit vector from the scene towards a distant light (its local +Z).
    radiance: intensity * color * 2**exposure, linear RGB.
    """

    kind: str
    radiance: tuple[float, float, float]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: tuple[float, float, float] = (0.0, 0.0, 1.0)
    prim_path: str = ""


@dataclass(frozen=True, eq=False)
class CameraState:
    """The camera at one rendered frame.

    time: the camera event's lab time t_c (float64).
    position: the camera event's lab position c at t_c, (3,) (already moved by
        its velocity when the camera carries SpacetimeBodyAPI).
    rotation: lab_from_camera rotation, (3, 3), orthonormal; columns are the
        camera's +X, +Y, +Z axes in the lab (the camera looks down -Z).
    focal_length, apertures, offsets: USD camera units (ratios matter only).
    velocity: lab velocity of the camera, (3,); zero for a camera at rest.
    decoupled: True selects Galilean (classical) aberration for a moving camera.
    """

    prim_path: str
    time: float
    position: np.ndarray
    rotation: np.ndarray
    focal_length: float = 50.0
    horizontal_aperture: float = 20.955
    vertical_aperture: float = 15.2908
    horizontal_aperture_offset: float = 0.0
    vertical_aperture_offset: float = 0.0
    light_speed: LightSpeed = LightSpeed.FINITE
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    decoupled: bool = False

    def advanced(self, dt: float) -> "CameraState":
        """The camera event ``dt`` later along the camera's worldline (a shutter's end)."""
        return dataclasses.replace(self, time=self.time + dt,
                                   position=np.asarray(self.position) + np.asarray(self.velocity) * dt)


@dataclass(frozen=True)
class RenderSettings:
    """Options from an optional UsdRender.Settings prim; None means not authored."""

    resolution: tuple[int, int] | None = None
    camera: str | None = None
    max_depth: int | None = None
    samples: int | None = None
    shutter: float | None = None
    precision: Precision | None = None
    background: tuple[float, float, float] | None = None
    doppler_color: bool | None = None
    searchlight: bool | None = None
    prim_path: str | None = None

    def merged(self, **overrides) -> "RenderSettings":
        """A copy with every non-None override applied (command line wins)."""
        return dataclasses.replace(self, **{k: v for k, v in overrides.items() if v is not None})


@dataclass(frozen=True)
class RenderVar:
    """A UsdRender.Var resolved to docs/spec.md §4 channels (``warp_st.usd.products``).

    channels: (EXR channel name, docs/spec.md §4 channel) pairs, R before G before B before A.
    half: the FLOAT channels are stored as HALF (dataType half, color3h, ...).
    """

    prim_path: str
    source_name: str
    data_type: str
    channels: tuple[tuple[str, str], ...]
    half: bool = False


@dataclass(frozen=True)
class RenderProduct:
    """A UsdRender.Product: one EXR file per frame holding its vars' channels.

    name: productName's default value; name_samples: its time samples as
    (time code, name) pairs in time order, which win over the default at every
    frame (USD value resolution; tokens are held, never interpolated).
    camera, resolution: authored on the product (None: the settings' apply).
    """

    prim_path: str
    name: str
    vars: tuple[RenderVar, ...]
    name_samples: tuple[tuple[float, str], ...] = ()
    camera: str | None = None
    resolution: tuple[int, int] | None = None

    def name_at(self, frame: float) -> str:
        """productName at time code ``frame`` (held: the last sample at or before it,
        the first sample before them all)."""
        if not self.name_samples:
            return self.name
        name = self.name_samples[0][1]
        for time, value in self.name_samples:
            if time > frame:
                break
            name = value
        return name


@dataclass(frozen=True, eq=False)
class Scene:
    """Everything a render needs, read once from a stage.

    bodies: in stage traversal order; objectId = 1 + index.
    cameras: prim paths of the stage's cameras, traversal order.
    default_camera: the settings' camera, else the first camera; DEFAULT_CAMERA when the
        stage has none (a camera framing its bounds); None for a Scene made by hand.
    frame_range: the stage's (startTimeCode, endTimeCode) when authored.
    products: the settings' UsdRender products in ``products`` order (empty: none).
    diagnostics: what the reader did not honour (warnings) and chose (info), stage order.
    meters_per_unit, time_codes_per_second: the stage's metadata (None: not read).
    camera_state: ``camera_state(path, frame) -> CameraState`` evaluates a camera
        at a USD time code (the camera is the one thing that changes per frame).
    """

    source: str
    bodies: tuple[Body, ...]
    lights: tuple[Light, ...]
    cameras: tuple[str, ...]
    settings: RenderSettings
    camera_state: object = None
    up_axis: str = "Y"
    frame_range: tuple[float, float] | None = None
    default_camera: str | None = None
    products: tuple[RenderProduct, ...] = ()
    diagnostics: tuple[Diagnostic, ...] = ()
    meters_per_unit: float | None = None
    time_codes_per_second: float | None = None

    def body_paths(self) -> list[str]:
        return [b.prim_path for b in self.bodies]

    def header(self) -> dict[str, str]:
        """Stage metadata for every frame's EXR header (``spacetime:<key>``)."""
        items = {"metersPerUnit": self.meters_per_unit, "timeCodesPerSecond": self.time_codes_per_second}
        return {key: repr(float(value)) for key, value in items.items() if value is not None}


def surface_triangles(surf) -> np.ndarray:
    """A surface's triangles as (T, 3) int64, without degenerate index triples (no surface)."""
    tris = np.asarray(surf.triangles, dtype=np.int64).reshape(-1, 3)
    keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
    return tris[keep]
