#!/usr/bin/env python3
"""Issue 18's database costs of USD-animated bodies: pieces, bottom levels, build time, memory.

A benchmark, not a test: it asserts nothing. Two tables, the CPU model first:

- examples: each ``examples/animation/*.usda`` in its own process (so peak RSS is its
  own), a ``Renderer`` over frames ``--frames`` (default 0..100) at ``--size``
  (default 640x360): the pieces the animated bodies are cut into, the bottom levels
  (``wp.Mesh`` objects) they use, the database build (the renderer's construction: cuts,
  shapes, bottom and top levels, uploads; kernels cached by a warm-up render first),
  peak RSS, and the median render time of three frames (first, middle, last);
- sequence: the rolling wheel over ``--sequence`` frames spread evenly over its
  animation (time codes 0-100) at 64x36, one ``Renderer`` for them all, every frame
  rendered: databases built (``database_cache.builds()`` around each construction; no
  frame builds another: checked after the frames), construction time and the median
  frame time, against the same wheel held still (its motion dropped), the two rendered
  back to back per frame; the ratio is animated / static per frame (issue 18: within 2x);
- wheel08c: the 0.8c wheel animated in its rest frame (``rolling_wheel_08c.usda``, the
  tetrahedra, leaves of the rigid path) over ``--sequence`` frames from ``--first`` every ``--step`` time codes
  at ``--size``, the same way against the same wheel without its animation (its rotateZ
  samples replaced by 0 and ``spacetime:animationFrame`` dropped: a coupled body at 0.8c on
  the rigid path), and how much of an animated frame is recentring the database on the
  frame's anchor (``rendering/anchor.py``; ``device_rigid.make_rigid_geometry``, the
  tetrahedra's included), per frame on average, and how many recentrings the frames took.

    python3 examples/benchmarks/bench_animation_db.py
    python3 examples/benchmarks/bench_animation_db.py --tables sequence --sequence 1000
    python3 examples/benchmarks/bench_animation_db.py --tables wheel08c --sequence 100 --first 9 --step 0.02 \
        --size 320x180
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchlib.machine import cpu_model  # noqa: E402

EXAMPLES = ("spinning_rod", "circular_orbit", "rolling_wheel")


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def one_example(name: str, frames: list[float], width: int, height: int) -> dict:
    """The examples table's row of ``name`` (run in a fresh process)."""
    import warp_st
    from warp_st.rendering import database_cache
    from warp_st.rendering.renderer import Renderer

    path = ROOT / "examples" / "animation" / f"{name}.usda"
    warp_st.render(warp_st.load(path), frame=frames[0], width=8, height=8)  # kernels compiled and loaded
    database_cache.clear()
    rss_before = _peak_rss_mb()
    scene = warp_st.load(path)
    t0 = time.perf_counter()
    renderer = Renderer(scene, frames=frames, width=width, height=height)
    build = time.perf_counter() - t0
    db = renderer.database
    times = []
    for f in (frames[0], frames[len(frames) // 2], frames[-1]):
        t1 = time.perf_counter()
        renderer.render(f)
        times.append(time.perf_counter() - t1)
    return {"example": name, "pieces": len(db.shapes.bodies), "bottom_levels": db.bottom.count,
            "segments": db.segments.count, "triangles": db.shapes.triangle_count,
            "build_s": build, "bottom_s": db.bottom.build_seconds, "peak_rss_mb": _peak_rss_mb(),
            "rss_before_mb": rss_before, "frame_s": statistics.median(times)}


def sequence(count: int, width: int, height: int) -> dict:
    """The sequence table: the rolling wheel animated against held still."""
    import warp_st
    from warp_st.rendering import database_cache
    from warp_st.rendering.renderer import Renderer

    path = ROOT / "examples" / "animation" / "rolling_wheel.usda"
    frames = [float(f) for f in np.linspace(0.0, 100.0, count, endpoint=False)]
    scene = warp_st.load(path)
    warp_st.render(scene, frame=0.0, width=8, height=8)  # kernels compiled and loaded
    database_cache.clear()
    still = dataclasses.replace(scene, bodies=tuple(dataclasses.replace(b, motion=None) for b in scene.bodies))
    out = {"frames": count, "width": width, "height": height}
    renderers = {}
    for label, sc in (("animated", scene), ("static", still)):
        builds = database_cache.builds()
        t0 = time.perf_counter()
        # primitive="rigid" asked for: the wheel's pieces of uniform motion on one bottom level (what this
        # table measures); by default the wheel is per-vertex worldlines (spacetime/turning.py, Unreleased)
        renderers[label] = Renderer(sc, frames=frames, width=width, height=height, primitive="rigid")
        out[label] = {"builds": database_cache.builds() - builds, "construct_s": time.perf_counter() - t0,
                      "pieces": len(renderers[label].database.shapes.bodies),
                      "bottom_levels": renderers[label].database.bottom.count, "per": []}
    built = database_cache.builds()
    for f in frames:  # both sides back to back per frame: the machine's drift cancels in the ratio
        for label, renderer in renderers.items():
            t1 = time.perf_counter()
            renderer.render(f)
            out[label]["per"].append(time.perf_counter() - t1)
    out["builds_during_frames"] = database_cache.builds() - built
    for label in renderers:
        per = out[label].pop("per")
        out[label].update(frame_median_s=statistics.median(per), frame_mean_s=statistics.fmean(per),
                          total_s=out[label]["construct_s"] + sum(per))
    return out


def wheel_08c(count: int, first: float, step: float, width: int, height: int) -> dict:
    """The wheel08c table: the 0.8c wheel animated in its rest frame against it held still."""
    import re
    import tempfile

    import warp_st
    import warp_st.rendering.device_rigid as device
    from warp_st.rendering import database_cache
    from warp_st.rendering.renderer import Renderer

    path = ROOT / "examples" / "animation" / "rolling_wheel_08c.usda"
    text = re.sub(r"double xformOp:rotateZ\.timeSamples = \{[^}]*\}", "double xformOp:rotateZ = 0", path.read_text())
    still = Path(tempfile.mkdtemp()) / "rolling_wheel_08c_still.usda"
    still.write_text(text.replace('    custom uniform token spacetime:animationFrame = "rest"\n', ""))
    frames = [round(first + i * step, 9) for i in range(count)]
    recentre = []
    make_geometry = device.make_rigid_geometry

    def timed(*args):  # renderer.render imports it from the module at each call
        t = time.perf_counter()
        out = make_geometry(*args)
        recentre.append(time.perf_counter() - t)
        return out

    out, renderers = {}, {}
    for label, stage in (("animated", path), ("static", still)):
        t0 = time.perf_counter()
        scene = warp_st.load(stage)
        load = time.perf_counter() - t0
        builds = database_cache.builds()
        renderers[label] = r = Renderer(scene, frames=frames, width=width, height=height)
        out[label] = {"load_s": load, "construct_s": time.perf_counter() - t0 - load,
                      "builds": database_cache.builds() - builds, "primitive": r.primitive,
                      "tets": r.stats.tetrahedra, "per": []}
    device.make_rigid_geometry = timed
    built = database_cache.builds()
    for f in frames:
        for label, renderer in renderers.items():
            t1 = time.perf_counter()
            renderer.render(f)
            out[label]["per"].append(time.perf_counter() - t1)
    device.make_rigid_geometry = make_geometry
    out["builds_during_frames"] = database_cache.builds() - built
    for label in renderers:
        per = out[label].pop("per")
        out[label].update(frame_median_s=statistics.median(per), first_half_s=statistics.median(per[:count // 2]),
                          second_half_s=statistics.median(per[count // 2:]))
    out["recentre_per_frame_s"] = sum(recentre) / count
    out["recentrings"] = len(recentre)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", default="examples,sequence")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--frames", default="0:100", help="first:last time codes, every integer")
    ap.add_argument("--sequence", type=int, default=1000, help="frames of the wheel sequence")
    ap.add_argument("--first", type=float, default=0.0, help="wheel08c: the first time code")
    ap.add_argument("--step", type=float, default=0.02, help="wheel08c: time codes between frames")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    width, height = (int(x) for x in args.size.split("x"))
    first, last = (int(x) for x in args.frames.split(":"))
    frames = [float(f) for f in range(first, last + 1)]
    if args.child:
        print(json.dumps(one_example(args.child, frames, width, height)))
        return
    print(f"CPU: {cpu_model()}")
    tables = args.tables.split(",")
    if "examples" in tables:
        print(f"\nexamples/animation at {width}x{height}, frames {first}..{last}")
        print("| example | pieces | bottom levels | triangles | segments | database build s | of it wp.Mesh s "
              "| peak RSS MB | frame s |")
        print("|---|---|---|---|---|---|---|---|---|")
        for name in EXAMPLES:
            res = subprocess.run([sys.executable, __file__, "--child", name, "--size", args.size,
                                  "--frames", args.frames], capture_output=True, text=True, check=True)
            r = json.loads(res.stdout.strip().splitlines()[-1])
            print(f"| {name} | {r['pieces']:,} | {r['bottom_levels']:,} | {r['triangles']:,} | {r['segments']:,} "
                  f"| {r['build_s']:.2f} | {r['bottom_s']:.2f} | {r['peak_rss_mb']:.0f} | {r['frame_s']:.3f} |",
                  flush=True)
    if "sequence" in tables:
        r = sequence(args.sequence, 64, 36)
        a, s = r["animated"], r["static"]
        print(f"\nrolling wheel, {r['frames']} frames over time codes 0-100 at 64x36, one Renderer")
        print("| wheel | databases built | bottom levels | construction s | frame median ms | frame mean ms "
              "| total s |")
        print("|---|---|---|---|---|---|---|")
        for label, x in (("animated", a), ("held still", s)):
            print(f"| {label} | {x['builds']} | {x['bottom_levels']:,} | {x['construct_s']:.2f} "
                  f"| {1e3 * x['frame_median_s']:.2f} | {1e3 * x['frame_mean_s']:.2f} | {x['total_s']:.1f} |")
        print(f"per frame animated / static: median {a['frame_median_s'] / s['frame_median_s']:.2f}x, "
              f"mean {a['frame_mean_s'] / s['frame_mean_s']:.2f}x; whole sequence {a['total_s'] / s['total_s']:.2f}x; "
              f"databases built while rendering the frames: {r['builds_during_frames']}")
    if "wheel08c" in tables:
        r = wheel_08c(args.sequence, args.first, args.step, width, height)
        print(f"\n0.8c wheel (rest frame), {args.sequence} frames from {args.first:g} every {args.step:g} at "
              f"{width}x{height}, one Renderer each (kernels compiled in the first frame)")
        print("| wheel | path | tetrahedra | databases built | load s | construction s | frame median ms "
              "| first / second half ms |")
        print("|---|---|---|---|---|---|---|---|")
        for label, x in (("animated", r["animated"]), ("static", r["static"])):
            print(f"| {label} | {x['primitive']} | {x['tets']:,} | {x['builds']} | {x['load_s']:.2f} "
                  f"| {x['construct_s']:.2f} | {1e3 * x['frame_median_s']:.1f} "
                  f"| {1e3 * x['first_half_s']:.1f} / {1e3 * x['second_half_s']:.1f} |")
        print(f"per frame animated / static: {r['animated']['frame_median_s'] / r['static']['frame_median_s']:.1f}x; "
              f"recentring the databases per frame (mean): {1e3 * r['recentre_per_frame_s']:.1f} ms "
              f"({r['recentrings']} recentrings); "
              f"databases built while rendering the frames: {r['builds_during_frames']}")


if __name__ == "__main__":
    main()
