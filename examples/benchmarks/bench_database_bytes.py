#!/usr/bin/env python3
"""Issue 17's bytes per triangle: what the rigid database of a static scene holds, table by table.

A benchmark, not a test: it asserts nothing. The scene is ``bench_two_level.py``'s
first-render one (16 spheres of 256 longitudes, 1,040,384 triangles, at rest; all 16
one shape, instanced), or with ``--distinct`` the same spheres each of its own radius
(16 shapes: no instancing). The count is ``rendering.database_bytes.rigid_tables`` after
one render (every host and device table, the bottom levels' own: accel/blas.py); as a
check of it, the process's resident memory growth over the renderer's
construction (kernels compiled and loaded before, by a small scene's render; glibc's
MALLOC_MMAP_THRESHOLD_=65536, set here when absent, returns freed temporaries to the
system, so the RSS is what is held, not the build's peak).

    python3 examples/benchmarks/bench_database_bytes.py
    python3 examples/benchmarks/bench_database_bytes.py --distinct --segments 128
"""
from __future__ import annotations

import argparse
import gc
import os
import resource
import sys
from pathlib import Path


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1]))


def rss_bytes() -> int:
    """The process's resident memory now (/proc/self/statm), bytes."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def scene(segments: int, distinct: bool):
    from bench_two_level import spheres_scene
    from benchlib.scenes import distinct_shapes

    s = spheres_scene(segments, moving=False)
    return distinct_shapes(s) if distinct else s


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--segments", type=int, default=256, help="sphere longitudes (default 256: 1.04M triangles)")
    p.add_argument("--distinct", action="store_true", help="16 shapes instead of one instanced")
    p.add_argument("--size", type=int, default=64, help="image width and height (default 64)")
    args = p.parse_args(argv)
    if os.environ.get("MALLOC_MMAP_THRESHOLD_") is None:
        # glibc otherwise keeps freed large temporaries in the heap: the RSS would count
        # the build's peak, not what is held. With a fixed threshold they go back.
        os.environ["MALLOC_MMAP_THRESHOLD_"] = "65536"
        os.execv(sys.executable, [sys.executable, *sys.argv])
    from bench_two_level import cpu_model

    from warp_st.rendering.database_bytes import rigid_tables, total_bytes
    from warp_st.rendering.renderer import Renderer, init_warp

    init_warp()
    Renderer(scene(8, False), frames=[0.0], width=8, height=8).render(0.0)  # kernels compiled and loaded
    sc = scene(args.segments, args.distinct)
    tris = sum(b.triangle_count for b in sc.bodies)
    gc.collect()
    before, peak_before = rss_bytes(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    r = Renderer(sc, frames=[0.0], width=args.size, height=args.size)
    gc.collect()
    grown = rss_bytes() - before
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - max(peak_before, before)
    r.render(0.0)
    tables = rigid_tables(r.database)
    total = total_bytes(tables)
    verts = sum(len(s.points) for b in sc.bodies for s in b.surfaces)
    print(f"CPU: {cpu_model()}; {tris:,} triangles, {verts:,} vertices, "
          f"{r.database.bottom.count} bottom level(s), {args.size}x{args.size}")
    print()
    print("| table | dtype | rows | bytes | B/tri |")
    print("|---|---|---|---|---|")
    for t in tables:
        print(f"| {t.name} | {t.dtype} | {t.rows:,} | {t.nbytes:,} | {t.nbytes / tris:.1f} |")
    print(f"| **database, counted** | | | {total:,} | **{total / tris:.1f}** |")
    print(f"| RSS growth over the construction | | | {grown:,} | {grown / tris:.1f} |")
    print(f"| peak RSS growth over the construction | | | {max(peak, 0):,} | {max(peak, 0) / tris:.1f} |")
    del r
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
