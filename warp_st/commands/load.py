"""Loading a stage from the command line: USD's diagnostics held back, corrupt crate files read
in a child process first, memory capped while reading."""
from __future__ import annotations

import contextlib
import os
import re
import sys
from pathlib import Path

from warp_st.core.native_output import held_diagnostics
from warp_st.core.scene import SceneError
from warp_st.usd.camera import NOTHING_TO_RENDER


@contextlib.contextmanager
def _address_space_cap(budget: int | None):
    """Lower the soft RLIMIT_AS to the current size + ``budget`` for the block (Linux).

    A corrupt .usdc can make USD's crate reader allocate and touch tens of GiB (the
    fuzzer found one that drew the OOM killer); under the cap the allocation fails and
    USD reports the file as corrupt instead. Restored afterwards; a no-op where
    unsupported.
    """
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        with open("/proc/self/statm") as fh:
            current = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (ImportError, OSError, ValueError, AttributeError):
        yield
        return
    cap = current + int(budget) if budget else None
    if cap is None or (soft != resource.RLIM_INFINITY and soft <= cap) or (
            hard != resource.RLIM_INFINITY and hard < cap):
        yield
        return
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


_CRATE_MAGIC = b"PXR-USDC"
_ASSET = re.compile(rb"@([^@\n]+)@")


def _uses_crate_layers(path: Path, depth: int = 0, seen: set | None = None) -> bool:
    """True if ``path`` or a layer its text names (transitively, 16 deep) is a binary crate file."""
    seen = set() if seen is None else seen
    try:
        path = path.resolve()
        if path in seen or depth > 16 or not path.is_file():
            return False
        seen.add(path)
        with open(path, "rb") as fh:
            data = fh.read(64 << 20)
    except (OSError, ValueError):  # unreadable, or a name with a NUL byte
        return False
    if data.startswith(_CRATE_MAGIC):
        return True
    for match in _ASSET.finditer(data):
        name = match.group(1).decode("utf-8", "replace")
        if _uses_crate_layers(path.parent / name, depth + 1, seen):
            return True
    return False


_PROBE = """
import resource, sys
budget = int(sys.argv[3])
if budget:
    try:
        resource.setrlimit(resource.RLIMIT_AS, (budget, resource.getrlimit(resource.RLIMIT_AS)[1]))
    except (ValueError, OSError):
        pass
import warp_st
try:
    warp_st.load(sys.argv[1], no_references=sys.argv[2] == "1")
except Exception:
    sys.exit(3)
"""


def _probe_in_child(scene_path: Path, no_references: bool, budget: int | None) -> None:
    """Read the stage once in a child process before reading it here.

    USD's binary (crate) reader can crash on a corrupt file (the fuzzer found
    segmentation faults inside ``Usd.Stage.Open``); a crash of the child becomes a
    SceneError instead of taking this process down. Errors the child reports are left
    for the in-process read to report with its usual message.
    """
    import signal
    import subprocess

    import warp_st

    env = dict(os.environ)
    package_root = str(Path(warp_st.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    cap = str(int(budget) if budget else 0)  # a runaway read aborts the child, not the machine
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE, str(scene_path), "1" if no_references else "0", cap],
                              env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, timeout=600)
    except subprocess.TimeoutExpired:
        raise SceneError(f"{scene_path}: reading it did not finish in 600 s; the file may be corrupt") from None
    except OSError:
        return  # no child processes here: read in-process as before
    if proc.returncode < 0:
        name = signal.Signals(-proc.returncode).name if -proc.returncode in signal.valid_signals() else str(-proc.returncode)
        raise SceneError(f"{scene_path}: USD crashed reading it ({name}): the file or a binary layer it uses "
                         "is corrupt")


def load(scene_path: Path, no_references: bool, max_memory: int | None = None, light_speed=None,
         camera: str | None = None, frames=None):
    """warp_st.load with its diagnostics held back (see held_diagnostics) and its
    memory capped (see _address_space_cap); stages with binary layers are first read
    in a child process (see _probe_in_child). The run's ``camera`` (None: the stage's) is
    evaluated at each of its ``frames`` (None: the stage's start, else 0) inside the block
    too: a bad camera attribute, or an animated camera at >= c at a later frame, is then
    the run's one error line, not a line after the stage's warnings (docs/spec.md §6)."""
    import warp_st
    from warp_st.core.limits import default_max_memory

    if _uses_crate_layers(scene_path):
        _probe_in_child(scene_path, no_references, default_max_memory())

    # Reading needs far less than rendering; the cap only stops runaway reads. (A low cap
    # is worse than none: USD aborts on some failed allocations instead of reporting them.)
    budget = max(filter(None, (max_memory, default_max_memory())), default=None)
    with held_diagnostics(), _address_space_cap(budget):
        try:
            scene = warp_st.load(str(scene_path), no_references=no_references, light_speed=light_speed)
        except MemoryError:
            raise SceneError(f"{scene_path}: reading it needs more memory than the limit "
                             "(--max-memory); the file may be corrupt") from None
        if any(d.code == "NothingToRender" for d in scene.diagnostics):  # one error line only
            raise SceneError(f"{scene_path}: {NOTHING_TO_RENDER}")
        if not frames:
            frames = [float(scene.frame_range[0]) if scene.frame_range is not None else 0.0]
        for frame in frames:
            scene.camera_state(camera, frame)
    return scene
