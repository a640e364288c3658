#!/usr/bin/env python3
"""Tracing benchmark for warp_st (a benchmark, not a test: it asserts nothing).

For each scene it measures the renderer (4D extrusion, BVH build, kernel compile,
full-frame render on 1 and 2 threads, BVH nodes visited per ray, bytes per
tetrahedron) and then compares, on the STATIC version of the scene (every body at
rest, so each triangle becomes one prism of three tetrahedra), our 4D BVH traced by
the ``cast_rays`` probe kernel against Warp's own 3D ``wp.Mesh`` +
``wp.mesh_query_ray`` on the same primary rays (closest hit only, no shading).

    python3 examples/benchmarks/bench_trace.py                 # full run, ~1-3 minutes
    python3 examples/benchmarks/bench_trace.py --quick         # smoke run, < 30 s
    python3 examples/benchmarks/bench_trace.py --scenes parade,spheres --runs 7 \
        --out bench.md --json bench.json

Timings are medians over ``--runs`` runs (1-thread and 2-thread runs interleaved),
with the min-max spread; Mrays/s counts primary rays (W*H) over kernel seconds.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
for _path in (HERE, ROOT):  # benchlib, and warp_st from this checkout when it is not installed
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

SCENES = ("parade", "spheres", "cubes", "flanges", "aberration")
#: Shipped stages benchmarked besides the parade (rendered at their start frame).
SHIPPED = {"flanges": "usd_scenes/mirrors/flanges_coupled.usda", "aberration": "usd_scenes/thesis/aberration.usda"}


# --------------------------------------------------------------------------- options


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs", type=int, default=5, help="timed runs per measurement (default 5): median and min-max")
    p.add_argument("--width", type=int, default=None, help="image width (default 640; --quick 160)")
    p.add_argument("--height", type=int, default=None, help="image height (default 360; --quick 90)")
    p.add_argument("--quick", action="store_true", help="tiny sizes for a smoke run (< 30 s with a warm kernel cache)")
    p.add_argument("--scenes", default=",".join(SCENES), help=f"comma-separated subset of {','.join(SCENES)} (default all)")
    p.add_argument("--sphere-segments", type=int, default=None, help="longitude segments per sphere of the sphere grid (default 50 -> ~1.0M tetrahedra; --quick 12)")
    p.add_argument("--cubes", type=int, default=None, help="number of cubes of the cubes scene (default 1000; --quick 64)")
    p.add_argument("--cold-cache", action="store_true", help="compile the kernels into a fresh temporary cache (measures a cold compile)")
    p.add_argument("--out", metavar="FILE.md", help="also write the report (markdown) to this file")
    p.add_argument("--json", metavar="FILE.json", help="also write the raw numbers to this file")
    args = p.parse_args(argv)
    if args.runs < 1:
        p.error("--runs must be >= 1")
    quick = args.quick
    args.width = args.width or (160 if quick else 640)
    args.height = args.height or (90 if quick else 360)
    args.sphere_segments = args.sphere_segments or (12 if quick else 50)
    args.cubes = args.cubes or (64 if quick else 1000)
    if quick and args.runs == 5:
        args.runs = 2
    args.scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    bad = [s for s in args.scenes if s not in SCENES]
    if bad:
        p.error(f"unknown scene(s) {bad}; choose from {list(SCENES)}")
    return args


# --------------------------------------------------------------------------- scenes


# Scene builders and machine helpers are shared with bench_performance.py (benchlib/).
from benchlib.machine import machine_info, summarize  # noqa: E402
from benchlib.scenes import cube_cloud_scene, load_parade, static_version  # noqa: E402
from warp_st.core.scene import surface_triangles  # noqa: E402
from warp_st.rendering.camera import pixel_directions  # noqa: E402
from warp_st.testing import sphere_grid_scene  # noqa: E402


def cache_entries(wp):
    d = wp.config.kernel_cache_dir
    try:
        return set(os.listdir(d)) if d and os.path.isdir(d) else set()
    except OSError:
        return set()


def _nbytes(a):
    import warp as wp

    return int(a.size * wp.types.type_size_in_bytes(a.dtype))


def uploaded_bytes(static, geo):
    """(trace bytes, all bytes): trace = vertices + primitive arrays + BVH node arrays as
    the kernel reads them; all = every device array of the database (shading too)."""
    import warp as wp

    trace_arrays = [geo.vert, geo.prim_event, geo.prim_vidx, geo.prim_tri, geo.tri_body, geo.node_lo, geo.node_hi, geo.node_link]
    trace = sum(_nbytes(a) for a in trace_arrays)
    others = {id(a): a for a in vars(static).values() if isinstance(a, wp.array)}
    for a in trace_arrays:
        others.pop(id(a), None)
    return trace, trace + sum(_nbytes(a) for a in others.values())


# --------------------------------------------------------------------------- wp.Mesh side

_MESH_KERNEL = None


def mesh_kernel():
    global _MESH_KERNEL
    if _MESH_KERNEL is None:
        import warp as wp

        @wp.kernel(enable_backward=False, module="unique")
        def mesh_rays(
            mesh: wp.uint64,
            origins: wp.array(dtype=wp.vec3),
            dirs: wp.array(dtype=wp.vec3),
            max_t: float,
            out_face: wp.array(dtype=wp.int32),
            out_t: wp.array(dtype=float),
            first: int,
        ):
            i = wp.tid() + first  # a tile passes its first ray, as our probe's launches do
            q = wp.mesh_query_ray(mesh, origins[i], dirs[i], max_t)
            if q.result:
                out_face[i] = q.face
                out_t[i] = q.t
            else:
                out_face[i] = -1
                out_t[i] = wp.inf

        _MESH_KERNEL = mesh_rays
    return _MESH_KERNEL


def probe_launcher(k, geo, dirs):
    """launch(a, b) of our ``cast_rays`` probe (closest hit, finite c, camera event at
    the render origin) on rays [a, b) of ``dirs``, and its outputs (primitive, lookback,
    nodes visited)."""
    import warp as wp

    n = len(dirs)
    o4 = wp.zeros(n, dtype=wp.vec4, device="cpu")
    out = (wp.zeros(n, dtype=wp.int32, device="cpu"), wp.zeros(n, dtype=wp.float32, device="cpu"),
           wp.zeros(n, dtype=wp.int32, device="cpu"))

    return tile_launcher(k.cast_rays, [geo, o4, dirs, 1, *out]), out


def mesh_launcher(points, tris, dirs):
    """launch(a, b) of wp.Mesh + mesh_query_ray from the origin on rays [a, b) of
    ``dirs`` over triangles ``tris`` of ``points`` (camera-relative), its outputs (face
    or -1, t), and the kernel."""
    import warp as wp

    n = len(dirs)
    wmesh = wp.Mesh(
        points=wp.array(np.asarray(points).astype(np.float32), dtype=wp.vec3, device="cpu"),
        indices=wp.array(tris.reshape(-1).astype(np.int32), dtype=wp.int32, device="cpu"),
    )
    mk = mesh_kernel()
    o3 = wp.zeros(n, dtype=wp.vec3, device="cpu")
    face = wp.zeros(n, dtype=wp.int32, device="cpu")
    t_hit = wp.zeros(n, dtype=wp.float32, device="cpu")

    launch = tile_launcher(mk, [wmesh.id, o3, dirs, 1.0e30, face, t_hit])
    launch.mesh = wmesh  # kept alive with its launches
    return launch, (face, t_hit), mk


def tile_launcher(kernel, inputs):
    """launch(a, b) of ``kernel`` (``inputs``, then the first ray) on rays [a, b), each
    thread replaying its recorded launch as the renderer's tiles do (``tile_launches``)."""
    import warp as wp

    from warp_st.rendering.launches import tile_launches

    replay = tile_launches(wp, kernel, inputs, per_thread=1, end=False)

    def launch(a, b):
        replay((a, b - a))

    return launch


