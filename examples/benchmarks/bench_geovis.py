#!/usr/bin/env python3
"""Speed against error on GeoViS's own scene (issue 19): exact quadrics and tessellation.

A benchmark, not a test: it asserts nothing. GeoViS's scene: a unit sphere at 0.9c, the
observer at rest at (t = 10; 0, -10, -1) looking along +Y, 40° field of view, 512². For
each way of rendering it (float32 / float64, exact / tessellated quadrics) it prints the
warm frame time (median of ``--runs``, ``Renderer.render``), the silhouette pixels whose
hit or miss differs from the closed form (``warp_st.core.lorentz.sphere_hit`` at the float64
pixel-centre rays) and the event-time error, median and max, over the pixels both hit.

    python3 examples/benchmarks/bench_geovis.py            # 512 x 512, 5 runs
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench_two_level import cpu_model  # noqa: E402  (the same CPU line as the other tables)


def geovis_scene(width: int, height: int):
    from warp_st.core import tessellate
    from warp_st.core.scene import Body, CameraState, Surface
    from warp_st.testing import synthetic_scene

    h_ap = 20.955
    cam = CameraState("/Camera", 10.0, np.array([0.0, -10.0, -1.0]),
                      np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
                      focal_length=0.5 * h_ap / math.tan(math.radians(20.0)), horizontal_aperture=h_ap,
                      vertical_aperture=h_ap * height / width)
    pts, tris, nrm = tessellate.sphere(1.0)
    surf = Surface("/Ball", pts, tris, normals=nrm, sphere=(1.0, np.eye(4)))
    body = Body("/Ball", (surf,), np.zeros(3), np.array([0.9, 0.0, 0.0]), 0.0, (-math.inf, math.inf))
    return synthetic_scene("geovis", [body], [], cam), cam


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--size", type=int, default=512)
    args = p.parse_args(argv)
    from warp_st.core import lorentz
    from warp_st.rendering.camera import pixel_directions
    from warp_st.rendering.renderer import Renderer, init_warp

    init_warp()
    w = h = args.size
    scene, cam = geovis_scene(w, h)
    dirs = pixel_directions(cam, w, h).reshape(-1, 3)
    exact = lorentz.sphere_hit(cam.time, cam.position, dirs, np.zeros(3), 1.0, np.array([0.9, 0.0, 0.0]), 0.0)
    truth = exact.event_time.reshape(h, w)
    rows = []
    for precision, quadrics in (("float32", "exact"), ("float32", "tessellated"), ("float64", "exact"),
                                ("float64", "tessellated")):
        r = Renderer(scene, frames=[cam.time], width=w, height=h, precision=precision, quadrics=quadrics)
        img = r.render(cam.time)
        times = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            img = r.render(cam.time)
            times.append(time.perf_counter() - t0)
        hit, want = img.object_id > 0, np.isfinite(truth)
        both = hit & want
        err = np.abs(img.event_time[both] - truth[both])
        rows.append((precision, quadrics, r.primitive, 1e3 * statistics.median(times), int((hit != want).sum()),
                     float(np.median(err)), float(err.max())))
        print(f"  {precision} {quadrics}: {rows[-1][3]:.1f} ms", file=sys.stderr, flush=True)
    print(f"CPU: {cpu_model()}; GeoViS's scene at {w}x{h}; medians of {args.runs} warm frames")
    print()
    print("| precision | quadrics | path | frame ms | silhouette pixels wrong | event-time error median | max |")
    print("|---|---|---|---|---|---|---|")
    for precision, quadrics, path, ms, wrong, med, mx in rows:
        print(f"| {precision} | {quadrics} | {path} | {ms:.1f} | {wrong} | {med:.2g} | {mx:.2g} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
