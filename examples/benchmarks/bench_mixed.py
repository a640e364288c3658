#!/usr/bin/env python3
"""A deforming body inside a big static scene: the rigid path with tetrahedra leaves against the all-tet path.

A benchmark, not a test: it asserts nothing. The scene is examples/animation/waving_flag.usda
(its ground and its banner, whose flag deforms) with bench_two_level's 16 static spheres
(128 longitudes, ~254k triangles) behind it, at rest or (``--moving``) at 0.3-0.9c, their
centres on the camera's past lightcone at the frame. Both paths render frame 32 from one
``Renderer`` each: the build (construction, kernels cached), then warm frames timed back
to back in each run (medians of ``--runs``), on 1 and 2 threads, and the bytes each
database holds after the frames (``rendering.database_bytes``: host tables, uploads,
cached geometries). The CPU model heads the table.

    python3 examples/benchmarks/bench_mixed.py --runs 5 [--moving]
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
for p in (ROOT, ROOT / "examples" / "benchmarks"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

import numpy as np  # noqa: E402

FRAME = 32.0


def scene_with_spheres(moving: bool = False, segments: int = 128):
    """The waving flag's scene with 16 spheres of radius 1 behind the banner (``moving``:
    bench_two_level's velocities, each centre on the camera's past lightcone at FRAME)."""
    import warp_st
    from bench_two_level import spheres_scene

    flag = warp_st.load(str(ROOT / "examples" / "animation" / "waving_flag.usda"))
    offset = np.array([2.0, 4.5, 2.0])  # the spheres' grid (z = -12) moved to z = -10, around the banner
    spheres = []
    camera = flag.camera_state(flag.default_camera, FRAME).position
    for b in spheres_scene(segments, moving=moving).bodies:
        surfaces = tuple(dataclasses.replace(s, points=np.asarray(s.points) + offset) for s in b.surfaces)
        origin = np.asarray(b.origin) + offset
        spheres.append(dataclasses.replace(b, surfaces=surfaces, origin=origin,
                                           reference_time=FRAME - float(np.linalg.norm(origin - camera))))
    return dataclasses.replace(flag, bodies=flag.bodies + tuple(spheres))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=180)
    ap.add_argument("--moving", action="store_true", help="the spheres at 0.3-0.9c")
    ap.add_argument("--segments", type=int, default=128, help="the spheres' longitudes (smoke tests: fewer)")
    args = ap.parse_args(argv)
    from bench_two_level import cpu_model

    from warp_st.rendering.budget import MemoryRefusal
    from warp_st.rendering.database_bytes import extrusion_tables, rigid_tables, total_bytes
    from warp_st.rendering.renderer import Renderer

    scene = scene_with_spheres(args.moving, args.segments)
    tris = sum(b.triangle_count for b in scene.bodies)
    renderers, builds = {}, {}
    for primitive in ("rigid", "tet"):
        try:
            Renderer(scene, frames=[FRAME], width=8, height=8, primitive=primitive).render(FRAME)  # compile
        except MemoryRefusal as exc:  # the extrusion of every moving sphere does not fit
            print(f"{primitive}: refused: {exc}")
            continue
        t0 = time.perf_counter()
        renderers[primitive] = Renderer(scene, frames=[FRAME], width=args.width, height=args.height,
                                        primitive=primitive)
        builds[primitive] = time.perf_counter() - t0
    if "tet" not in renderers:
        r = renderers["rigid"]
        times = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            r.render(FRAME, threads=2)
            times.append(time.perf_counter() - t0)
        print(f"CPU: {cpu_model()}; mixed only: {r.stats.tetrahedra:,} tetrahedra, build {builds['rigid']:.2f} s, "
              f"warm frame (2 thr) {1e3 * statistics.median(times):.1f} ms, "
              f"database {total_bytes(rigid_tables(r.database)) / 1e6:.1f} MB")
        return
    times = {(p, n): [] for p in renderers for n in (1, 2)}
    for _ in range(args.runs):
        for threads in (1, 2):
            for primitive, r in renderers.items():
                t0 = time.perf_counter()
                r.render(FRAME, threads=threads)
                times[primitive, threads].append(time.perf_counter() - t0)
    size = {p: total_bytes((rigid_tables if p == "rigid" else extrusion_tables)(r.database))
            for p, r in renderers.items()}
    print(f"CPU: {cpu_model()}; {tris:,} triangles ({'moving' if args.moving else 'static'} spheres), "
          f"{args.width}x{args.height}, frame {FRAME:g}, "
          f"medians of {args.runs} runs, both paths timed back to back in each run")
    print()
    print("| measure | all-tet | mixed (rigid + tet leaves) | tet / mixed |")
    print("|---|---|---|---|")
    tets = {p: r.stats.tetrahedra for p, r in renderers.items()}
    print(f"| tetrahedra | {tets['tet']:,} | {tets['rigid']:,} | {tets['tet'] / max(tets['rigid'], 1):.0f}x |")
    print(f"| build (construction), s | {builds['tet']:.2f} | {builds['rigid']:.2f} | "
          f"{builds['tet'] / builds['rigid']:.1f}x |")
    for threads in (1, 2):
        a, b = statistics.median(times["tet", threads]), statistics.median(times["rigid", threads])
        print(f"| warm frame, {threads} thr, ms | {1e3 * a:.1f} | {1e3 * b:.1f} | {a / b:.2f}x |")
    print(f"| database bytes (host + uploads + geometry), MB | {size['tet'] / 1e6:.1f} | {size['rigid'] / 1e6:.1f} | "
          f"{size['tet'] / size['rigid']:.1f}x |")


if __name__ == "__main__":
    main()
