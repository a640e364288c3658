"""``warp-st validate``: every problem of a stage, one line each (``warp_st.usd.validators``).

Output (stdout): ``SEVERITY file[:prim[.attribute]]: message`` per problem, in stage
order, then a summary line; ``--json`` prints one JSON object instead. Exit 0 when
there is no error (warnings allowed), 2 when there is one (with one line
``warp-st: error: ...`` on stderr, as for any bad input), 1 on an internal error.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from warp_st.commands.common import PROG, UsageError, stage_light_speed_arg
from warp_st.commands.load import (
    _address_space_cap,
    _probe_in_child,
    _uses_crate_layers,
)


def add_arguments(parser) -> None:
    """The options of ``warp-st validate``."""
    parser.add_argument("scene", metavar="SCENE.usda")
    parser.add_argument("--no-references", action="store_true",
                        help="compose only the file's own layers: ignore references and payloads")
    parser.add_argument("--json", action="store_true", help="print the problems as one JSON object")
    parser.add_argument("--light-speed", type=stage_light_speed_arg, metavar="C",
                        help="the stage's speed of light, as render's --light-speed (e.g. 30m/s, 2units/timecode)")



def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def run(args) -> int:
    from warp_st.core.limits import default_max_memory
    from warp_st.core.native_output import captured_output
    from warp_st.usd.stage import _open_file
    from warp_st.usd.validators import counts, validate_stage

    scene_path = Path(args.scene)
    if not scene_path.is_file():
        raise UsageError(f"{scene_path}: no such file")
    if _uses_crate_layers(scene_path):  # a crash in USD's crate reader becomes a SceneError
        _probe_in_child(scene_path, args.no_references, default_max_memory())
    label = str(scene_path)
    # USD's own printout is dropped: what it reports (composition errors, material
    # bindings) is listed by the built-in validators.
    with captured_output(), _address_space_cap(default_max_memory()):
        stage, _ = _open_file(label, args.no_references)
        problems, scene = validate_stage(stage, label, no_references=args.no_references, light_speed=args.light_speed)
    if scene is not None:
        problems = list(problems) + _animation_problems(scene, label)
    n = counts(problems)
    if scene is not None:
        contents = f"{len(scene.bodies)} bodies, {len(scene.cameras)} cameras, {len(scene.lights)} lights"
    else:
        contents = None
    verdict = "ok" if n["error"] == 0 else "invalid"
    summary = f"{label}: {verdict}: {_plural(n['error'], 'error')}, {_plural(n['warning'], 'warning')}"
    if contents:
        summary += f"; {contents}"
    if args.json:
        print(json.dumps({"file": label, "ok": n["error"] == 0, "errors": n["error"], "warnings": n["warning"],
                          "problems": [p.as_dict() for p in problems]}, indent=2))
    else:
        for problem in problems:
            print(problem.line())
        print(summary)
    if n["error"]:
        sys.stdout.flush()
        print(f"{PROG}: error: {label}: {_plural(n['error'], 'error')} (listed above)", file=sys.stderr)
        return 2
    return 0


def _animation_problems(scene, label: str) -> list:
    """INFO per animated body (docs/spec.md §2.1): samples, speed range and the motion
    segments it renders as through the scene's camera at its resolution, over the
    stage's time codes (at most 101 frames of them, evenly spread); and per animated
    light (§3.4): samples and speed range."""
    import functools

    import numpy as np

    from warp_st.core.conventions import DEFAULT_RESOLUTION, LightSpeed
    from warp_st.core.scene import SceneError
    from warp_st.rendering.renderer import DEFAULT_MAX_DEPTH
    from warp_st.spacetime.animation import animation_report
    from warp_st.spacetime.reach import motion_reach
    from warp_st.usd.light_motion import light_report
    from warp_st.usd.validators import Problem

    lights = [Problem("info", label, path, None, text, "animation") for path, text in light_report(scene.lights)]
    if not any(b.motion is not None for b in scene.bodies):
        return lights
    width, height = scene.settings.resolution or DEFAULT_RESOLUTION
    start, end = scene.frame_range or (0.0, 0.0)
    try:
        cameras = [scene.camera_state(None, float(f)) for f in np.linspace(start, end, min(101, int(end - start) + 1))]
    except SceneError:  # listed as the camera's own error
        cameras = []
    # the chunks of the motion those frames reach (spacetime/reach.py), as the renderer cuts them
    reach = functools.partial(motion_reach, cameras=cameras, max_depth=DEFAULT_MAX_DEPTH if scene.settings.max_depth
                              is None else int(scene.settings.max_depth),
                              infinite_modes=[LightSpeed(c.light_speed) == LightSpeed.INFINITE for c in cameras])
    return [Problem("info", label, path, None, text, "animation")
            for path, text in animation_report(scene, cameras, width=width, height=height, reach=reach,
                                               worldlines=True)] + lights  # as the default render traces them
