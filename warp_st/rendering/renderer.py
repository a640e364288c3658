"""Orchestrates rendering: options, the 4D database (built once per scene), per-frame launches.

``Renderer(scene, frames=[...])`` resolves the options, clips every body to the time
window the frames can see, extrudes, builds the BVH and uploads the static arrays once,
or takes all of that from the scene's cache (``database_cache``: a second renderer of the
same scene, options and frames builds nothing);
``render(frame)`` recentres on that frame's camera event, launches the megakernel over
row tiles from a thread pool (Warp runs a CPU launch serially and releases the GIL,
so the tiles use every core) and returns a :class:`~warp_st.output.film.Image`.
"""
from __future__ import annotations

import collections
import dataclasses
import functools
import math
import os
import time
from dataclasses import dataclass

import numpy as np

from warp_st.core.conventions import DEFAULT_RESOLUTION, LightSpeed, Precision
from warp_st.core.limits import resolve_max_memory
from warp_st.core.scene import CameraState, Scene, SceneError
from warp_st.core.thread_pool import each_on_threads
from warp_st.kernels.layout import PRIMITIVES
from warp_st.output.cryptomatte import image_layers, resolve_layers
from warp_st.output.film import Image
from warp_st.rendering import database_cache, frame_inputs
from warp_st.rendering.budget import BYTES_PER_PIXEL, MemoryRefusal, check_limits, check_resources, estimate_bytes
from warp_st.rendering.database_build import build_database
from warp_st.rendering.film_planes import copy_film, film_into, finish_in_place
from warp_st.rendering.frame_inputs import camera_key, lens_key
from warp_st.rendering.launches import tile_launches
from warp_st.rendering.warp_init import init_warp
from warp_st.spacetime.adaptive import retessellated, sphere_tessellation
from warp_st.spacetime.animation import animated_bodies, animation_cuts, piece_count
from warp_st.spacetime.deform import deform_primitive, deforming, slice_view
from warp_st.spacetime.reach import motion_reach
from warp_st.spacetime.rigid import all_exact_quadrics, quadric_body
from warp_st.spacetime.visibility import union, visibility_windows

__all__ = ["Renderer", "build_database", "RenderStats", "DEFAULT_RESOLUTION", "PRIMITIVES",
           "TILE_PIXELS", "init_warp"]


#: Mirror reflections followed when nothing asks otherwise (issue: light transport).
DEFAULT_MAX_DEPTH = 4
#: Pixels per kernel launch; small enough to balance two cores (rows differ in cost:
#: the parade's floor tiles take ten times its sky tiles), large enough that launch
#: overhead (~9 us) is negligible. 4,096 against 8,192, five alternations (README,
#: Performance): the aberration scene's 1 -> 2 core speed-up 1.64-1.86x (median
#: 1.79x) against 1.67-1.74x.
TILE_PIXELS = 4096


@dataclass
class RenderStats:
    tetrahedra: int = 0  # the database's size in tetrahedra (3 per prism), either primitive
    primitives: int = 0  # what the BVH indexes: prisms or tetrahedra
    bvh_nodes: int = 0
    bvh_depth: int = 0
    extrude_seconds: float = 0.0
    bvh_seconds: float = 0.0
    upload_seconds: float = 0.0
    compile_seconds: float = 0.0
    last_frame_seconds: float = 0.0
    last_kernel_seconds: float = 0.0
    last_mean_visits: float = 0.0
    rays: int = 0
    triangles: int = 0  # rigid: the bottom levels' triangles
    segments: int = 0  # rigid: the top level's motion segments
    database_built: bool = False  # False: the scene's cached database served (database_cache)


@dataclass
class _BuildStats:
    """How long the steps of a cached database's build took."""

    extrude_seconds: float
    bvh_seconds: float


