"""The ``warp-st`` command line (docs/spec.md §6): thin commands over the public API.

    warp-st render SCENE.usda [-o OUT.exr | -o OUT.####.exr] [--frame N | --frames 1-240x2]
                   [--camera /Path] [--width W --height H] [--max-depth D] [--samples S]
                   [--precision float32|float64] [--light-speed finite|infinite]
                   [--resume] [--quiet]
    warp-st inspect OUT.exr [--pixel X Y] [--channel NAME --png OUT.png]
    warp-st validate SCENE.usda
    warp-st bench [NAME [ARGS...]]

Exit status: 0 success; 2 bad input (one line ``warp-st: error: ...`` on stderr, no
traceback, nothing written); 1 internal error (traceback with WARP_ST_DEBUG set);
130 interrupted (the message says which frames are complete).
"""
from __future__ import annotations

import argparse
import os
import sys
import traceback

from warp_st.commands.common import (
    PROG,
    UsageError,
    closed_pipe_status,
    error,
    interrupted_status,
    interruption,
    terminate_as_interrupt,
)
from warp_st.core.frames import expand_output, format_frame, has_frame_pattern, parse_frames
from warp_st.core.scene import SceneError

__all__ = ["main", "build_parser", "parse_frames", "expand_output", "has_frame_pattern", "format_frame"]

class _Parser(argparse.ArgumentParser):
    """argparse that reports errors as one line (no usage block) through UsageError."""

    def error(self, message):  # noqa: D102 - argparse API
        raise UsageError(message)


# --- argument parsing ----------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    from warp_st import __version__
    from warp_st.commands import bench, inspect, render, validate

    parser = _Parser(
        prog=PROG,
        description="Special-relativistic spacetime renderer: USD scenes -> EXR frames.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{render,inspect,validate,bench}")

    r = sub.add_parser("render", help="render frames of a USD scene to EXR files", prog=f"{PROG} render")
    render.add_arguments(r)
    i = sub.add_parser("inspect", help="print an EXR's header, channel statistics or a pixel",
                       prog=f"{PROG} inspect")
    inspect.add_arguments(i)
    v = sub.add_parser("validate", help="load a scene and report what it contains", prog=f"{PROG} validate")
    validate.add_arguments(v)
    b = sub.add_parser("bench", help="run a benchmark script of the source checkout (none: list them)",
                       prog=f"{PROG} bench")
    bench.add_arguments(b)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``warp-st`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    with terminate_as_interrupt():
        try:
            status = _main(argv)
            sys.stdout.flush()  # output that fit the buffer meets a closed pipe only here
        except BrokenPipeError:
            return closed_pipe_status()
    return status


def _main(argv: list[str]) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.command is None:
            raise UsageError("a command is required: render, inspect, validate or bench (see --help)")
        if args.command == "render":
            from warp_st.commands import render

            return render.run(args, argv)
        if args.command == "inspect":
            from warp_st.commands import inspect

            return inspect.run(args)
        if args.command == "bench":
            from warp_st.commands import bench

            return bench.run(args)
        from warp_st.commands import validate

        return validate.run(args)
    except SystemExit as exc:  # --help / --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except UsageError as exc:
        error(str(exc))
        return 2
    except SceneError as exc:
        error(str(exc))
        return 2
    except KeyboardInterrupt as exc:
        print(f"{PROG}: {interruption(exc)}", file=sys.stderr)
        return interrupted_status(exc)
    except BrokenPipeError:  # the reader of stdout went away: main() ends quietly
        raise
    except OSError as exc:  # e.g. disk full while writing: not a bug, not bad input
        error(str(exc))
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1
    except Exception as exc:  # noqa: BLE001 - the last resort of a command line
        print(f"{PROG}: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        if os.environ.get("WARP_ST_DEBUG"):
            traceback.print_exc()
        return 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
