"""Helpers for tests that run ``warp-st`` (in-process or in a child process, interrupted),
and the small stage they render."""
from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

from warp_st.output import exr

ROOT = Path(__file__).resolve().parents[1]


def run(capsys, *argv):
    """``warp-st *argv`` in this process: (exit code, stdout, stderr)."""
    from warp_st.commands.cli import main

    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def moving_body_stage(body: str, *, end_time: int, extra: str = "", vertical_aperture: float | None = None) -> str:
    """A small stage: a camera at (0, 0, 10) looking down -Z, the prim /World/Mover moving at
    0.5c along +x (SpacetimeBodyAPI) holding the gprim text ``body``, a distant light of
    intensity 1, and ``extra`` (more prims under /World); time codes 0 to ``end_time``."""
    aperture = "" if vertical_aperture is None else f"\n        float verticalAperture = {vertical_aperture:g}"
    return f"""#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = {end_time}
)

def Xform "World"
{{
    def Camera "Cam"
    {{
        double3 xformOp:translate = (0, 0, 10)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        float focalLength = 35
        float horizontalAperture = 36{aperture}
    }}

    def Xform "Mover" (
        prepend apiSchemas = ["SpacetimeBodyAPI"]
    )
    {{
        custom double4 spacetime:fourVelocity = (1, 0.5, 0, 0)

        {body}
    }}
{extra}
    def DistantLight "Sun"
    {{
        float inputs:angle = 0
        float inputs:intensity = 3.1415927
    }}
}}
"""


def child_env(**extra) -> dict:
    """The environment of a child ``python -m warp_st``: this checkout, the shared kernel cache."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), **extra)
    env.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))
    env.pop("WARP_ST_DEBUG", None)
    return env


def one_line(err: str) -> str:
    """The single non-empty line of ``err`` (no traceback)."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def no_temp_files(directory: Path) -> None:
    assert not [p.name for p in directory.iterdir() if p.name.endswith(".tmp")]


def resume_renders_the_rest(argv: list[str], folder: Path, before: dict[str, bytes], total: int) -> None:
    """``argv --resume`` skips the complete frames ``before`` (name -> bytes), renders exactly
    the other ones of ``seq.0000.exr`` .. ``seq.<total-1>.exr`` and leaves ``before`` byte-identical."""
    resumed = subprocess.run(argv + ["--resume"], env=child_env(), cwd=str(folder), capture_output=True,
                             text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    skipped = [ln for ln in resumed.stdout.splitlines() if "complete, skipped" in ln]
    rendered = [ln for ln in resumed.stdout.splitlines() if " s -> " in ln]
    assert len(skipped) == len(before) and len(rendered) == total - len(before), resumed.stdout
    assert all(exr.is_complete_exr(folder / f"seq.{f:04d}.exr") for f in range(total))
    assert all((folder / name).read_bytes() == data for name, data in before.items())


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def signal_after(argv: list[str], cwd: Path, ready, sig: signal.Signals, timeout: float = 120.0):
    """Run ``argv`` (a child warp-st), send it ``sig`` once ``ready()`` holds, and return
    (exit code, stderr). Fails if ``ready()`` never held; the child is killed if it
    outlives the test."""
    # The child starts as a terminal's foreground job does, with SIGINT at its default: an
    # ignored disposition in this process (a native library of an earlier test may set one;
    # Python cannot see it) would be inherited across exec and swallow the signal.
    proc = subprocess.Popen(argv, env=child_env(), cwd=str(cwd), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not ready():
            time.sleep(0.005)
        assert ready(), "the child never got far enough to be interrupted"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err
