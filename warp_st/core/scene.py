"""The host scene model: what a stage says, in the lab frame, float64, backend-free.

The USD reader (``warp_st.usd.reader``) produces a :class:`Scene`; the extrusion,
BVH and render steps consume it. Nothing here imports ``pxr`` or ``warp``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from warp_st.core.conventions import LightSpeed, Precision
from warp_st.core.motion import BodyMotion

__all__ = [
    "SceneError",
    "surface_triangles",
    "WRAP_MODES",
    "Texture",
    "Material",
    "Surface",
    "surface_keep",
    "Body",
    "Light",
    "Dome",
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


#: Texture wrap modes the kernel knows, in its numbering (docs/spec.md §2, textures).
WRAP_MODES = ("repeat", "clamp", "mirror", "black")


@dataclass(frozen=True, eq=False)
class Texture:
    """One UsdUVTexture output feeding a material input (docs/spec.md §2, textures).

    texels: (H, W, 4) float32, linear, ``scale`` and ``bias`` already applied; row 0 is
        the top of the image (t = 1), column 0 its left (s = 0).
    wrap: (wrapS, wrapT), each one of WRAP_MODES (``useMetadata`` already resolved).
    border: the value outside [0, 1] under "black" wrap: black, scaled and biased (the bias).
    channel: the output read: -1 for ``rgb``, 0..3 for ``r``, ``g``, ``b``, ``a``.
    primvar, st_fallback: the UsdPrimvarReader_float2's ``varname`` and ``fallback``
        (the st where the gprim has no such primvar).
    st_transform: (2, 3) affine map of st (UsdTransform2d nodes between the reader and
        the texture), None for none.
    """

    file: str
    texels: np.ndarray
    wrap: tuple[str, str] = ("repeat", "repeat")
    border: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    channel: int = -1
    primvar: str = "st"
    st_fallback: tuple[float, float] = (0.0, 0.0)
    st_transform: np.ndarray | None = None


@dataclass(frozen=True)
class Material:
    """UsdPreviewSurface subset. Colours are linear RGB.

    ``metallic`` is the weight of a perfect mirror (docs/spec.md §2). ``prim_path``: the
    bound UsdShade.Material's ("" for displayColor): the CryptoMaterial names (§4.4). A
    ``*_texture`` replaces the constant with a texture lookup at the hit's st (the
    constants then only matter where no texture is bound).
    """

    diffuse: tuple[float, float, float] = (0.18, 0.18, 0.18)
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)
    metallic: float = 0.0
    prim_path: str = ""
    diffuse_texture: Texture | None = None
    emissive_texture: Texture | None = None
    metallic_texture: Texture | None = None

    @property
    def textures(self) -> tuple[Texture | None, Texture | None, Texture | None]:
        """(diffuse, emissive, metallic) textures, None where the input is a constant."""
        return (self.diffuse_texture, self.emissive_texture, self.metallic_texture)


@dataclass(frozen=True, eq=False)
class Surface:
    """One gprim, triangulated, in world space at the body's reference time.

    points: authored world-space positions, shape (P, 3), float64 (not yet
        Lorentz contracted: extrusion does that).
    triangles: vertex indices into ``points``, shape (T, 3), int64.
    normals: optional per-point shading normals in world space, shape (P, 3),
        unit length (e.g. a tessellated sphere); None means flat shading.
    st: texture coordinates at each triangle corner, shape (T, 3, 2), aligned with
        ``triangles``; None when no material of the surface is textured.
    subset_materials, triangle_material: per-face materials (GeomSubset bindings):
        triangle i uses ``material`` where triangle_material[i] == 0, else
        subset_materials[triangle_material[i] - 1]; None: ``material`` everywhere.
    sphere: for a UsdGeom.Sphere, the analytic shape the triangles approximate:
        (radius, world_from_local 4x4 float64 in USD's row-vector convention,
        p_world = p_local @ M[:3, :3] + M[3, :3]); the renderer re-tessellates it
        for the resolution (``warp_st.spacetime.adaptive.adapt_sphere_tessellation``). None for
        every other surface (its triangles are exact).
    quadric: for a UsdGeom.Cylinder, Cone or Capsule, the analytic shape its triangles
        approximate: (kind "cylinder" / "cone" / "capsule", axis "X" / "Y" / "Z", radius,
        height, world_from_local 4x4 as for ``sphere``); None otherwise. The rigid path
        traces it exactly (``spacetime.rigid``).
    samples: a ``warp_st.core.deform.PointSamples`` when USD deforms the surface
        (time-sampled ``points`` or UsdSkel skinning, docs/spec.md §2.2; ``points`` is
        then its value at the start time code), else None.
    """

    prim_path: str
    points: np.ndarray
    triangles: np.ndarray
    material: Material = Material()
    normals: np.ndarray | None = None
    sphere: tuple[float, np.ndarray] | None = None
    quadric: tuple | None = None
    st: np.ndarray | None = None
    subset_materials: tuple[Material, ...] = ()
    triangle_material: np.ndarray | None = None
    samples: object = None


@dataclass(frozen=True, eq=False)
class Body:
    """A set of surfaces sharing one worldline (docs/spec.md §2).

    origin: world-space pivot o of the prim carrying ``SpacetimeBodyAPI``, (3,).
    velocity: lab velocity v = (x, y, z) / t of ``spacetime:fourVelocity``, (3,).
    lifetime: lab times (tBegin, tEnd); +-inf when unbounded.
    motion: a ``warp_st.core.motion.BodyMotion`` when USD animates the body (docs/spec.md
        §2.1; ``velocity`` is then only its held part), else None.
    spin: the lab velocity gradient W about the moving pivot, (3, 3), column vectors: the
        body point at x at lab time t moves with velocity + W (x - o - velocity (t -
        reference_time)) (an animated body's piece that turns, docs/spec.md §2.1); None: 0.
    piece_linear: for a piece of an animated body (``spacetime.animation.piece_bodies``),
        the linear part L its surfaces were moved by from the body's static ones (row
        vectors: piece points - origin = (static points - static pivot) L), (3, 3); the
        rigid path shares one bottom level among a body's pieces through it. Else None.
    seam: for such a piece, the largest distance between its surfaces and its neighbouring
        pieces' where they overlap in time (they model one surface): shadow rays leaving
        the piece ignore its object that near (``kernels/shade.py``). Else 0.
    rest_frame: its animation is its motion in its own rest frame S' (``spacetime:animationFrame
        = "rest"``, docs/spec.md §2.1): its points are lab positions (``decoupled`` for
        tracing), its proper time is t' of the event in S', gamma(v) ((t - t_ref) - v.(x - o)).
    clock: (times, tau), the proper time of a deforming body's every point at lab times
        ``times`` (its pivot's, linear between them: a coupled body turning on a moving
        pivot, ``spacetime.turning``), (M,) each; None: §2's (``velocity``, ``decoupled``).
    """

    prim_path: str
    surfaces: tuple[Surface, ...]
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference_time: float = 0.0
    lifetime: tuple[float, float] = (-np.inf, np.inf)
    decoupled: bool = False
    motion: object = None
    spin: object = None
    piece_linear: object = None
    seam: float = 0.0
    rest_frame: bool = False
    clock: object = None

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
    """A light at rest in the lab (UsdLux semantics: docs/spec.md §3, docs/design/usdlux.md).

    kind: "sphere" (a sphere of ``radius`` about ``position``; radius 0: a point),
        "distant" (from ``direction``), "rect" or "disk" (one-sided area lights centred
        on ``position``, emitting along -``direction``).
    direction: unit vector: a distant light's local +Z in the lab (towards it); an area
        light's surface normal on its local +Z side (its back: it emits along -direction).
    radiance: the linear-RGB scale a Lambert surface of albedo rho multiplies, such that
        it reflects rho * radiance * cos / d^2 from a sphere or point (radiance = I / pi,
        I the radiant intensity), rho * radiance * cos from a distant light (radiance =
        E / pi, E its irradiance at normal incidence), and rho * radiance * the
        integral of cos cos' / d^2 over an area light (radiance = L / pi, L its
        emitted radiance).
    radius: the emitting sphere's radius (shadow rays leave from its silhouette); 0 for
        a point (and for ``treatAsPoint``).
    axes: "rect"/"disk": the light's half-extent vectors along its local X and Y in
        the lab (a rect spans position + a u + b v for a, b in [-1, 1]; a disk has
        a^2 + b^2 <= 1).
    motion: the light's animated worldline (docs/spec.md §3.4, time-sampled xformOps), or
        None (at rest). ``position``, ``direction`` and ``axes`` are the light at the
        motion's static pivot ``motion.static_pivot`` (= ``position``); a light point p
        is at o(t) + (p - position) @ L(t), a direction d along d @ L(t).
    """

    kind: str
    radiance: tuple[float, float, float]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: tuple[float, float, float] = (0.0, 0.0, 1.0)
    prim_path: str = ""
    radius: float = 0.0
    axes: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    motion: BodyMotion | None = None

    @property
    def extent(self) -> float:
        """Radius of a ball about ``position`` that holds every point a shadow ray ends at
        (an animated light's at any time: its pivot's largest excursion added, and its own
        extent under the largest stretch of L(t))."""
        u, v = (float(np.linalg.norm(a)) for a in self.axes)
        own = {"sphere": self.radius, "rect": u + v, "disk": max(u, v)}.get(self.kind, 0.0)
        if self.motion is None or self.kind == "distant":
            return own
        m = self.motion
        away = np.linalg.norm(m.pivot - np.asarray(self.position, dtype=np.float64), axis=1)
        return float((away + own * np.linalg.norm(m.linear, ord=2, axis=(1, 2))).max())


@dataclass(frozen=True, eq=False)
class Dome:
    """A DomeLight: the sky, at rest in the lab at infinity (docs/spec.md §3, the sky).

    radiance: intensity * color * 2**exposure, linear RGB (the texels' multiplier).
    texels: the latlong map, (H, W, 4) float32 linear, OpenEXR's orientation (row 0
        latitude +pi/2, column 0 longitude +pi); None: a constant sky of ``radiance``.
    local_from_lab: (3, 3) rotation taking a lab direction into the dome's own axes.
    irradiance: (9, 3) spherical-harmonic coefficients of the diffuse irradiance it gives,
        lab axes (``core.sky_irradiance``); None: it lights nothing.
    """

    radiance: tuple[float, float, float]
    texels: np.ndarray | None = None
    local_from_lab: np.ndarray = field(default_factory=lambda: np.eye(3))
    prim_path: str = ""
    irradiance: np.ndarray | None = None


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
    dome: the sky (a DomeLight), None: the render settings' background.
    light_speed: c in stage units per time code, the lab time of one time code (docs/spec.md
        §3.1): every time on the scene (bodies, cameras) is lab time = light_speed x time code;
        ``light_speed_origin`` says where it came from (schema, settings, --light-speed, physical).
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
    dome: Dome | None = None
    light_speed: float = 1.0
    light_speed_origin: str = ""

    def body_paths(self) -> list[str]:
        return [b.prim_path for b in self.bodies]

    def header(self) -> dict[str, str]:
        """Stage metadata for every frame's EXR header (``spacetime:<key>``)."""
        items = {"metersPerUnit": self.meters_per_unit, "timeCodesPerSecond": self.time_codes_per_second,
                 "lightSpeedUnitsPerTimeCode": self.light_speed}
        header = {key: repr(float(value)) for key, value in items.items() if value is not None}
        if self.light_speed_origin:
            header["lightSpeedOrigin"] = self.light_speed_origin
        return header


def surface_keep(surf) -> np.ndarray:
    """(T,) bool: the surface's triangles that are not degenerate index triples."""
    tris = np.asarray(surf.triangles, dtype=np.int64).reshape(-1, 3)
    return (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])


def surface_triangles(surf) -> np.ndarray:
    """A surface's triangles as (T, 3) int64, without degenerate index triples (no surface)."""
    return np.asarray(surf.triangles, dtype=np.int64).reshape(-1, 3)[surface_keep(surf)]