def scene_triangles(scene, windows):
    """World-space triangles of a static scene in the extrusion's triangle order
    (bodies, then surfaces, degenerate index triples dropped)."""
    pts_all, tris_all, base = [], [], 0
    for body, window in zip(scene.bodies, windows):
        if window is None or not body.surfaces:
            continue
        for surf in body.surfaces:
            tris = surface_triangles(surf)
            if len(tris) == 0:
                continue
            pts = np.asarray(surf.points, dtype=np.float64)
            pts_all.append(pts)
            tris_all.append(tris + base)
            base += len(pts)
    return np.concatenate(pts_all), np.concatenate(tris_all)


# --------------------------------------------------------------------------- measurements


class Launcher:
    """Launches a kernel over a ray range in tiles, on 1 thread or from a thread pool."""

    def __init__(self, n, tile):
        self.tiles = [(o, min(o + tile, n)) for o in range(0, n, tile)]

    def run(self, launch_tile, threads):
        from warp_st.core.thread_pool import each_on_threads

        t0 = time.perf_counter()
        each_on_threads(lambda t: launch_tile(*t), self.tiles, threads)
        return time.perf_counter() - t0


def bench_renderer(name, scene, args, log, first):
    import warp as wp

    from warp_st.rendering.device import make_geometry
    from warp_st.rendering.renderer import Renderer, init_warp

    init_warp()
    before = cache_entries(wp) if first else None
    t0 = time.perf_counter()
    r = Renderer(scene, frames=[0], width=args.width, height=args.height, primitive="prism")
    ctor = time.perf_counter() - t0
    st = r.stats
    res = {
        "tetrahedra": st.tetrahedra,
        "primitives": st.primitives,
        "triangles": int(sum(b.triangle_count for b in scene.bodies)),
        "bodies": len(scene.bodies),
        "lights": len(scene.lights),
        "bvh_nodes": st.bvh_nodes,
        "bvh_depth": st.bvh_depth,
        "extrude_s": st.extrude_seconds,
        "bvh_s": st.bvh_seconds,
        "upload_s": st.upload_seconds,
        "compile_s": st.compile_seconds,
        "constructor_s": ctor,
        "precision": r.precision.value,
        "samples": getattr(r, "samples", 1),
        "max_depth": getattr(r, "max_depth", None),
        "describe": r.describe(),
    }
    if first:
        new = cache_entries(wp) - before
        res["first_construction"] = True
        res["kernel_cache"] = "cold (compiled now)" if new else "warm (loaded from cache)"
    cam = scene.camera_state(r.camera_path, r.frames[0])
    origin = np.array([cam.time, *cam.position], dtype=np.float64)
    geo = make_geometry(r.kernels, r.static, r.mesh, r.bvh, origin)
    trace_b, all_b = uploaded_bytes(r.static, geo)
    res["bytes_trace"], res["bytes_all"] = trace_b, all_b
    res["bytes_per_tet_trace"] = trace_b / max(st.tetrahedra, 1)
    res["bytes_per_tet_all"] = all_b / max(st.tetrahedra, 1)
    log(f"  [{name}] {st.tetrahedra:,} tets, {st.bvh_nodes:,} nodes; extrude {st.extrude_seconds:.2f} s, BVH {st.bvh_seconds:.2f} s, compile {st.compile_seconds:.2f} s")

    r.render(0, threads=2)  # warm-up (first-touch of every array)
    kern = {1: [], 2: []}
    frame = {1: [], 2: []}
    visits = None
    coverage = None
    for _ in range(args.runs):
        for th in (1, 2):
            img = r.render(0, threads=th)
            kern[th].append(r.stats.last_kernel_seconds)
            frame[th].append(r.stats.last_frame_seconds)
            visits = r.stats.last_mean_visits
            coverage = float((img.object_id > 0).mean())
    rays = args.width * args.height
    for th in (1, 2):
        res[f"render_kernel_s_{th}t"] = summarize(kern[th])
        res[f"render_frame_s_{th}t"] = summarize(frame[th])
        res[f"render_mrays_{th}t"] = rays / statistics.median(kern[th]) / 1e6
    res["render_speedup"] = statistics.median(kern[1]) / statistics.median(kern[2])
    res["render_visits_per_ray"] = visits
    res["coverage"] = coverage
    log(f"  [{name}] render {res['render_mrays_1t']:.3f} / {res['render_mrays_2t']:.3f} Mrays/s (1/2 threads), {visits:.1f} nodes/ray")
    return res, cam


