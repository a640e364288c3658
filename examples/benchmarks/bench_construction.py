#!/usr/bin/env python3
"""Construction of a new scene's rigid database, by process CPU time (a benchmark, not a test).

Times, medians of ``--runs``: ``rigid_shapes`` (shapes and shading tables), the bottom
levels (``accel.blas.bottom_levels``) and a whole ``Renderer`` for frames 0 and 10,000 at
512 x 512 (shapes, bottom levels, windows, segments, top level, device arrays), each on a
new Scene object, for the two scenes of ``bench_two_level.py``: 16 spheres of 16k
triangles at 0.3-0.9c (its "sequence" table) and 16 spheres of 65k at rest (its "first"
table). Process CPU time, not wall time, so that another job on the machine changes it
little: run it in two checkouts to compare them (docs/design/two-level.md).

    python3 examples/benchmarks/bench_construction.py --runs 7
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
for _path in (HERE, HERE.parents[1]):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=7)
    args = p.parse_args(argv)
    import bench_two_level as b

    from warp_st.accel.blas import bottom_levels
    from warp_st.rendering.renderer import Renderer, init_warp
    from warp_st.spacetime.shape_tables import rigid_shapes

    init_warp()
    print(f"CPU: {b.cpu_model()}; process CPU time, medians of {args.runs} runs")
    print()
    print("| scene | shapes ms | bottom levels ms | whole construction ms |")
    print("|---|---|---|---|")
    for label, segments, moving in (("16 spheres x 16k triangles at 0.3-0.9c", 128, True),
                                    ("16 spheres x 65k triangles at rest", 256, False)):
        scene = b.spheres_scene(segments, moving=moving)
        Renderer(dataclasses.replace(scene), frames=[0.0], width=64, height=64)  # kernels loaded
        times = {"shapes": [], "bottom": [], "whole": []}
        for _ in range(args.runs):
            c0 = time.process_time()
            shapes = rigid_shapes(dataclasses.replace(scene))
            c1 = time.process_time()
            bottom_levels(shapes)
            c2 = time.process_time()
            Renderer(dataclasses.replace(scene), frames=[0.0, 10000.0], width=512, height=512)
            c3 = time.process_time()
            times["shapes"].append(c1 - c0)
            times["bottom"].append(c2 - c1)
            times["whole"].append(c3 - c2)
        print(f"| {label} | " + " | ".join(f"{1e3 * statistics.median(v):.0f}" for v in times.values()) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
