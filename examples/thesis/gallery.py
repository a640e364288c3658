"""Render the thesis figures for ``docs/thesis.md`` with the command line, as PNGs.

Each figure is one ``warp-st render`` of a scene in ``usd_scenes/thesis/`` followed by
``warp-st inspect OUT.exr --channel RGB --png docs/images/thesis_NAME.png``; the exact
commands are printed (and are the ones quoted in docs/thesis.md).

    python examples/thesis/gallery.py [--out docs/images] [--only NAME ...] [--dry-run]
"""
from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
S = "usd_scenes/thesis"
OBS = "/World/Observers"

# name: (scene, render options, channel). The stage views are 321 pixels wide so that a
# pixel centre lies on the green line x = 0 (the camera is at x = 0): the bars are 1/20
# wide, about one pixel, and an even width would put that line exactly between pixels.
FIGURES = {
    # Figs. 4.7-4.8: the flange at 0.00866c, frames 920 and 1151
    "fig4_7_flange_frame920": (f"{S}/flange_slow.usda", "--frame 920 --width 321 --height 241", "RGB"),
    "fig4_8_flange_frame1151": (f"{S}/flange_slow.usda", "--frame 1151 --width 321 --height 241", "RGB"),
    # Figs. 4.14-4.15 with the no-delay view (Fig. 4.6's three models): infinite c / classical / relativistic
    "fig4_6_flange_0866c_infinite": (f"{S}/flange_0866c_decoupled.usda",
                                     "--frame 0 --camera /World/CameraNoDelay --width 321 --height 241", "RGB"),
    "fig4_14_flange_0866c_decoupled": (f"{S}/flange_0866c_decoupled.usda", "--frame 0 --width 321 --height 241", "RGB"),
    "fig4_15_flange_0866c_coupled": (f"{S}/flange_0866c_coupled.usda", "--frame 0 --width 321 --height 241", "RGB"),
    "fig4_15_flange_0866c_coupled_infinite": (f"{S}/flange_0866c_coupled.usda",
                                              "--frame 0 --camera /World/CameraNoDelay --width 321 --height 241", "RGB"),
    "fig4_15_flange_0866c_coupled_eventTime": (f"{S}/flange_0866c_coupled.usda", "--frame 0 --width 321 --height 241",
                                               "spacetime.eventTime"),
    # Figs. 2.1-2.2
    "fig2_1_sphere_cubes_rest": (f"{S}/sphere_and_cubes.usda", "--frame 0 --width 320 --height 180", "RGB"),
    "fig2_2_sphere_cubes_0866c": (f"{S}/sphere_and_cubes_moving.usda", "--frame 0 --width 320 --height 180", "RGB"),
    "fig2_2_sphere_cubes_0866c_telescope": (f"{S}/sphere_and_cubes_moving.usda",
                                            "--frame 0 --camera /World/Telescope --width 320 --height 180", "RGB"),
}
# Figs. 4.10-4.13: the observers of aberration.usda
for _name in ["Rest"] + [f"{d}_{s}_{m}" for s in ("0500", "0866") for m in ("Classical", "Relativistic")
                         for d in ("Towards", "Left", "Away", "Right")]:
    FIGURES[f"aberration_{_name}"] = (f"{S}/aberration.usda", f"--camera {OBS}/{_name}/Camera --width 240 --height 240",
                                      "RGB")


def commands(name: str, out_dir: str, tmp: str) -> list[str]:
    scene, opts, channel = FIGURES[name]
    exr = f"{tmp}/thesis_{name}.exr"
    return [f"warp-st render {scene} {opts} -o {exr} --quiet",
            f"warp-st inspect {exr} --channel {channel} --png {out_dir}/thesis_{name}.png"]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/images", help="PNG directory (relative to the repository root)")
    parser.add_argument("--only", nargs="*", default=None, help="figure names (default: all)")
    parser.add_argument("--dry-run", action="store_true", help="print the commands only")
    args = parser.parse_args(argv)
    names = args.only or list(FIGURES)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            for cmd in commands(name, args.out, tmp):
                print(cmd.replace(tmp, "/tmp"))
                if args.dry_run:
                    continue
                argv_ = shlex.split(cmd)
                argv_ = [sys.executable, "-m", "warp_st"] + argv_[1:]  # the checkout's package, installed or not
                env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
                res = subprocess.run(argv_, cwd=ROOT, env=env, capture_output=True, text=True)
                if res.returncode != 0:
                    print(res.stdout + res.stderr, file=sys.stderr)
                    return res.returncode
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
