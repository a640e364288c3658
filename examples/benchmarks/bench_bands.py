"""Where a static scene's tracing time goes, band by band (a benchmark: it asserts nothing).

The image is cut into horizontal bands; for each band the same primary rays of the
static copy (every body at rest, as in ``bench_trace.py``) go through our prism tracer
(the ``cast_rays`` probe) and through Warp's ``wp.Mesh`` + ``mesh_query_ray``, one
whole-band launch at a time on one thread. Printed per band: nanoseconds per ray (median
of ``--runs``), the ratio, the fraction of rays that hit, and our wide BVH nodes
visited per ray. Bands of sky (rays that miss the database's box) show the fixed cost
per ray; bands of near geometry show the traversal.

    python3 examples/benchmarks/bench_bands.py                  # the parade, 640x360, 10 bands
    python3 examples/benchmarks/bench_bands.py --scene flanges --bands 6 --runs 9

``--only ours|mesh --band B`` launches one tracer on one band ``--runs`` times and
prints nothing else, for hardware counters: the difference of two runs of ``perf stat
-e instructions,cycles`` with different ``--runs`` is the cost of the extra launches
alone (set-up cancels).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_trace as bt  # noqa: E402
from benchlib.machine import cpu_model  # noqa: E402
from benchlib.scenes import load_parade, static_version  # noqa: E402


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="parade", choices=["parade", *bt.SHIPPED], help="scene (default parade)")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=360)
    p.add_argument("--bands", type=int, default=10, help="horizontal bands (default 10)")
    p.add_argument("--runs", type=int, default=15, help="timed launches per band and tracer (default 15)")
    p.add_argument("--only", choices=["ours", "mesh"], help="launch only this tracer, on --band (for perf stat)")
    p.add_argument("--band", type=int, default=0, help="the band --only launches (default 0)")
    return p.parse_args(argv)


def tracers(scene, width, height):
    """The static copy's primary rays through both tracers: (rays, ours(a, b),
    wp_mesh(a, b), outputs). ``ours``/``wp_mesh`` launch on rays [a, b); outputs holds
    our hit primitive and nodes visited and wp.Mesh's hit face, per ray."""
    import warp as wp

    from warp_st.kernels import get_kernels
    from warp_st.rendering.camera import pixel_directions
    from warp_st.rendering.renderer import Renderer, init_warp
    from warp_st.spacetime.visibility import visibility_windows

    init_warp()
    r = Renderer(scene, frames=[0], width=16, height=9)
    cam = scene.camera_state(r.camera_path, r.frames[0])
    sscene = static_version(scene)
    windows = visibility_windows(sscene, [cam], infinite=False)
    origin = np.array([cam.time, *cam.position], dtype=np.float64)
    k = get_kernels("float32", "prism")
    geo, _mesh, _bvh, _ = bt.our_tracer(k, sscene, windows, "prism", origin)
    dirs64 = pixel_directions(cam, width, height).reshape(-1, 3)
    n = len(dirs64)
    dirs = wp.array(dirs64.astype(np.float32), dtype=wp.vec3, device="cpu")
    ours, (prim, _s, visits) = bt.probe_launcher(k, geo, dirs)
    pts, tris = bt.scene_triangles(sscene, windows)
    theirs, (face, _t), _kernel = bt.mesh_launcher(pts - cam.position, tris, dirs)
    return n, ours, theirs, {"prim": prim, "visits": visits, "face": face}


def band_range(band, bands, width, height):
    return band * height // bands * width, (band + 1) * height // bands * width


def band_table(scene, width, height, bands, runs):
    """Rows (band, ours ns/ray, wp.Mesh ns/ray, hit fraction, wide visits/ray)."""
    n, ours, theirs, out = tracers(scene, width, height)

    def ns_per_ray(fn, a, b):
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            fn(a, b)
            times.append(time.perf_counter() - t0)
        return statistics.median(times) / (b - a) * 1e9

    ours(0, n)  # warm-up: compile or load, first touch
    theirs(0, n)
    rows = []
    for band in range(bands):
        a, b = band_range(band, bands, width, height)
        if b <= a:
            continue
        x, y = ns_per_ray(ours, a, b), ns_per_ray(theirs, a, b)
        hit = out["prim"].numpy()[a:b] >= 0
        if not np.array_equal(hit, out["face"].numpy()[a:b] >= 0):
            raise RuntimeError(f"band {band}: our tracer and wp.Mesh disagree on which rays hit")
        rows.append((band, x, y, float(hit.mean()), float(out["visits"].numpy()[a:b].mean())))
    return rows


def main(argv=None) -> int:
    args = parse_args(argv)
    import warp_st

    scene = load_parade() if args.scene == "parade" else warp_st.load(str(bt.ROOT / bt.SHIPPED[args.scene]))
    if args.only:
        n, ours, theirs, _out = tracers(scene, args.width, args.height)
        a, b = band_range(args.band, args.bands, args.width, args.height)
        fn = ours if args.only == "ours" else theirs
        fn(0, n)  # warm-up
        for _ in range(args.runs):
            fn(a, b)
        return 0
    rows = band_table(scene, args.width, args.height, args.bands, args.runs)
    print(f"{args.scene} static copy, {args.width}x{args.height}, {args.bands} bands, median of {args.runs}, 1 thread; "
          f"CPU: {cpu_model()}")
    print("| band | ours ns/ray | wp.Mesh ns/ray | ours / wp.Mesh speed | hits | wide visits/ray |")
    print("|---|---|---|---|---|---|")
    for band, x, y, hit, vis in rows:
        print(f"| {band} | {x:.1f} | {y:.1f} | {y / x:.2f} | {hit:.2f} | {vis:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