def embree_scene(tri_points):
    """An Embree scene of float32 triangles (N, 3, 3) through ``embreex``; None if not installed."""
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        return None
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, np.ascontiguousarray(tri_points, dtype=np.float32))
    return scene


def our_tracer(k, sscene, windows, primitive, origin):
    """(geometry, mesh, bvh, build seconds) of our 4D database over ``primitive``."""
    from warp_st.rendering.device import StaticArrays, make_geometry
    from warp_st.rendering.renderer import build_database

    t0 = time.perf_counter()
    mesh, bvh = build_database(sscene, windows, primitive)
    build = time.perf_counter() - t0
    static = StaticArrays(k, mesh, bvh)
    return make_geometry(k, static, mesh, bvh, origin), mesh, bvh, build


def bench_static(name, scene, cam, args, log):
    """Static scene, closest hit of the same primary rays: our cast_rays probe over prisms
    (the renderer's default) and over tetrahedra, Warp's wp.Mesh + mesh_query_ray, and
    Embree (embreex, when installed)."""
    import warp as wp

    from warp_st.kernels import get_kernels
    from warp_st.rendering.renderer import TILE_PIXELS, init_warp
    from warp_st.spacetime.visibility import visibility_windows

    init_warp()
    sscene = static_version(scene)
    res = {}
    windows = visibility_windows(sscene, [cam], infinite=False)
    origin = np.array([cam.time, *cam.position], dtype=np.float64)
    pts, tris = scene_triangles(sscene, windows)
    res["triangles"] = int(len(tris))
    dirs64 = pixel_directions(cam, args.width, args.height).reshape(-1, 3)  # the same rays for every tracer
    n = len(dirs64)
    dirs = wp.array(dirs64.astype(np.float32), dtype=wp.vec3, device="cpu")
    # The renderer's tile size, smaller for tiny images so two threads still balance.
    launcher = Launcher(n, min(TILE_PIXELS, max(256, n // 16)))
    tracers = {}  # name -> (launch tile, hit triangle per ray or -1, lookback per ray)

    for primitive in ("prism", "tet"):
        k = get_kernels("float32", primitive)
        geo, mesh, bvh, build = our_tracer(k, sscene, windows, primitive, origin)
        # Every triangle extruded (a static body's time range may still be cut into several
        # segments, each its own prism; hits map back to triangles through prim_tri below).
        covered = np.unique(mesh.prism_tri if primitive == "prism" else mesh.tet_tri)
        assert covered.size == len(tris), f"{name}: {covered.size} of {len(tris)} triangles extruded"
        res[f"{primitive}_build_s"] = build
        res[f"{primitive}_primitives"] = mesh.prim_count
        res[f"{primitive}_bvh_nodes"] = bvh.node_count_total
        t0 = time.perf_counter()
        wp.load_module(k.cast_rays.module, device="cpu")
        res[f"{primitive}_probe_compile_s"] = time.perf_counter() - t0
        ours, out = probe_launcher(k, geo, dirs)
        prim_tri = mesh.prism_tri if primitive == "prism" else mesh.tet_tri

        def result(out=out, prim_tri=prim_tri):
            prim = out[0].numpy()
            return np.where(prim >= 0, prim_tri[np.maximum(prim, 0)], -1), out[1].numpy().astype(np.float64), out[2].numpy()

        tracers[f"ours_{primitive}"] = (ours, result)

    t0 = time.perf_counter()
    theirs, (face, t_hit), mk = mesh_launcher(pts - cam.position, tris, dirs)
    res["mesh_build_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    wp.load_module(mk.module, device="cpu")
    res["mesh_kernel_compile_s"] = time.perf_counter() - t0
    tracers["mesh"] = (theirs, lambda: (face.numpy(), t_hit.numpy().astype(np.float64), None))

    tri_points = (pts - cam.position)[tris]  # float64 -> float32 in embree_scene
    t0 = time.perf_counter()
    escene = embree_scene(tri_points)
    res["embree_build_s"] = time.perf_counter() - t0
    if escene is not None:
        e_org = np.zeros((n, 3), dtype=np.float32)
        e_dir = np.ascontiguousarray(dirs64.astype(np.float32))
        e_out = {"prim": np.full(n, -1, np.int64), "t": np.full(n, np.inf)}

        def embree(a, b):  # embreex releases the GIL: tiles run in parallel
            r = escene.run(e_org[a:b], e_dir[a:b], output=1)
            e_out["prim"][a:b] = np.where(r["geomID"] >= 0, r["primID"], -1)
            e_out["t"][a:b] = np.where(r["geomID"] >= 0, r["tfar"], np.inf)

        tracers["embree"] = (embree, lambda: (e_out["prim"], e_out["t"], None))
    else:
        log("  embreex not installed (pip install embreex): Embree column skipped")

    for launch, _ in tracers.values():  # warm-up
        launcher.run(launch, 2)
    times = {(w, th): [] for w in tracers for th in (1, 2)}
    for _ in range(args.runs):
        for th in (1, 2):
            for who, (launch, _) in tracers.items():
                times[(who, th)].append(launcher.run(launch, th))
    for (who, th), v in times.items():
        res[f"{who}_s_{th}t"] = summarize(v)
        res[f"{who}_mrays_{th}t"] = n / statistics.median(v) / 1e6
    for who in tracers:
        res[f"{who}_speedup"] = statistics.median(times[(who, 1)]) / statistics.median(times[(who, 2)])
        for th in (1, 2):
            res[f"{who}_over_mesh_{th}t"] = res[f"{who}_mrays_{th}t"] / res[f"mesh_mrays_{th}t"]
            # Run by run: each run times both tracers back to back, so the machine's
            # drift between runs cancels in these ratios.
            res[f"{who}_over_mesh_paired_{th}t"] = summarize(
                [m / o for o, m in zip(times[(who, th)], times[("mesh", th)])])

    # Agreement with wp.Mesh: hit/miss, triangle and lookback s (= 3D distance at rest).
    ref_tri, ref_t, _ = tracers["mesh"][1]()
    res["rays"] = int(n)
    for who, (_, result) in tracers.items():
        tri, s, visits = result()
        if visits is not None:
            res[f"{who}_visits_per_ray"] = float(visits.mean())
            res[f"{who}_visits_max"] = int(visits.max())
        hit, ref_hit = tri >= 0, ref_tri >= 0
        both = hit & ref_hit
        rel = np.abs(s[both] - ref_t[both]) / np.maximum(ref_t[both], 1e-30)
        res[f"{who}_agree"] = {
            "hits": int(hit.sum()), "hit_mismatch": int((hit != ref_hit).sum()),
            "same_triangle_frac": float((tri[both] == ref_tri[both]).mean()) if both.any() else 1.0,
            "max_rel_ds": float(rel.max()) if both.any() else 0.0, "far_ds_rays": int((rel > 1e-3).sum()),
        }
    log(f"  [{name} static] Mrays/s 1/2 threads: " + ", ".join(
        f"{who} {res[f'{who}_mrays_1t']:.3f}/{res[f'{who}_mrays_2t']:.3f}" for who in tracers))
    return res


# --------------------------------------------------------------------------- report


def _ms(summary):
    return f"{1e3 * summary['median']:.1f} ({1e3 * summary['min']:.1f}–{1e3 * summary['max']:.1f})"


def _mr_range(rays, summary):
    lo, hi = rays / summary["max"] / 1e6, rays / summary["min"] / 1e6
    return f"{rays / summary['median'] / 1e6:.3f} ({lo:.3f}–{hi:.3f})"


SCENE_TITLES = {"parade": "relativistic_parade.usda", "spheres": "sphere grid", "cubes": "moving cubes",
                "flanges": "mirrors/flanges_coupled.usda", "aberration": "thesis/aberration.usda"}


def build_report(results, machine, args):
    names = [n for n in args.scenes if n in results]
    rays = args.width * args.height
    rows = []

    def row(label, fn):
        cells = []
        for n in names:
            try:
                cells.append(fn(results[n]))
            except (KeyError, TypeError, ZeroDivisionError):
                cells.append("–")
        rows.append((label, cells))

    R = lambda n: n["render"]  # noqa: E731
    S = lambda n: n["static"]  # noqa: E731
    row("bodies / triangles / lights", lambda x: f"{R(x)['bodies']} / {R(x)['triangles']:,} / {R(x)['lights']}")
    row("samples/pixel, max depth, precision", lambda x: f"{R(x)['samples']}, {R(x)['max_depth']}, {R(x)['precision']}")
    row("tetrahedra (moving) / prisms", lambda x: f"{R(x)['tetrahedra']:,} / {R(x)['primitives']:,}")
    row("BVH nodes / depth (binary SAH tree)", lambda x: f"{R(x)['bvh_nodes']:,} / {R(x)['bvh_depth']}")
    row("extrusion + BVH build, s", lambda x: f"{R(x)['extrude_s']:.2f} + {R(x)['bvh_s']:.2f}")
    row("kernel compile/load, s", lambda x: f"{R(x)['compile_s']:.2f}" + (" (first, " + R(x)["kernel_cache"].split(" ")[0] + " cache)" if R(x).get("first_construction") else ""))
    row("bytes/tet: trace arrays (all)", lambda x: f"{R(x)['bytes_per_tet_trace']:.1f} ({R(x)['bytes_per_tet_all']:.1f})")
    row("render kernel 1 thread, ms", lambda x: _ms(R(x)["render_kernel_s_1t"]))
    row("render kernel 2 threads, ms", lambda x: _ms(R(x)["render_kernel_s_2t"]))
    row("render full frame 1 / 2 thr, ms", lambda x: f"{1e3 * R(x)['render_frame_s_1t']['median']:.1f} / {1e3 * R(x)['render_frame_s_2t']['median']:.1f}")
    row("render Mrays/s 1 thread", lambda x: _mr_range(rays, R(x)["render_kernel_s_1t"]))
    row("render Mrays/s 2 threads", lambda x: _mr_range(rays, R(x)["render_kernel_s_2t"]))
    row("render 1→2 core speed-up", lambda x: f"{R(x)['render_speedup']:.2f}x")
    row("render wide BVH nodes visited/ray (all rays of a pixel)", lambda x: f"{R(x)['render_visits_per_ray']:.1f}")
    row("pixel coverage", lambda x: f"{100 * R(x)['coverage']:.1f}%")
    row("**static** (closest hit): triangles", lambda x: f"{S(x)['triangles']:,}")
    row("static ours BVH nodes: prisms / tets", lambda x: f"{S(x)['prism_bvh_nodes']:,} / {S(x)['tet_bvh_nodes']:,}")
    row("static build s: prisms / tets / wp.Mesh / Embree",
        lambda x: f"{S(x)['prism_build_s']:.2f} / {S(x)['tet_build_s']:.2f} / {S(x)['mesh_build_s']:.2f} / "
        + (f"{S(x)['embree_build_s']:.2f}" if "embree_s_1t" in S(x) else "–"))
    for who, label in (("ours_prism", "ours, prisms"), ("ours_tet", "ours, tetrahedra"), ("mesh", "wp.Mesh"), ("embree", "Embree")):
        for th in (1, 2):
            row(f"static {label} Mrays/s {th} thr", lambda x, who=who, th=th: _mr_range(rays, S(x)[f"{who}_s_{th}t"]))
    for who, label in (("ours_prism", "ours (prisms)"), ("ours_tet", "ours (tets)"), ("embree", "Embree")):
        row(f"static ratio {label} / wp.Mesh, 1 / 2 thr",
            lambda x, who=who: f"{S(x)[f'{who}_over_mesh_1t']:.2f} / {S(x)[f'{who}_over_mesh_2t']:.2f}")
    for th in (1, 2):
        row(f"static ratio ours (prisms) / wp.Mesh run by run, {th} thr: median (min–max)",
            lambda x, th=th: "{median:.2f} ({min:.2f}–{max:.2f})".format(**S(x)[f"ours_prism_over_mesh_paired_{th}t"]))
    row("static ratio ours (prisms) / Embree, 1 / 2 thr",
        lambda x: f"{S(x)['ours_prism_mrays_1t'] / S(x)['embree_mrays_1t']:.2f} / {S(x)['ours_prism_mrays_2t'] / S(x)['embree_mrays_2t']:.2f}")
    row("static 1→2 speed-up: prisms / wp.Mesh / Embree",
        lambda x: f"{S(x)['ours_prism_speedup']:.2f}x / {S(x)['mesh_speedup']:.2f}x / "
        + (f"{S(x)['embree_speedup']:.2f}x" if "embree_speedup" in S(x) else "–"))
    row("static wide nodes visited/ray: prisms / tets", lambda x: f"{S(x)['ours_prism_visits_per_ray']:.1f} / {S(x)['ours_tet_visits_per_ray']:.1f}")

    m = machine
    lines = [
        "# warp_st tracing benchmark",
        "",
        f"Machine: {m['cpu']}, {m['cpu_count']} logical cores ({m['usable_cores']} usable), "
        f"warp {m['warp']}, numpy {m['numpy']}, Python {m['python']}, {m['platform']}; "
        f"1-min load average {m['loadavg'][0]:.2f} at start, {m.get('loadavg_end', [float('nan')])[0]:.2f} at end "
        "(other processes on the cores distort the 2-thread numbers); "
        f"{m['date']}.",
        f"Image {args.width}x{args.height} = {rays:,} primary rays; {args.runs} runs per timing, "
        "median (min–max); 1- and 2-thread runs interleaved; Mrays/s = W*H / kernel seconds.",
        "",
    ]
    header = "| metric | " + " | ".join(SCENE_TITLES.get(n, n) for n in names) + " |"
    lines += [header, "|" + "---|" * (len(names) + 1)]
    for label, cells in rows:
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("Sanity (static scenes, every tracer against wp.Mesh on identical float32 rays):")
    for n in names:
        s = results[n].get("static")
        if not s:
            continue
        for who in ("ours_prism", "ours_tet", "embree"):
            g = s.get(f"{who}_agree")
            if g is None:
                continue
            flag = "OK" if g["hit_mismatch"] <= 1e-3 * s["rays"] else "MISMATCH > 0.1% of rays: investigate"
            lines.append(
                f"- {SCENE_TITLES.get(n, n)}, {who}: hit/miss agree on {s['rays'] - g['hit_mismatch']:,}/{s['rays']:,} rays "
                f"(hits {g['hits']:,}); same triangle {100 * g['same_triangle_frac']:.3f}% of rays both hit; "
                f"max rel |Δs| {g['max_rel_ds']:.1e}; rays with rel Δs > 1e-3: {g['far_ds_rays']} — {flag}"
            )
    lines.append("")
    notes = [
        "Notes:",
        "- render = `Renderer.render(0, threads=…)`, everything the renderer does per pixel (shadow rays to each light, "
        "mirror bounces up to max depth, all AOVs); Mrays/s counts W*H primary rays only; kernel time from `stats.last_kernel_seconds`, full frame from `stats.last_frame_seconds` "
        "(adds recentring upload and film read-back).",
        "- static = same camera and pixel rays, every body at rest (a prism, 3 tets, per triangle and time segment); closest hit only, "
        "tiles of min(4096, W*H/16) rays, 2 threads = the calling thread and one pool thread, each taking the next tile and replaying its recorded Warp launch (embreex releases the GIL). "
        "wp.Mesh uses Warp's default CPU BVH (SAH, leaf size 4); Embree is Intel Embree 4 through `embreex` "
        "(`EmbreeScene.run`, rtcIntersect1 per ray, its default BVH and SIMD kernels, float32); "
        "ours is the 4D binned-SAH BVH (leaf size ≤ 4) collapsed to 4 children per node (a visit = one 16-lane slab test of four 4D boxes) with float64 leaf tests: one comoving triangle per prism "
        "(the renderer's default) or three ray/tetrahedron tests (the general path).",
        "- scenes: parade = the shipped USD scene, frame 0 (2 lights); sphere grid = 10x10 UV spheres "
        f"({args.sphere_segments} segments) at z = -30, at rest / coupled up to 0.9c / decoupled up to 0.9c, unlit; "
        f"moving cubes = {args.cubes} cubes, 20% at rest, others up to 0.95c in random directions "
        "(1/3 decoupled), 1 distant light; flanges = the shipped thesis Fig. 4.6 mirror scene (coupled, 0.866c, "
        "mirrors up to max depth 4), aberration = the shipped moving-camera aberration scene, both at frame 0. "
        "Static versions: the same bodies at rest at their authored positions.",
        "- bytes/tet: per tetrahedron of the database (3 per prism); trace arrays = vertices + inline primitive events + "
        "primitive vertex indices + primitive triangles + tri_body + node boxes and links as uploaded; "
        "all = plus the shading arrays (normals, materials, bodies).",
    ]
    for n in names:
        s = results[n].get("static")
        if s:
            notes.append(
                f"- {SCENE_TITLES.get(n, n)}: probe compile/load {s['prism_probe_compile_s']:.2f} s, "
                f"wp.Mesh kernel compile/load {s['mesh_kernel_compile_s']:.2f} s."
            )
            break
    lines += notes
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- main


def main(argv=None):
    args = parse_args(argv)
    t_start = time.perf_counter()
    if args.cold_cache:
        import atexit
        import shutil

        cold_dir = tempfile.mkdtemp(prefix="warp_st_bench_cache_")
        os.environ["WARP_CACHE_PATH"] = cold_dir
        atexit.register(shutil.rmtree, cold_dir, ignore_errors=True)
    from warp_st.rendering.renderer import init_warp

    wp = init_warp()

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    machine = machine_info()
    log(f"bench_trace: {args.width}x{args.height}, runs={args.runs}, scenes={args.scenes}, kernel cache {wp.config.kernel_cache_dir}")
    results = {}
    first = True
    for name in args.scenes:
        t0 = time.perf_counter()
        if name == "parade":
            scene = load_parade()
        elif name == "spheres":
            scene = sphere_grid_scene(args.sphere_segments)
        elif name == "cubes":
            scene = cube_cloud_scene(args.cubes)
        else:
            import warp_st

            scene = warp_st.load(str(ROOT / SHIPPED[name]))
        log(f"[{name}] scene built in {time.perf_counter() - t0:.2f} s")
        render, cam = bench_renderer(name, scene, args, log, first)
        first = False
        static = bench_static(name, scene, cam, args, log)
        results[name] = {"render": render, "static": static}

    try:
        machine["loadavg_end"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    report = build_report(results, machine, args)
    print(report, end="")
    total = time.perf_counter() - t_start
    log(f"total {total:.1f} s")
    if args.out:
        Path(args.out).write_text(report)
    if args.json:
        payload = {
            "machine": machine,
            "options": {k: v for k, v in vars(args).items() if k not in ("out", "json")},
            "total_seconds": total,
            "results": results,
        }
        Path(args.json).write_text(json.dumps(payload, indent=2, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
