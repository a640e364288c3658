#!/usr/bin/env python3
"""Issue 17's ratio table: warm and first renders against Warp's wp.Mesh on the same rays.

A benchmark, not a test: it asserts nothing. Every ratio is measured in one run, the two
sides timed back to back in each repetition; a row's ratio is the median of the
repetitions' ratios (``paired``, ``--runs`` of them), so the machine's drift between
repetitions cancels, and its times are the medians of each side; the CPU model heads the
table.

- static:  warm ``warp_st.render`` (the public call, everything included: options,
  database look-up, launch, film read-back) of 16 static spheres (128 longitudes,
  ~254k triangles), unlit, against ``wp.mesh_query_ray`` closest hits of the same
  primary rays over one ``wp.Mesh`` of all triangles (ratio = wp.Mesh time / ours,
  >= 1 means ours is faster);
- trace:   closest hits only (the ``cast_rays`` probe through the two levels, no
  shading or film) against ``wp.Mesh`` and Embree (``embreex``, ``pip install -e '.[bench]'``;
  skipped with a line when absent) on the same rays (ratio = their time / ours);
- shipped: closest hits only on static copies of shipped stages (the parade, the coupled
  flanges, the aberration and sphere-and-cubes stages; every body at rest, spheres as
  their triangles) against wp.Mesh and Embree over the same triangles and camera rays;
- parade:  the shipped parade rendered in full (frame 0, 640 x 360, lit, warm) in
  Mrays/s on 1 and 2 threads, default and prism paths;
- motion:  the same render with the spheres moving at 0.3-0.9c against at rest
  (ratio = moving time / resting time);
- first:   the first render of a new 1.03M-triangle static scene (kernels cached)
  against ``wp.Mesh`` and Embree build + query (ratio = ours / theirs, <= 2 is the goal),
  and the builds alone per million triangles: our database (bottom levels, top level,
  shading tables) against ``wp.Mesh`` and Embree over the same triangles;
- distinct: the same first render with each sphere a shape of its own (16 bottom levels
  to build instead of 2, as in a stage without instancing);
- cubes:   warm render of 1,000 cubes moving at up to 0.95c (a third decoupled), lit by
  one distant light (shadow rays), against the same cubes at rest;
- sequence: frames 0 and 10,000 of the moving spheres from one renderer (first
  construction and both frames), per frame, against one warm frame.

    python3 examples/benchmarks/bench_two_level.py               # 512 x 512, 5 runs
    python3 examples/benchmarks/bench_two_level.py --runs 7 --tables static,motion
    python3 examples/benchmarks/bench_two_level.py --tables trace --clock cpu   # a shared machine
    python3 examples/benchmarks/bench_two_level.py --tables shipped --stages all  # every shipped stage
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
for _path in (ROOT, Path(__file__).resolve().parent):  # warp_st from this checkout; benchlib
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from benchlib.machine import cpu_model  # noqa: E402

TABLES = ("static", "trace", "shipped", "parade", "motion", "first", "distinct", "cubes", "sequence")
#: The clock of the ray queries' timings (``MeshQueries.run``): wall time, or with
#: ``--clock cpu`` the process's CPU time, which other jobs on a shared machine change far
#: less (it sums both threads' on 2 threads: a cost, not a latency).
CLOCK = [time.perf_counter]
#: (speed, direction) of the moving spheres, cycled: 0.3c to 0.9c along the image axes.
MOTIONS = ((0.3, (1, 0, 0)), (0.5, (0, 1, 0)), (0.7, (-1, 0, 0)), (0.9, (1, 1, 0)))


def spheres_scene(segments: int, *, moving: bool):
    """16 spheres of radius 1 on a 4 x 4 grid at z = -12 in front of a camera at the
    origin (t_c = 0) looking down -Z; each body's reference time puts its centre on
    the camera's past lightcone at its grid position."""
    from warp_st.core import tessellate
    from warp_st.core.scene import Body, CameraState, Material, RenderSettings, Scene, Surface

    cam = CameraState("/Camera", 0.0, np.zeros(3), np.eye(3), focal_length=27.0, horizontal_aperture=36.0,
                      vertical_aperture=36.0)
    pts, tris, nrm = tessellate.sphere(1.0, segments)
    bodies = []
    for i in range(16):
        centre = np.array([(i % 4 - 1.5) * 3.0, (i // 4 - 1.5) * 3.0, -12.0])
        speed, direction = MOTIONS[i % len(MOTIONS)] if moving else (0.0, (1, 0, 0))
        v = speed * np.asarray(direction, float) / np.linalg.norm(direction)
        path = f"/Spheres/S{i}"
        surf = Surface(path, pts + centre, tris, Material(diffuse=(0.2 + 0.05 * i, 0.5, 0.7)), nrm)
        bodies.append(Body(path, (surf,), centre, v, -float(np.linalg.norm(centre)), (-math.inf, math.inf)))
    return Scene(source="<bench:spheres>", bodies=tuple(bodies), lights=(), cameras=(cam.prim_path,),
                 settings=RenderSettings(), default_camera=cam.prim_path,
                 camera_state=lambda path, frame: dataclasses.replace(cam, time=float(frame)))


def cubes_scene(count: int, *, moving: bool, seed: int = 1):
    """``count`` unit cubes on a jittered grid in front of the camera, random velocities
    up to 0.95c (one third Lorentz decoupled) unless at rest, one distant light."""
    from warp_st.core import tessellate
    from warp_st.core.scene import Body, Light, Material, Surface

    rng = np.random.default_rng(seed)
    base = spheres_scene(8, moving=False)
    pts, tris = tessellate.cube(0.8)
    side = round(count ** (1.0 / 3.0))
    bodies = []
    for i in range(count):
        centre = np.array([(i % side - (side - 1) / 2) * 3.2, (i // side % side - (side - 1) / 2) * 1.8,
                           -14.0 - 2.0 * (i // side // side)]) + rng.uniform(-0.3, 0.3, 3)
        d = rng.normal(size=3)
        v = rng.uniform(0.1, 0.95) * d / np.linalg.norm(d) if moving else np.zeros(3)
        path = f"/Cubes/C{i}"
        surf = Surface(path, pts + centre, tris, Material(diffuse=tuple(rng.uniform(0.2, 0.9, 3))))
        bodies.append(Body(path, (surf,), centre, v, -float(np.linalg.norm(centre)), (-math.inf, math.inf),
                           bool(moving and i % 3 == 0)))
    sun = Light("distant", (1.0, 1.0, 1.0), direction=(0.29, 0.78, 0.49), prim_path="/Sun")
    return dataclasses.replace(base, source="<bench:cubes>", bodies=tuple(bodies), lights=(sun,))


def pixel_directions(scene, width, height, frame=0.0):
    """The renderer's primary ray directions (docs/spec.md §3 pinhole) at ``frame``, float32 (N, 3)."""
    cam = scene.camera_state(scene.default_camera, frame)
    i = np.arange(width) + 0.5
    j = np.arange(height) + 0.5
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    X, Y = np.meshgrid((2.0 * i / width - 1.0) * h_ap / 2 / cam.focal_length,
                       (1.0 - 2.0 * j / height) * v_ap / 2 / cam.focal_length)
    d = np.stack([X, Y, -np.ones_like(X)], axis=-1).reshape(-1, 3) @ np.asarray(cam.rotation).T
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


class MeshQueries:
    """wp.Mesh over every triangle of a static scene and closest-hit queries of rays from
    the camera (at ``origin``, the world origin by default), launched in the renderer's
    tiles on 1 or 2 threads."""

    def __init__(self, scene, dirs, origin=(0.0, 0.0, 0.0)):
        import warp as wp

        from warp_st.rendering.renderer import TILE_PIXELS

        self.wp = wp
        surfaces = [s for b in scene.bodies for s in b.surfaces]
        self.points = np.concatenate([s.points for s in surfaces]).astype(np.float32)
        base = np.cumsum([0] + [len(s.points) for s in surfaces])
        self.indices = np.concatenate([s.triangles + o for s, o in zip(surfaces, base)]).astype(np.int32).reshape(-1)
        n = len(dirs)
        self.dirs = wp.array(dirs, dtype=wp.vec3, device="cpu")
        self.origins = wp.array(np.tile(np.asarray(origin, np.float32), (n, 1)), dtype=wp.vec3, device="cpu")
        self.face = wp.zeros(n, dtype=wp.int32, device="cpu")
        self.t = wp.zeros(n, dtype=wp.float32, device="cpu")
        self.tiles = [(o, min(o + TILE_PIXELS, n)) for o in range(0, n, TILE_PIXELS)]
        self.kernel = _mesh_kernel(wp)
        self.kept = {}  # each thread's recorded launches, kept between calls as the renderer's are
        self.build()
        self.query(2)  # compile / load the kernel, first touch

    def build(self) -> float:
        t0 = time.perf_counter()
        wp = self.wp
        self.mesh = wp.Mesh(points=wp.array(self.points, dtype=wp.vec3, device="cpu"),
                            indices=wp.array(self.indices, dtype=wp.int32, device="cpu"))
        return time.perf_counter() - t0

    def query(self, threads: int) -> float:
        return self.run(self.replayed(self.kernel, [self.mesh.id, self.origins, self.dirs, self.face, self.t]), threads)

    def replayed(self, kernel, inputs):
        """``launch(tile)`` of ``kernel`` (``inputs``, then the tile's first ray), each thread
        replaying its recorded launch, kept between calls (``kept``), as the renderer's tiles
        do (``launches.tile_launches``)."""
        from warp_st.rendering.launches import tile_launches

        replay = tile_launches(self.wp, kernel, inputs, per_thread=1, end=False, kept=self.kept)
        return lambda tile: replay((tile[0], tile[1] - tile[0]))

    def run(self, launch, threads: int) -> float:
        """Seconds to call ``launch(tile)`` on every tile, in turn or on 2 threads taking
        the next tile as the renderer's do (``each_on_threads``; wall time, or with
        ``--clock cpu`` the process's CPU time: ``CLOCK``)."""
        from warp_st.core.thread_pool import each_on_threads

        t0 = CLOCK[0]()
        each_on_threads(launch, self.tiles, threads)
        return CLOCK[0]() - t0


class EmbreeQueries:
    """Embree (``embreex``: rtcIntersect1 per ray, its default BVH, float32) over the same
    triangles and rays as ``MeshQueries``, in the same tiles and threads (embreex
    releases the GIL). ``EmbreeQueries.create`` is None when embreex is not installed."""

    @classmethod
    def create(cls, mesh: MeshQueries, log):
        try:
            from embreex import rtcore_scene  # noqa: F401
        except ImportError:
            log("  embreex not installed (pip install -e '.[bench]'): Embree column skipped")
            return None
        return cls(mesh)

    def __init__(self, mesh: MeshQueries):
        self.mesh = mesh
        self.tri_points = np.ascontiguousarray(mesh.points[mesh.indices.reshape(-1, 3)], dtype=np.float32)
        self.dirs = np.ascontiguousarray(mesh.dirs.numpy(), dtype=np.float32)
        self.origins = np.ascontiguousarray(mesh.origins.numpy(), dtype=np.float32)
        self.face = np.full(len(self.dirs), -1, np.int64)
        self.build()
        self.query(2)

    def build(self) -> float:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        t0 = time.perf_counter()
        self.scene = rtcore_scene.EmbreeScene()
        TriangleMesh(self.scene, self.tri_points)
        self.scene.run(self.origins[:1], self.dirs[:1], output=1)  # Embree commits (builds) on first use
        return time.perf_counter() - t0

    def query(self, threads: int) -> float:
        def launch(tile):
            a, b = tile
            r = self.scene.run(self.origins[a:b], self.dirs[a:b], output=1)
            self.face[a:b] = np.where(r["geomID"] >= 0, r["primID"], -1)

        return self.mesh.run(launch, threads)


def _mesh_kernel(wp):
    @wp.kernel(enable_backward=False, module="unique")
    def mesh_rays(mesh: wp.uint64, origins: wp.array(dtype=wp.vec3), dirs: wp.array(dtype=wp.vec3),
                  out_face: wp.array(dtype=wp.int32), out_t: wp.array(dtype=float), first: int):
        i = wp.tid() + first  # a tile passes its first ray, as our probe's launches do
        q = wp.mesh_query_ray(mesh, origins[i], dirs[i], 1.0e30)
        out_face[i] = wp.where(q.result, q.face, -1)
        out_t[i] = wp.where(q.result, q.t, wp.inf)

    return mesh_rays


def timed_render(scene, args, threads):
    import warp_st

    t0 = time.perf_counter()
    img = warp_st.render(scene, frame=0, width=args.width, height=args.height, threads=threads)
    return time.perf_counter() - t0, img


def med(values) -> float:
    return statistics.median(values)


def paired(num, den) -> float:
    """The median over repetitions of num[i] / den[i]: each ratio of two timings taken back
    to back, so the machine's drift between repetitions cancels (a ratio of the two
    medians could pair a fast repetition of one side with a slow one of the other)."""
    return statistics.median(a / b for a, b in zip(num, den))


def table_static(args, log):
    scene = spheres_scene(128, moving=False)
    tris = sum(b.triangle_count for b in scene.bodies)
    mesh = MeshQueries(scene, pixel_directions(scene, args.width, args.height))
    timed_render(scene, args, 2)  # first render: builds what the scene caches
    rows = []
    for threads in (1, 2):
        ours, theirs = [], []
        for _ in range(args.runs):
            ours.append(timed_render(scene, args, threads)[0])
            theirs.append(mesh.query(threads))
        rows.append((f"warm render, {tris:,} static triangles, {args.width}x{args.height}, {threads} thr",
                     med(ours), med(theirs), paired(theirs, ours), "wp.Mesh / ours"))
        log(f"  static {threads} thr: ours {1e3 * med(ours):.1f} ms, wp.Mesh {1e3 * med(theirs):.1f} ms")
    return rows


def moving_against_resting(label, rest, moving, args, log):
    """Rows: warm renders of ``moving`` against ``rest``, 1 and 2 threads, back to back."""
    timed_render(rest, args, 2)
    timed_render(moving, args, 2)
    rows = []
    for threads in (1, 2):
        a, b = [], []
        for _ in range(args.runs):
            b.append(timed_render(moving, args, threads)[0])
            a.append(timed_render(rest, args, threads)[0])
        rows.append((f"warm render, {label} against at rest, {threads} thr", med(b), med(a), paired(b, a),
                     "moving / resting"))
        log(f"  {label}, {threads} thr: moving {1e3 * med(b):.1f} ms, resting {1e3 * med(a):.1f} ms")
    return rows


def closest_hits(r, geo, mesh, origin_event, label, args, log, finite=1):
    """Rows timing closest hits of ``mesh``'s rays through renderer ``r``'s two levels
    (``cast_rays`` on the frame's geometry ``geo``, rays from ``origin_event`` relative to
    its origin, ``finite`` 0 for a stage of infinite light speed: its database holds the
    camera's instant only) against ``mesh`` (wp.Mesh) and Embree over the same rays, 1
    and 2 threads, both sides back to back in each run; a row notes where the hit masks
    differ."""
    import warp as wp

    n = len(mesh.face)
    outs = [wp.array(np.tile(np.asarray(origin_event, np.float32), (n, 1)), dtype=wp.vec4, device="cpu"),
            wp.zeros(n, dtype=wp.int32, device="cpu"), wp.zeros(n, dtype=wp.float32, device="cpu"),
            wp.zeros(n, dtype=wp.int32, device="cpu")]

    def ours(threads):
        return mesh.run(mesh.replayed(r.kernels.cast_rays, [geo, outs[0], mesh.dirs, finite, *outs[1:]]), threads)

    ours(2)
    embree = EmbreeQueries.create(mesh, log)
    rows = []
    for threads in (1, 2):
        a, b, e = [], [], []
        for _ in range(args.runs):
            a.append(ours(threads))
            b.append(mesh.query(threads))
            if embree is not None:
                e.append(embree.query(threads))
        hit = outs[1].numpy() >= 0
        for who, times, faces in (("wp.Mesh", b, mesh.face.numpy()), ("Embree", e, None if embree is None else
                                                                      embree.face)):
            if times:
                agree = (hit == (faces >= 0)).mean()
                rows.append((f"closest hit only, {label.format(who=who)}, {threads} thr", med(a), med(times),
                             paired(times, a),
                             f"{who} / ours" + ("" if agree == 1.0 else f" (hit masks agree on {100 * agree:.2f} %)")))
        log(f"  {label.format(who='wp.Mesh')} {threads} thr: ours {1e3 * med(a):.1f} ms, wp.Mesh {1e3 * med(b):.1f} ms")
    return rows


def table_trace(args, log):
    from warp_st.rendering.renderer import Renderer

    scene = spheres_scene(128, moving=False)
    dirs = pixel_directions(scene, args.width, args.height)
    mesh = MeshQueries(scene, dirs)
    r = Renderer(scene, frames=[0.0], width=args.width, height=args.height)
    r.render(0.0)
    geo = r.database.geometry_for("float32", (0.0, 0.0, 0.0, 0.0), None)  # the frame's geometry, cached
    return closest_hits(r, geo, mesh, (0.0, 0.0, 0.0, 0.0), "16 static spheres (two levels against one {who})",
                        args, log)


def table_parade(args, log):
    """The shipped parade rendered in full (frame 0, 640 x 360, lit, warm), primary rays
    per second on 1 and 2 threads, the default path (exact spheres) and the prisms. The
    rows' ratio column holds Mrays/s (A: ms a frame)."""
    import warp_st
    from warp_st.rendering.renderer import Renderer

    scene = warp_st.load(str(ROOT / "usd_scenes" / "relativistic_parade.usda"))
    rows = []
    for primitive in (None, "prism"):
        r = Renderer(scene, frames=[0.0], width=640, height=360, primitive=primitive)
        r.render(0.0, threads=2)
        for threads in (1, 2):
            times = []
            for _ in range(args.runs):
                t0 = time.perf_counter()
                r.render(0.0, threads=threads)
                times.append(time.perf_counter() - t0)
            rate = 640 * 360 / med(times) / 1e6
            rows.append((f"full parade render, 640x360 lit, {primitive or 'default'} path, {threads} thr", med(times),
                         float("nan"), rate, "Mrays/s (not a ratio)"))
            log(f"  parade {primitive or 'default'} {threads} thr: {rate:.2f} Mrays/s")
    return rows


def table_motion(args, log):
    return moving_against_resting("16 spheres at 0.3-0.9c", spheres_scene(128, moving=False),
                                  spheres_scene(128, moving=True), args, log)


#: Shipped stages for the closest-hit table (static copies), with the frame each is timed at.
SHIPPED = (("relativistic_parade.usda", 0.0), ("mirrors/flanges_coupled.usda", 0.0), ("thesis/aberration.usda", 0.0),
           ("thesis/sphere_and_cubes.usda", 0.0))


def shipped_stages(which: str):
    """The shipped table's (stage, frame) pairs: ``SHIPPED``, or with ``all`` every stage
    under usd_scenes/ at frame 0."""
    if which == "all":
        return tuple((str(p.relative_to(ROOT / "usd_scenes")), 0.0) for p in sorted((ROOT / "usd_scenes").rglob("*.usda")))
    return SHIPPED


def table_shipped(args, log):
    """Closest hits on static copies of shipped stages (every body at rest, spheres as
    their triangles): our two levels against wp.Mesh and Embree over the same triangles
    and primary rays from the camera (``cast_rays``, no shading); ``--stages all``: every
    shipped stage."""
    import warp_st
    from benchlib.scenes import fixed_tessellation, static_version
    from warp_st.core.conventions import LightSpeed
    from warp_st.rendering.anchor import anchor_step, geometry_anchor
    from warp_st.rendering.renderer import Renderer

    rows = []
    for stage, frame in shipped_stages(args.stages):
        scene = fixed_tessellation(static_version(warp_st.load(str(ROOT / "usd_scenes" / stage))))
        r = Renderer(scene, frames=[frame], width=args.width, height=args.height, quadrics="tessellated")
        r.render(frame)
        cam = r._cameras[frame]
        event = np.array([cam.time, *cam.position], dtype=np.float64)
        origin = geometry_anchor(event, anchor_step(r.bvh.node_lo[0], r.bvh.node_hi[0]))
        geo = r.database.geometry_for("float32", tuple(origin.tolist()), None)  # the frame's, cached
        dirs = pixel_directions(scene, args.width, args.height, frame)
        mesh = MeshQueries(scene, dirs, cam.position)
        finite = int(r._frame_light_speed(cam) != LightSpeed.INFINITE)
        rows += closest_hits(r, geo, mesh, event - origin,
                             f"{Path(stage).stem} static copy ({len(mesh.indices) // 3:,} triangles)", args, log, finite)
    return rows


def first_renders(scene, label, args, log):
    """Rows: the first render of ``scene`` (a new Scene object each run, kernels loaded)
    against wp.Mesh's and Embree's build plus query of the same rays, 1 and 2 threads."""
    tris = sum(b.triangle_count for b in scene.bodies)
    mesh = MeshQueries(scene, pixel_directions(scene, args.width, args.height))
    embree = EmbreeQueries.create(mesh, log)
    timed_render(dataclasses.replace(scene), args, 2)  # kernels compiled / loaded
    rows = []
    for threads in (1, 2):
        ours, theirs, emb = [], [], []
        for _ in range(args.runs):
            fresh = dataclasses.replace(scene)  # a new Scene object: nothing cached for it
            ours.append(timed_render(fresh, args, threads)[0])
            theirs.append(mesh.build() + mesh.query(threads))
            if embree is not None:
                emb.append(embree.build() + embree.query(threads))
        for who, times in (("wp.Mesh", theirs), ("Embree", emb)):
            if times:
                rows.append((f"first render, {tris:,} static triangles{label}, {threads} thr", med(ours), med(times),
                             paired(ours, times), f"ours / ({who} build + query)"))
                log(f"  first{label} {threads} thr: ours {1e3 * med(ours):.1f} ms, {who} build+query "
                    f"{1e3 * med(times):.1f} ms")
    return rows, mesh, embree


def table_first(args, log):
    from warp_st.rendering.renderer import Renderer

    scene = spheres_scene(256, moving=False)
    tris = sum(b.triangle_count for b in scene.bodies)
    rows, mesh, embree = first_renders(scene, "", args, log)
    # The builds alone, per million triangles: our database for the frame (the renderer's
    # construction: shapes and shading tables, bottom levels, segments, top level) against the
    # 3D tracers' builds over the same triangles.
    from warp_st.accel.blas import bottom_levels
    from warp_st.spacetime.shape_tables import rigid_shapes

    builds = {"ours": [], "wp.Mesh": [], "Embree": [], "trees": []}
    shapes = rigid_shapes(scene)
    distinct = sum(len(t) for t in shapes.shape_triangles)
    for _ in range(args.runs):
        t0 = time.perf_counter()
        Renderer(dataclasses.replace(scene), frames=[0.0], width=args.width, height=args.height)
        builds["ours"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        bottom_levels(shapes)  # the bottom levels alone, over the distinct shapes' triangles
        builds["trees"].append(time.perf_counter() - t0)
        builds["wp.Mesh"].append(mesh.build())
        if embree is not None:
            builds["Embree"].append(embree.build())
    per_m = 1e6 / tris
    for who in ("wp.Mesh", "Embree"):
        if builds[who]:
            rows.append((f"build per million triangles ({tris:,} static triangles)", per_m * med(builds["ours"]),
                         per_m * med(builds[who]), paired(builds["ours"], builds[who]), f"ours / {who}"))
            # Builder against builder: our bottom levels per million triangles they hold
            # (the distinct shapes': instances are built once) against the same tracer's.
            rows.append((f"bottom levels alone per million triangles built ({distinct:,} in distinct shapes)",
                         1e6 / distinct * med(builds["trees"]), per_m * med(builds[who]),
                         paired(builds["trees"], builds[who]) * tris / distinct, f"ours / {who}"))
    log("  builds per M triangles: " + ", ".join(f"{k} {1e3 * (1e6 / distinct if k == 'trees' else per_m) * med(v):.0f}"
                                                 " ms" for k, v in builds.items() if v))
    return rows


def table_distinct(args, log):
    """The first render of the same 1.04M triangles with no two spheres sharing a shape
    (16 bottom levels to build, not 2)."""
    from benchlib.scenes import distinct_shapes

    return first_renders(distinct_shapes(spheres_scene(256, moving=False)), " in 16 distinct shapes", args, log)[0]


def table_cubes(args, log):
    return moving_against_resting("1,000 lit cubes up to 0.95c", cubes_scene(1000, moving=False),
                                  cubes_scene(1000, moving=True), args, log)


def table_sequence(args, log):
    from warp_st.rendering.renderer import Renderer

    scene = spheres_scene(128, moving=True)
    timed_render(scene, args, 2)
    rows = []
    for threads in (1, 2):
        seq, one = [], []
        for _ in range(args.runs):
            fresh = dataclasses.replace(scene)
            t0 = time.perf_counter()
            r = Renderer(fresh, frames=[0.0, 10000.0], width=args.width, height=args.height, threads=threads)
            r.render(0.0)
            r.render(10000.0)
            seq.append((time.perf_counter() - t0) / 2)
            one.append(timed_render(scene, args, threads)[0])
        rows.append((f"frames 0 and 10,000 of the moving spheres, per frame, {threads} thr", med(seq), med(one),
                     paired(seq, one), "per frame / one warm frame"))
        log(f"  sequence {threads} thr: {1e3 * med(seq):.1f} ms per frame, warm frame {1e3 * med(one):.1f} ms")
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=5, help="repetitions per measurement (median; default 5)")
    p.add_argument("--width", type=int, default=512)
    p.add_argument("--height", type=int, default=512)
    p.add_argument("--tables", default=",".join(TABLES), help=f"comma-separated subset of {','.join(TABLES)}")
    p.add_argument("--stages", choices=("four", "all"), default="four",
                   help="the shipped table's stages: parade, flanges_coupled, aberration, sphere_and_cubes "
                        "(default) or every stage under usd_scenes/")
    p.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                   help="time the ray queries (trace table) by wall or process CPU time (default wall)")
    args = p.parse_args(argv)
    CLOCK[0] = time.process_time if args.clock == "cpu" else time.perf_counter
    tables = [t for t in args.tables.split(",") if t]
    unknown = sorted(set(tables) - set(TABLES))
    if unknown or args.runs < 1:
        p.error(f"unknown table {', '.join(unknown)}" if unknown else "--runs must be >= 1")
    from warp_st.rendering.renderer import init_warp

    init_warp()

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    rows = []
    for name in tables:
        log(f"[{name}]")
        rows += {"static": table_static, "trace": table_trace, "shipped": table_shipped, "parade": table_parade, "motion": table_motion, "first": table_first,
                 "distinct": table_distinct, "cubes": table_cubes, "sequence": table_sequence}[name](args, log)
    print(f"CPU: {cpu_model()}; times: medians of {args.runs} runs; ratios: medians of the runs' ratios, both sides timed back to back in each run")
    print()
    print("| measure | A ms | B ms | ratio | ratio is |")
    print("|---|---|---|---|---|")
    for label, a, b, ratio, what in rows:
        ratio_text = f"{ratio:.2f}" if "Mrays" in what else f"{ratio:.2f}x"
        b_text = "-" if b != b else f"{1e3 * b:.1f}"
        print(f"| {label} | {1e3 * a:.1f} | {b_text} | {ratio_text} | {what} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