def _non_negative(value, what: str, source: str):
    if value is None:
        return None
    try:
        fvalue = float(value)
    except (TypeError, ValueError):
        raise SceneError.at(source, None, what, f"must be a number, got {value!r}") from None
    if not math.isfinite(fvalue) or fvalue < 0.0:
        raise SceneError.at(source, None, what, f"must be finite and >= 0, got {value!r}")
    return fvalue


def _positive_int(value, what: str, source: str, minimum: int = 1):
    if value is None:
        return None
    try:
        ivalue = int(value)
    except (TypeError, ValueError):
        raise SceneError.at(source, None, what, f"must be an integer, got {value!r}") from None
    if ivalue != value or ivalue < minimum:
        raise SceneError.at(source, None, what, f"must be an integer >= {minimum}, got {value!r}")
    return ivalue


class Renderer:
    """Renders frames of one scene from one static 4D database.

    frames: the USD time codes that will be rendered (the database covers exactly
        what their past lightcones can reach); default: the stage's start frame or 0.
    Keyword options override the stage's render settings; None keeps them.
    primitive: "rigid" (the default in float32: each body's shape at rest traced once
        in its comoving coordinates, a 4D top level over its motion segments), "prism"
        (the default in float64: one comoving triangle test per extruded prism) or
        "tet" (three tetrahedra per prism, the general path); all give the same images
        to float32 rounding. Deforming bodies are tetrahedra on the rigid path too (its
        second leaf kind, spacetime/mixed.py); in float64 their scenes default to "tet".
        A turning body traced as per-vertex worldlines by default (spacetime/turning.py) is
        cut into pieces of uniform motion instead when "rigid" or "prism" is asked for
        explicitly, or quadrics="exact".
    quadrics: "exact" (the default on the rigid path: a body whose one surface is a
        UsdGeom.Sphere is traced as its exact ellipsoid, spacetime/rigid.py) or
        "tessellated" (every sphere as triangles within half a pixel; the only choice on
        the prism and tet paths). In float64 the rigid path is the default, and allowed,
        only when every body is an exact quadric (its meshes would be traced in float32).
    cryptomatte: the Cryptomatte layers to compute (True: all; docs/spec.md §4.4), kept
        in the Image's ``extra`` with their manifests in ``Image.cryptomatte``; None:
        those the stage's render products name.

    Two options exist to measure the database's rules (examples/benchmarks), not to
    render: the default None keeps the renderer's own rules.
    sweep_fraction: time segments in which each body sweeps this fraction of its own
        size (prism and tet databases), instead of the default rule (``extrude.segment_sweep``, with the coarser
        fallback when memory is short).
    adjust_windows: ``adjust_windows(scene, windows) -> windows``, called with the
        per-body visibility windows of the (re-tessellated) scene; the memory check and
        the extrusion use what it returns. A window cut short loses what the frames see.
    A renderer given either builds a database of its own, never shared through the
    scene's cache.
    """

    #: A float32 render's kernel writes the Image's planes itself (``film_planes.film_into``);
    #: False copies them out of a film of its own instead, as float64 renders do (the
    #: tests' twin of the kernel's time codes).
    _film_into = True

    def __init__(
        self,
        scene: Scene,
        *,
        frames=None,
        camera: str | None = None,
        width: int | None = None,
        height: int | None = None,
        max_depth: int | None = None,
        samples: int | None = None,
        shutter: float | None = None,
        doppler_color: bool | None = None,
        searchlight: bool | None = None,
        precision: str | None = None,
        light_speed: str | None = None,
        threads: int | None = None,
        max_memory: int | str | None = None,
        primitive: str | None = None,
        quadrics: str | None = None,
        cryptomatte: bool | str | tuple | None = None,
        sweep_fraction: float | None = None,
        adjust_windows=None,
    ):
        src = scene.source
        if sweep_fraction is not None and not (math.isfinite(sweep_fraction) and sweep_fraction > 0.0):
            raise ValueError(f"sweep_fraction must be finite and > 0, got {sweep_fraction!r}")
        self.sweep_fraction = sweep_fraction
        self.adjust_windows = adjust_windows
        if primitive is not None and primitive not in PRIMITIVES:
            raise SceneError.at(src, None, "primitive", f"must be one of {', '.join(PRIMITIVES)}, got {primitive!r}")
        self.scene = scene
        self.max_memory = resolve_max_memory(max_memory, src)  # bytes; None = no limit known
        try:
            precision = Precision(precision) if precision is not None else None
        except ValueError:
            raise SceneError.at(src, None, "precision", f"must be float32 or float64, got {precision!r}") from None
        try:
            self.light_speed = LightSpeed(light_speed) if light_speed is not None else None
        except ValueError:
            raise SceneError.at(src, None, "lightSpeed", f"must be finite or infinite, got {light_speed!r}") from None
        settings = scene.settings.merged(
            camera=camera,
            max_depth=_positive_int(max_depth, "maxDepth", src, 0),
            samples=_positive_int(samples, "samples", src),
            shutter=_non_negative(shutter, "shutter", src),
            doppler_color=None if doppler_color is None else bool(doppler_color),
            searchlight=None if searchlight is None else bool(searchlight),
            precision=precision,
        )
        self.settings = settings
        self.max_depth = DEFAULT_MAX_DEPTH if settings.max_depth is None else int(settings.max_depth)
        self.samples = 1 if settings.samples is None else int(settings.samples)
        self.shutter = 0.0 if settings.shutter is None else float(settings.shutter)
        self.doppler_color = bool(settings.doppler_color)
        self.searchlight = bool(settings.searchlight)
        self.precision = Precision(settings.precision or Precision.FLOAT32)
        # The rigid path's bottom-level queries are float32: in float64 it serves only scenes
        # whose every body is an exact quadric (then it is exact in float64).
        all_exact = quadrics != "tessellated" and all_exact_quadrics(scene)
        # Turning bodies become per-vertex worldlines (spacetime/turning.py) unless the pieces'
        # path is asked for (primitive "rigid" or "prism") or exact quadrics; deforming bodies
        # are tetrahedra, as rigid-path leaves in float32 (docs/spec.md §2.1, §2.2).
        self._worldlines = quadrics != "exact" and primitive in (None, "tet")
        primitive = deform_primitive(scene, primitive, self.precision == Precision.FLOAT32, worldlines=self._worldlines)
        if primitive is None:
            primitive = "rigid" if self.precision == Precision.FLOAT32 or all_exact else "prism"
        if primitive == "rigid" and self.precision != Precision.FLOAT32 and not all_exact:
            raise SceneError.at(src, None, "primitive", "rigid traces meshes in float32: in float64 only "
                                                        "scenes of exact quadrics; use prism or tet")
        if primitive == "rigid" and sweep_fraction is not None:
            raise ValueError("sweep_fraction sets the extrusion's time segments; the rigid path has none "
                             "(use primitive='prism' or 'tet')")
        self.primitive = primitive
        if quadrics not in (None, "exact", "tessellated"):
            raise SceneError.at(src, None, "quadrics", f"must be exact or tessellated, got {quadrics!r}")
        if quadrics == "exact" and primitive != "rigid":
            raise SceneError.at(src, None, "quadrics", "exact quadrics are traced on the rigid path only (float32, "
                                                       "or float64 for scenes of nothing else); use "
                                                       "quadrics='tessellated'")
        self.exact_quadrics = quadrics != "tessellated" and primitive == "rigid"
        try:  # Cryptomatte layers (docs/spec.md §4.4); None: those the stage's products name
            self.cryptomatte = resolve_layers(cryptomatte, scene.products)
        except (TypeError, ValueError) as exc:
            raise SceneError.at(src, None, "cryptomatte", str(exc)) from None
        width = _positive_int(width, "width", src)
        height = _positive_int(height, "height", src)
        res = settings.resolution or DEFAULT_RESOLUTION
        if width is None and height is None:
            width, height = res
        elif height is None:
            height = max(1, round(width * res[1] / res[0]))
        elif width is None:
            width = max(1, round(height * res[0] / res[1]))
        self.width, self.height = int(width), int(height)
        self.camera_path = settings.camera or scene.default_camera
        if self.camera_path is None:
            raise SceneError.at(src, None, None, "the stage has no camera (add a UsdGeom.Camera)")
        if frames is None:
            frames = [scene.frame_range[0] if scene.frame_range else 0.0]
        self.frames = [self._frame_value(f) for f in frames]
        self.threads = max(1, int(threads or os.cpu_count() or 1))
        self.stats = RenderStats()
        self._cameras = {f: self._camera(f) for f in self.frames}
        self._lens_uses = None  # lens_key -> planned frames with it (render), made on first use
        self._build(list(self._cameras.values()))

    # -- setup ---------------------------------------------------------------

    def _frame_value(self, frame) -> float:
        try:
            value = float(frame)
        except (TypeError, ValueError):
            raise SceneError.at(self.scene.source, None, "frame", f"must be a number, got {frame!r}") from None
        if not math.isfinite(value):
            raise SceneError.at(self.scene.source, None, "frame", f"must be finite, got {frame!r}")
        return value

    def _camera(self, frame: float) -> CameraState:
        return self.scene.camera_state(self.camera_path, frame)

    @property
    def _lab_shutter(self) -> float:
        """The shutter (time codes) in lab time (docs/spec.md §3.1)."""
        return self.shutter * self.scene.light_speed

    def _frame_light_speed(self, cam: CameraState) -> LightSpeed:
        return self.light_speed or LightSpeed(cam.light_speed)

    def _build(self, cams: list[CameraState]) -> None:
        """The database for cameras ``cams``: the scene's cached one when it covers them
        (``database_cache``), else built now and cached on the scene."""
        from warp_st.kernels import get_kernels
        from warp_st.kernels.traverse import stack_for
        from warp_st.rendering.device import StaticArrays
        from warp_st.rendering.device_mixed import rigid_arrays

        wp = init_warp()
        t0 = time.perf_counter()
        modes = {self._frame_light_speed(c) for c in cams}
        # The shutter moves each camera event along its worldline by up to `shutter`.
        shutter = self._lab_shutter if self.samples > 1 else 0.0
        ends = cams + [c.advanced(shutter) for c in cams if shutter > 0.0]
        cache = database_cache.for_scene(self.scene)
        scene = self.scene
        # Animated bodies (docs/spec.md §2.1): pieces of uniform motion within half a pixel in every frame.
        # Only the chunks of their motion some frame can reach (spacetime/reach.py) are cut.
        reach = functools.partial(motion_reach, cameras=cams, infinite_modes=[m == LightSpeed.INFINITE for m in modes],
                                  max_depth=self.max_depth, shutter=shutter)
        self.animation = animation_cuts(self.scene, ends, width=self.width, height=self.height, reach=reach,
                                        worldlines=self._worldlines)  # turning bodies: spacetime/turning.py
        self.object_of = None  # the scene body of each rendered body (None: the same)
        if self.animation:  # the cache holds the bodies only: an entry must not keep its scene alive
            bodies, self.object_of = cache.tessellated(("animation", self.animation),
                                                       lambda: animated_bodies(self.scene, self.animation))
            scene = dataclasses.replace(self.scene, bodies=bodies)
        # UsdGeom.Spheres: the cheapest tessellation within half a pixel in every frame.
        # Spheres traced exactly keep the reader's tessellation (their shading tables only).
        self.sphere_segments = sphere_tessellation(
            scene, ends, width=self.width, height=self.height,
            modes=sorted(m == LightSpeed.INFINITE for m in modes), max_depth=self.max_depth)
        exact = {s.prim_path for b in scene.bodies if quadric_body(b, self.exact_quadrics) for s in b.surfaces}
        self.sphere_segments = {k: v for k, v in self.sphere_segments.items() if k not in exact}
        tessellation = tuple(sorted(self.sphere_segments.items())) + ((("animation", self.animation),)
                                                                       if self.animation else ())
        if self.sphere_segments:
            pieces = scene
            bodies = cache.tessellated(tessellation, lambda: retessellated(pieces, self.sphere_segments).bodies)
            scene = dataclasses.replace(self.scene, bodies=bodies)
        # Deforming bodies (docs/spec.md §2.2): slices within half a pixel in every frame.
        self.slice_view = (slice_view(ends, width=self.width, height=self.height)
                           if any(deforming(b) for b in scene.bodies) else None)
        tessellation += (("deform", self.slice_view),) if self.slice_view is not None else ()
        # The measuring options build a database of their own, neither looked up nor cached.
        measuring = self.sweep_fraction is not None or self.adjust_windows is not None
        if measuring:
            windows = self._windows(scene, cams, modes, shutter)
            if self.adjust_windows is not None:
                windows = list(self.adjust_windows(scene, windows))
        else:
            windows = cache.windows((tessellation, tuple(sorted(m.value for m in modes)), self.max_depth, shutter,
                                     tuple((c.time, *np.asarray(c.position).tolist(), *np.asarray(c.velocity).tolist())
                                           for c in cams)),
                                    lambda: self._windows(scene, cams, modes, shutter))
        check_limits(scene, windows, width=self.width, height=self.height, samples=self.samples,
                     max_depth=self.max_depth)
        pixels = self.width * self.height
        if self.exact_quadrics:  # the shapes and databases of exact quadrics are cached apart
            tessellation += (("quadrics", "exact"),)
        db = None if measuring else next(
            (d for d in cache.candidates(tessellation, self.primitive, windows)
             if self.max_memory is None or d.nbytes + pixels * BYTES_PER_PIXEL <= self.max_memory), None)
        self.stats.database_built = db is None
        if db is None:
            if self.primitive == "rigid":
                db = self._new_rigid_database(scene, windows, tessellation, cache, t0)
            else:
                db = self._new_database(scene, windows, tessellation, t0)
            if not measuring:
                cache.add(db)
        else:
            cache.use(db)
        tc = time.perf_counter()
        # The rigid top level's traversal stack fits its tree (the full one zeroes 768 bytes a ray).
        self.kernels = get_kernels(self.precision.value, self.primitive, db.tets is not None, stack_for(db.bvh.depth))
        wp.load_module(self.kernels.pixels(bool(self.scene.lights)).module, device="cpu")
        self.stats.compile_seconds = time.perf_counter() - tc
        t3 = time.perf_counter()
        if self.precision.value not in db.static:
            db.static[self.precision.value] = (
                rigid_arrays(self.kernels, db) if self.primitive == "rigid"
                else StaticArrays(self.kernels, db.mesh, db.bvh))
        self.database = db
        self.static = db.static[self.precision.value]
        self.mesh, self.bvh, self.segments = db.mesh, db.bvh, db.segments
        self.memory_estimate = db.nbytes + pixels * BYTES_PER_PIXEL
        self.fine_segments = db.fine
        s = self.stats
        s.tetrahedra = db.mesh.tet_count if db.mesh is not None else db.tets[0].tet_count if db.tets else 0
        s.primitives = db.mesh.prim_count if db.mesh is not None else db.segments.count
        s.triangles = db.shapes.triangle_count if db.shapes is not None else 0
        s.segments = db.segments.count if db.segments is not None else 0
        s.bvh_nodes = db.bvh.node_count_total
        s.bvh_depth = db.bvh.depth
        s.extrude_seconds = db.stats.extrude_seconds
        s.bvh_seconds = db.stats.bvh_seconds
        s.upload_seconds = time.perf_counter() - t3

    def _windows(self, scene: Scene, cams: list[CameraState], modes, shutter: float) -> list:
        """Per body, the lab times the cameras can see: the union over the light-speed modes."""
        windows = None
        for mode in modes:
            w = visibility_windows(scene, cams, infinite=mode == LightSpeed.INFINITE, max_depth=self.max_depth,
                                   shutter=shutter)
            windows = w if windows is None else [union(a, b) for a, b in zip(windows, w)]
        return windows

    def _new_database(self, scene: Scene, windows: list, tessellation: tuple, t0: float):
        """Extrude and build over ``windows`` (refusing before allocating what would not fit)."""
        # The tetrahedron count is known from the windows. Time segments follow finely
        # tessellated bodies' triangles unless that does not fit; then they fall back to
        # the coarser rule (faster to build, slower to trace).
        limits = dict(width=self.width, height=self.height, samples=self.samples, max_depth=self.max_depth,
                      max_memory=self.max_memory, fraction=self.sweep_fraction, view=self.slice_view)
        try:
            check_resources(scene, windows, **limits)
            fine = True
        except MemoryRefusal:
            check_resources(scene, windows, fine=False, **limits)
            fine = False
        mesh, bvh = build_database(scene, windows, self.primitive, fine=fine,
                                   fraction=self.sweep_fraction, view=self.slice_view)
        t2 = time.perf_counter()
        built = _BuildStats(extrude_seconds=t2 - bvh.build_seconds - t0, bvh_seconds=bvh.build_seconds)
        return database_cache.Database(tessellation=tessellation, primitive=self.primitive, fine=fine,
                                       windows=windows, mesh=mesh, bvh=bvh, stats=built,
                                       nbytes=estimate_bytes(mesh.tet_count, len(mesh.vertices)))

    def _new_rigid_database(self, scene: Scene, windows: list, tessellation: tuple, cache, t0: float):
        """The rigid database over ``windows``: the tessellation's shapes and bottom levels
        (cached on the scene apart, built on first use) under a new top level."""
        from warp_st.accel.instances import build_top_level, shapes_and_bottom_levels
        from warp_st.rendering.database_mixed import shapes_key, tet_leaves
        from warp_st.spacetime.mixed import has_deforming, rigid_part
        from warp_st.spacetime.rigid import motion_segments

        mixed = has_deforming(scene)  # deforming bodies: tetrahedra as leaves beside the instances
        rigid = rigid_part(scene) if mixed else scene

        def shapes_and_bottom():  # the shapes' tables in the bottom levels' leaf order
            return shapes_and_bottom_levels(tuple(rigid.bodies), self.exact_quadrics)

        limits = dict(width=self.width, height=self.height, samples=self.samples, max_depth=self.max_depth,
                      max_memory=self.max_memory)
        nbytes = check_resources(rigid, windows, rigid=True, **limits) - self.width * self.height * BYTES_PER_PIXEL
        shapes, bottom = cache.shapes(shapes_key(tessellation), shapes_and_bottom)
        segments = motion_segments(rigid, shapes, windows)
        tets = None
        if mixed:
            tets, shapes, segments, tet_bytes = tet_leaves(scene, windows, shapes, segments, view=self.slice_view,
                                                           rigid_bytes=nbytes, **limits)
            nbytes += tet_bytes
        top = build_top_level(segments)
        built = _BuildStats(extrude_seconds=time.perf_counter() - t0 - top.build_seconds,
                            bvh_seconds=top.build_seconds)
        return database_cache.Database(tessellation=tessellation, primitive="rigid", fine=True, windows=windows,
                                       bvh=top, segments=segments, shapes=shapes, bottom=bottom, stats=built,
                                       nbytes=nbytes, tets=tets)

    def describe(self) -> dict:
        s = self.stats
        return {
            "tetrahedra": s.tetrahedra,
            "primitive": self.primitive,
            "triangles": s.triangles,
            "motion_segments": s.segments,
            "animated_segments": sum(piece_count(cuts) for _, cuts in self.animation),  # of the chunks reached
            "time_segments": ("motion segments (rigid)" if self.primitive == "rigid"
                              else f"sweep {self.sweep_fraction:g} x body size" if self.sweep_fraction is not None
                              else "per triangle" if self.fine_segments else "per body (memory)"),
            "bvh_nodes": s.bvh_nodes,
            "extrude_seconds": round(s.extrude_seconds, 4),
            "bvh_seconds": round(s.bvh_seconds, 4),
            "compile_seconds": round(s.compile_seconds, 4),
            "width": self.width,
            "height": self.height,
            "precision": self.precision.value,
            "quadrics": "exact" if self.exact_quadrics else "tessellated",
            "camera": self.camera_path,
            "max_depth": self.max_depth,
            "samples": self.samples,
            "shutter": self.shutter,
            "doppler_color": self.doppler_color,
            "searchlight": self.searchlight,
        }

    # -- per frame -------------------------------------------------------------

    def render(self, frame=None, *, threads: int | None = None) -> Image:
        """Render one frame (a USD time code) to an :class:`Image`."""
        from warp_st.rendering.anchor import anchor_step, geometry_anchor
        from warp_st.rendering.camera import camera_rays, make_camera
        from warp_st.rendering.device import make_geometry, make_shading
        from warp_st.rendering.device_rigid import make_rigid_geometry

        wp = init_warp()
        frame = self.frames[0] if frame is None else self._frame_value(frame)
        if frame not in self._cameras:
            # A frame outside the prepared set: widen the database to cover it.
            self._cameras[frame] = self._camera(frame)
            self._lens_uses = None
            self.frames.append(frame)
            self._build(list(self._cameras.values()))
        cam = self._cameras[frame]
        t_start = time.perf_counter()
        k = self.kernels
        event = np.array([cam.time, *cam.position], dtype=np.float64)
        # the database recentred on a grid point near the camera event (rendering/anchor.py)
        origin = geometry_anchor(event, anchor_step(self.bvh.node_lo[0], self.bvh.node_hi[0]))
        if self.primitive == "rigid":
            def make():
                return make_rigid_geometry(k, self.static, self.segments, self.bvh, origin)
        else:
            def make():
                return make_geometry(k, self.static, self.mesh, self.bvh, origin)
        geo = self.database.geometry_for(self.precision.value, tuple(origin.tolist()), make)
        background = self.settings.background or (0.0, 0.0, 0.0)
        light_speed = self._frame_light_speed(cam)
        n_threads = max(1, int(threads or self.threads))

        def make_structs():
            return (make_shading(k, self.static, self.scene.lights, origin, background, self.max_depth,
                                 doppler_color=self.doppler_color, searchlight=self.searchlight, dome=self.scene.dome,
                                 camera_event=event),
                    make_camera(k, cam, self.width, self.height, light_speed, samples=self.samples,
                                shutter=self._lab_shutter, origin=event - origin))

        key = (self.precision.value, camera_key(cam), self.width, self.height, light_speed.value, self.samples,
               self._lab_shutter, tuple(float(x) for x in background), self.max_depth, self.doppler_color,
               self.searchlight, tuple(origin.tolist()))
        shd, kcam = frame_inputs.structs(self.database, key, make_structs)
        if kcam.dirs.shape[0] == 0:  # the pixel centres' directions: a table once the lens is seen again
            lens = lens_key(self.precision.value, cam, self.width, self.height)
            if self._lens_uses is None:  # how many planned frames have each lens
                self._lens_uses = collections.Counter(lens_key(self.precision.value, c, self.width, self.height)
                                                      for c in self._cameras.values())
            # A lens another planned frame shares gets its table at its first frame.
            table = frame_inputs.directions(self.database, lens, lambda: camera_rays(k, kcam, n_threads),
                                            planned=self._lens_uses[lens] > 1)
            if table is not None:
                kcam.dirs = table
        n_pix = self.width * self.height
        frame_inputs.keep_only(database_cache.for_scene(self.scene).databases, self.database)
        # A float32 kernel writes the Image's planes itself (film_planes.film_into); a float64
        # one its own film's, copied out after (copy_film).
        into_image = self.precision == Precision.FLOAT32 and self._film_into
        film_key, film = frame_inputs.take_film(self.database, k, n_pix, n_pix * self.samples if self.cryptomatte else 0,
                                                into_image)
        per_code = float(self.scene.light_speed)  # the kernels' times are lab times, the Image's time codes (§3.1)
        out = frame_inputs.image_planes(self.database, self.height, self.width)
        if into_image:
            film_into(k, film, out, origin=float(cam.time) / per_code, per_code=per_code)
        tiles = [(o, min(TILE_PIXELS, n_pix - o)) for o in range(0, n_pix, TILE_PIXELS)]

        kernel = k.pixels(bool(self.scene.lights))  # without lights: the kernel that casts no shadow rays

        launch = tile_launches(wp, kernel, [geo, shd, kcam, film], kept=self.database.launches)

        t_kernel = time.perf_counter()
        each_on_threads(launch, tiles, n_threads)
        kernel_seconds = time.perf_counter() - t_kernel
        if film.overflow.numpy()[0]:
            raise RuntimeError("BVH traversal stack overflow: the image would be wrong (please report)")
        image = self._image(film, out, into_image, cam, frame, n_threads)
        self.stats.last_mean_visits = frame_inputs.film_visits(film, n_pix)
        frame_inputs.give_back(self.database, film_key, film)
        self.stats.last_kernel_seconds = kernel_seconds
        self.stats.last_frame_seconds = time.perf_counter() - t_start
        self.stats.rays = n_pix
        return image

    def _image(self, film, out: dict, into_image: bool, cam: CameraState, frame: float, threads: int = 1) -> Image:
        """The Image of planes ``out`` (``frame_inputs.image_planes``): written by the kernel
        (``into_image``) and finished in place, else copied out of ``film`` (reused by the next
        render)."""
        h, w = self.height, self.width
        per_code = float(self.scene.light_speed)
        origin = float(cam.time) / per_code
        if into_image:
            finish_in_place(out, per_code=per_code, object_of=self.object_of)
            lows = {}
        else:
            lows = copy_film(film, out, h, w, origin=origin, per_code=per_code,
                             float64=self.precision == Precision.FLOAT64, object_of=self.object_of, threads=threads)
        paths = self.scene.body_paths()
        tables = self.database.shapes if self.primitive == "rigid" else self.mesh
        crypto_planes, layers = image_layers(
            film.sample_id.numpy().reshape(h, w, self.samples), self.cryptomatte, tables.tri_body, paths,
            tables.tri_material, [m.prim_path for m in tables.materials]) if self.cryptomatte else ({}, {})
        return Image(
            **out,
            camera_time=origin,
            time_origin=origin,
            frame=frame,
            precision=self.precision.value,
            id_manifest={i + 1: path for i, path in enumerate(paths)},
            extra={**crypto_planes, **lows},
            cryptomatte=layers,
            metadata={
                "stage": str(self.scene.source),
                "camera": str(self.camera_path),
                "lightSpeed": self._frame_light_speed(cam).value,
                "coverage": f"{frame_inputs.film_covered(film)}/{out['object_id'].size}",
                "maxDepth": str(self.max_depth),
                "samples": str(self.samples),
                "shutter": repr(self.shutter),
                "dopplerColor": str(self.doppler_color).lower(),
                "searchlight": str(self.searchlight).lower(),
                **self.scene.header(),  # metersPerUnit, timeCodesPerSecond
            },
        )
