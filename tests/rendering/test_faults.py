"""Faults, limits, reproducibility and untrusted stages (issue: bad input and faults).

Laws:

- Resource limits: the tetrahedron and vertex counts are known before anything big is
  allocated and equal what the build makes; a render whose estimate exceeds
  ``--max-memory`` / ``max_memory=`` is refused with a SceneError (exit 2) giving the
  count and the estimate, and nothing is built or written. The estimate bounds the
  measured host peak of the build.
- Output faults: a full disk (a real 192 KiB tmpfs where this process may mount one, else
  a writer that fails with ENOSPC midway), a read-only directory and a SIGKILL while a large
  EXR is being written never leave a partial file under the final name and never replace
  an earlier good frame. SIGTERM in the middle of a sequence stops with one line naming
  the complete frames and exit 143; ``--resume`` then renders exactly the missing ones.
- Reproducibility: the same stage, options and version give bit-identical EXR files
  across processes (different hash seeds) and with 1 or 2 threads; the header records
  the version, the options, the stage path and the sha256 of its root layer, and no time.
- Untrusted stages: ``--no-references`` renders a stage whose references are missing or
  point elsewhere, from its own layer only; reading a stage never loads code from it.
"""
from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import child_env, moving_body_stage, no_temp_files, one_line, resume_renders_the_rest, signal_after

import warp_st
from warp_st.commands import cli
from warp_st.core import limits
from warp_st.core.scene import SceneError
from warp_st.output import exr
from warp_st.output.film import Image
from warp_st.rendering import budget
from warp_st.rendering.renderer import Renderer

ROOT = Path(__file__).resolve().parents[2]

SCENE = moving_body_stage('def Sphere "Ball"\n        {\n            double radius = 1\n        }', end_time=40, extra="""
    def Cube "Block"
    {
        double size = 1.5
        double3 xformOp:translate = (-2, -1, -2)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
""")


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "scene.usda"
    path.write_text(SCENE)
    return path


def run(capsys, *argv) -> tuple[int, str, str]:
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# --- resource limits ---------------------------------------------------------------------


@pytest.mark.parametrize("frames", [[0.0], [0.0, 20.0, 40.0]])
def test_count_before_build_equals_the_build(scene_file, frames):
    """The cheap count (windows -> body_slices -> 3 T K per body) is exactly the database
    the build makes, so the estimate is computed from the real numbers."""
    scene = warp_st.load(str(scene_file))
    r = Renderer(scene, frames=frames, width=16, height=12, primitive="prism")
    assert r.stats.tetrahedra > 0
    assert r.memory_estimate == budget.estimate_bytes(r.stats.tetrahedra, len(r.mesh.vertices), 16 * 12)


@pytest.mark.parametrize("frames", [[0.0], [0.0, 20.0, 40.0]])
def test_rigid_estimate_counts_triangles_whatever_the_frames(scene_file, frames):
    """The rigid (two-level) database holds each triangle once at rest: its estimate is
    the scene's triangles and vertices, the same for one frame or a span of them."""
    scene = warp_st.load(str(scene_file))
    r = Renderer(scene, frames=frames, width=16, height=12)
    assert r.primitive == "rigid" and r.stats.triangles == r.database.shapes.triangle_count > 0
    vertices = len(r.database.shapes.vertex_normals)
    assert r.memory_estimate == budget.estimate_rigid_bytes(r.stats.triangles, vertices, 16 * 12)
    assert r.memory_estimate == Renderer(scene, frames=[0.0], width=16, height=12).memory_estimate


def test_estimate_bounds_the_measured_peak(tmp_path):
    """The host memory traced during a build (NumPy: extrusion, boxes, BVH) stays below the
    estimate, and the estimate is not wildly pessimistic (< 2x)."""
    bodies = "".join(
        f'def Xform "B{i}" (\n prepend apiSchemas = ["SpacetimeBodyAPI"]\n)\n{{\n'
        f"double3 xformOp:translate = ({i * 0.3}, 0, 0)\nuniform token[] xformOpOrder = [\"xformOp:translate\"]\n"
        f"custom double4 spacetime:fourVelocity = (1, 0.9, 0, 0)\ndef Sphere \"S\"\n{{\n}}\n}}\n"
        for i in range(16)
    )
    path = tmp_path / "many.usda"
    path.write_text(SCENE.split('def Xform "World"')[0] + 'def Camera "Cam"\n{\ndouble3 xformOp:translate = '
                    '(0, 0, 10)\nuniform token[] xformOpOrder = ["xformOp:translate"]\n}\n' + bodies)
    scene = warp_st.load(str(path))
    Renderer(scene, frames=[0.0], width=8, height=6, primitive="prism")  # kernels compiled outside the measurement
    tracemalloc.start()
    try:
        r = Renderer(scene, frames=[float(f) for f in range(0, 21, 2)], width=8, height=6, primitive="prism")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert r.stats.tetrahedra > 20_000
    assert peak <= r.memory_estimate < 2 * peak, (peak, r.memory_estimate)


def test_max_memory_refuses_before_allocating(scene_file, monkeypatch):
    """Renderer(max_memory=) below the estimate: SceneError with the count and the estimate,
    and the extrusion is never called."""
    import warp_st.rendering.renderer as renderer_module

    scene = warp_st.load(str(scene_file))
    called = []
    monkeypatch.setattr(renderer_module, "build_database", lambda *a: called.append(a))
    with pytest.raises(SceneError) as info:
        Renderer(scene, frames=[0.0], width=8, height=6, max_memory=64 * 1024, primitive="prism")
    text = str(info.value)
    assert scene_file.name in text and "tetrahedra" in text and "memory limit of 64.0 KiB" in text, text
    assert "/World/Mover" in text  # the largest body
    assert not called


def test_max_memory_cli_exit_2_and_nothing_written(scene_file, tmp_path, capsys):
    out = tmp_path / "out.exr"
    # The rigid database of this scene needs ~19 KiB at 8 x 6 pixels.
    code, _, err = run(capsys, "render", scene_file, "-o", out, "--width", 8, "--height", 6, "--max-memory", "16K")
    line = one_line(err)
    assert code == 2 and scene_file.name in line and "triangles" in line and "KiB" in line, err
    assert not out.exists()
    code, _, err = run(capsys, "render", scene_file, "-o", out, "--max-memory", "lots")
    assert code == 2 and "--max-memory" in one_line(err)
    code, _, err = run(capsys, "render", scene_file, "-o", out, "--width", 8, "--height", 6, "--max-memory", "1G")
    assert code == 0 and out.exists(), err


def test_sizes_and_default_limit():
    assert limits.parse_size("8G") == 8 << 30
    assert limits.parse_size("512M") == 512 << 20
    assert limits.parse_size("1.5GiB") == 3 << 29
    assert limits.parse_size("1000") == 1000
    for bad in ("", "-1G", "8X", "0", "G"):
        with pytest.raises(ValueError):
            limits.parse_size(bad)
    default = limits.default_max_memory()
    physical = limits.physical_memory()
    assert default is not None and physical is not None and 0 < default <= 0.75 * physical + 1


def test_option_caps(scene_file):
    """Samples, bounces and pixel counts beyond what the kernels index are refused."""
    scene = warp_st.load(str(scene_file))
    for kwargs, word in (({"samples": limits.MAX_SAMPLES + 1}, "samples"),
                         ({"max_depth": limits.MAX_BOUNCES + 1}, "maxDepth"),
                         ({"width": 1 << 16, "height": 1 << 16}, "pixels")):
        with pytest.raises(SceneError, match=word):
            Renderer(scene, frames=[0.0], **{"width": 8, "height": 6, **kwargs})


# --- faults during output ------------------------------------------------------------------


@contextlib.contextmanager
def small_filesystem(tmp_path: Path, size_kb: int, *, read_only: bool = False):
    """A real tmpfs of ``size_kb`` mounted under tmp_path, or None where mounting is not allowed."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if not (sys.platform.startswith("linux") and hasattr(os, "geteuid") and os.geteuid() == 0):
        yield None
        return
    opts = f"size={size_kb}k" + (",ro" if read_only else "")
    try:
        proc = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(mnt)], capture_output=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        proc = None
    if proc is None or proc.returncode != 0:
        yield None
        return
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True, timeout=20)


def _good_frame(path: Path) -> bytes:
    rgba = np.full((480, 640, 4), 0.25, np.float32)
    Image(rgba=rgba, camera_time=0.0, frame=0.0).write_exr(path)
    return path.read_bytes()


def test_disk_full_keeps_earlier_frame_and_leaves_nothing(scene_file, tmp_path, capsys, monkeypatch):
    """ENOSPC in the middle of a write: exit 1 with one line naming the file and the
    complete frames; the earlier good frame is byte-identical; no partial file, no temp.
    On a real full tmpfs when one can be mounted, else through a writer that fails midway."""
    with small_filesystem(tmp_path, 192) as mnt:
        directory = mnt if mnt is not None else tmp_path / "out"
        directory.mkdir(exist_ok=True)
        earlier = directory / "f.0001.exr"
        good = _good_frame(earlier)
        if mnt is None:
            real_encode = exr._encode

            def encode_then_fail(header, channels, fh):
                fh.write(b"\0" * 1000)
                raise OSError(errno.ENOSPC, "No space left on device")

            monkeypatch.setattr(exr, "_encode", encode_then_fail)
        else:  # fill the filesystem so that no second 640 x 480 frame fits beside the first
            with open(directory / "ballast", "wb") as fh:
                with contextlib.suppress(OSError):
                    fh.write(b"\0" * (192 * 1024 - len(good) - 40 * 1024))
        code, _, err = run(capsys, "render", scene_file, "-o", directory / "f.####.exr", "--frames", "0-1",
                           "--width", 640, "--height", 480, "--quiet")
        line = one_line(err)
        assert code == 1 and "No space left on device" in line and "frames complete" in line, err
        assert earlier.read_bytes() == good
        assert not (directory / "f.0000.exr").exists() or exr.is_complete_exr(directory / "f.0000.exr")
        no_temp_files(directory)
        if mnt is None:
            monkeypatch.setattr(exr, "_encode", real_encode)


def test_read_only_directory_exit_2_and_nothing_touched(scene_file, tmp_path, capsys, monkeypatch):
    """A read-only output directory (a read-only tmpfs when one can be mounted; root
    ignores mode bits, so otherwise access() is made to say no): exit 2 before rendering."""
    with small_filesystem(tmp_path, 64, read_only=True) as mnt:
        directory = mnt
        if directory is None:
            directory = tmp_path / "ro"
            directory.mkdir()
            directory.chmod(0o555)
            real_access = os.access
            monkeypatch.setattr(exr.os, "access", lambda p, m: False if Path(p) == directory else real_access(p, m))
        code, _, err = run(capsys, "render", scene_file, "-o", directory / "f.exr", "--width", 8, "--height", 6)
        assert code == 2 and "not writable" in one_line(err), err
        assert list(directory.iterdir()) == []


def test_directory_turning_read_only_mid_sequence(scene_file, tmp_path, capsys, monkeypatch):
    """The directory stops accepting files after the check (permission lost mid-run): the
    frames already written stay, the earlier frame is untouched, exit 1 names the file."""
    out = tmp_path / "seq"
    out.mkdir()
    earlier = out / "f.0002.exr"
    good = _good_frame(earlier)
    real_open = open
    writes = []

    def flaky_open(path, mode="r", *args, **kwargs):
        if "w" in mode and str(path).endswith(".tmp"):
            writes.append(path)
            if len(writes) > 1:
                raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, mode, *args, **kwargs)

    monkeypatch.setattr(exr, "open", flaky_open, raising=False)
    code, _, err = run(capsys, "render", scene_file, "-o", out / "f.####.exr", "--frames", "1-2",
                       "--width", 8, "--height", 6, "--quiet")
    line = one_line(err)
    assert code == 1 and "f.0002.exr" in line and "frames complete: 1 " in line, err
    assert exr.is_complete_exr(out / "f.0001.exr")
    assert earlier.read_bytes() == good
    no_temp_files(out)


KILL_WRITER = r"""
import sys, numpy as np
from warp_st.output.film import Image
rng = np.random.default_rng(0)
h, w = 2048, 2048
img = Image(rgba=rng.random((h, w, 4), dtype=np.float32), depth=rng.random((h, w), dtype=np.float32),
            proper_time=rng.random((h, w), dtype=np.float32), doppler=rng.random((h, w), dtype=np.float32),
            event_time=rng.random((h, w)), source_time=rng.random((h, w)), camera_time=0.0, frame=1.0)
print("writing", flush=True)
img.write_exr(sys.argv[1])
"""


@pytest.mark.parametrize("earlier", [True, False])
def test_sigkill_while_writing_a_large_exr(tmp_path, earlier):
    """SIGKILL while a 2048 x 2048 EXR is being encoded: the final name holds the earlier
    good frame byte for byte (or nothing); only a hidden .NAME.PID.tmp may remain."""
    target = tmp_path / "big.exr"
    good = _good_frame(target) if earlier else None
    proc = subprocess.Popen([sys.executable, "-c", KILL_WRITER, str(target)], env=child_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "writing"
        deadline = time.monotonic() + 60
        temp = None
        while time.monotonic() < deadline and temp is None:
            temp = next((p for p in tmp_path.iterdir() if p.name.endswith(".tmp") and p.stat().st_size > 0), None)
            time.sleep(0.001)
        assert temp is not None, "the writer never started its temporary file"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == -signal.SIGKILL
    if earlier:
        assert target.read_bytes() == good
    else:
        assert not target.exists()
    leftovers = [p.name for p in tmp_path.iterdir() if p.name != target.name]
    assert all(n.startswith(".big.exr.") and n.endswith(".tmp") for n in leftovers), leftovers


def test_sigterm_mid_sequence_then_resume(scene_file, tmp_path):
    """SIGTERM after the first frame of 41: one stderr line naming the complete frames,
    exit 143, every file under a final name complete; --resume renders exactly the rest
    and leaves the complete ones byte-identical."""
    pattern = tmp_path / "seq.####.exr"
    argv = [sys.executable, "-m", "warp_st", "render", str(scene_file), "-o", str(pattern), "--frames", "0-40",
            "--width", "640", "--height", "480"]
    code, err = signal_after(argv, tmp_path, (tmp_path / "seq.0000.exr").exists, signal.SIGTERM)
    assert code == 143, err
    line = one_line(err)
    assert "terminated by SIGTERM" in line and "frames complete: 0" in line and "--resume" in line, line
    written = sorted(p for p in tmp_path.glob("seq.*.exr"))
    assert 1 <= len(written) < 41, "SIGTERM came too late to test anything"
    assert all(exr.is_complete_exr(p) for p in written)
    no_temp_files(tmp_path)
    before = {p.name: p.read_bytes() for p in written}

    resume_renders_the_rest(argv, tmp_path, before, 41)


# --- reproducibility -------------------------------------------------------------------------


def test_same_stage_same_bytes_across_processes(scene_file, tmp_path):
    """Two processes (different PYTHONHASHSEED) rendering the same stage with the same
    command line write bit-identical files; the header holds version, options, stage path
    and the root layer's sha256, and nothing time-dependent."""
    outputs = []
    for seed in ("1", "2"):
        run_dir = tmp_path / f"run{seed}"
        run_dir.mkdir()
        proc = subprocess.run([sys.executable, "-m", "warp_st", "render", str(scene_file), "-o", "out.exr",
                               "--width", "64", "--height", "48", "--frame", "3", "--quiet"],
                              env=child_env(PYTHONHASHSEED=seed), cwd=str(run_dir), capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        outputs.append((run_dir / "out.exr").read_bytes())
        time.sleep(1.1)  # a timestamp in the header would now differ
    assert outputs[0] == outputs[1]
    header = exr.read_header(tmp_path / "run1" / "out.exr")
    assert header["spacetime:stageHash"] == "sha256:" + hashlib.sha256(scene_file.read_bytes()).hexdigest()
    assert header["spacetime:stage"] == str(scene_file)
    assert header["spacetime:version"] == warp_st.__version__
    assert "width=64" in header["spacetime:options"] and "height=48" in header["spacetime:options"]
    assert not [k for k in header if any(w in k.lower() for w in ("date", "time.", "utc", "clock"))]


def test_one_and_two_threads_give_the_same_bytes(scene_file, tmp_path):
    """Renderer.render(frame, threads=1) and threads=2 over several tiles: identical EXR bytes."""
    scene = warp_st.load(str(scene_file))
    r = Renderer(scene, frames=[0.0, 5.0], width=160, height=120)  # 19200 pixels: 3 tiles
    for frame in (0.0, 5.0):
        paths = []
        for threads in (1, 2):
            img = r.render(frame, threads=threads)
            paths.append(tmp_path / f"f{frame}_{threads}.exr")
            img.write_exr(paths[-1])
        assert paths[0].read_bytes() == paths[1].read_bytes()
    again = Renderer(scene, frames=[0.0, 5.0], width=160, height=120).render(5.0, threads=2)
    again.write_exr(tmp_path / "again.exr")
    assert (tmp_path / "again.exr").read_bytes() == paths[1].read_bytes()


# --- untrusted stages --------------------------------------------------------------------------

LOCAL_AND_REFERENCED = """#usda 1.0
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cube "Local"
{
    double size = 2
}
def Xform "Imported" (
    prepend references = @./%s@
)
{
    double3 xformOp:translate = (3, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""

OTHER = """#usda 1.0
(
    defaultPrim = "Asset"
)
def Xform "Asset"
{
    def Sphere "Ball"
    {
        double radius = 1
    }
}
"""


def test_no_references_renders_a_stage_with_a_missing_reference(tmp_path, capsys):
    """A missing reference is a real-world USD problem: one warning naming it, and the rest
    renders (exit 0), the same pixels as with --no-references, which composes no arcs."""
    stage = tmp_path / "stage.usda"
    stage.write_text(LOCAL_AND_REFERENCED % "missing.usda")
    out, local = tmp_path / "out.exr", tmp_path / "local.exr"
    code, _, err = run(capsys, "render", stage, "-o", out, "--width", 16, "--height", 12, "--quiet")
    assert code == 0, err
    assert [ln for ln in err.splitlines() if "missing.usda" in ln and "warning" in ln], err
    code, _, err = run(capsys, "render", stage, "-o", local, "--width", 16, "--height", 12, "--no-references")
    assert code == 0, err
    img, with_arcs = warp_st.read_exr(local), warp_st.read_exr(out)
    assert set(img.id_manifest.values()) == {"/Local"} == set(with_arcs.id_manifest.values())
    np.testing.assert_array_equal(img.rgba, with_arcs.rgba)
    assert "no_references=True" in img.metadata["options"]
    code, out_text, err = run(capsys, "validate", stage, "--no-references")
    assert code == 0 and "1 bodies" in out_text, err


def test_no_references_ignores_a_reference_to_another_file(tmp_path, capsys):
    (tmp_path / "other.usda").write_text(OTHER)
    stage = tmp_path / "stage.usda"
    stage.write_text(LOCAL_AND_REFERENCED % "other.usda")
    with_refs = warp_st.load(str(stage))
    without = warp_st.load(str(stage), no_references=True)
    assert [b.prim_path for b in with_refs.bodies] == ["/Local", "/Imported/Ball"]
    assert [b.prim_path for b in without.bodies] == ["/Local"]
    out = tmp_path / "out.exr"
    code, _, err = run(capsys, "render", stage, "-o", out, "--width", 16, "--height", 12, "--no-references")
    assert code == 0, err


def test_reading_a_stage_loads_no_code_from_it(tmp_path):
    """A stage directory holding a USD plugin (plugInfo.json + a Python module that would
    leave a marker if imported) and a stage referencing a file of that plugin's format:
    reading it never imports the module (USD loads plugins only from PXR_PLUGINPATH_NAME)."""
    marker = tmp_path / "executed"
    plugin = tmp_path / "evilplug"
    plugin.mkdir()
    (plugin / "__init__.py").write_text(f"open({str(marker)!r}, 'w').write('ran')\n")
    (plugin / "plugInfo.json").write_text("""{"Plugins": [{"Type": "python", "Name": "evilplug",
        "Info": {"Types": {"evilplug.Format": {"bases": ["SdfFileFormat"], "extensions": ["evil"],
        "formatId": "evil", "primary": true, "target": "usd"}}}, "Root": ".", "LibraryPath": ""}]}""")
    (tmp_path / "plugInfo.json").write_text('{"Includes": ["evilplug/"]}')
    (tmp_path / "asset.evil").write_text("anything")
    stage = tmp_path / "stage.usda"
    stage.write_text(LOCAL_AND_REFERENCED % "asset.evil")
    code = f"""
import sys, warp_st
try:
    warp_st.load({str(stage)!r})
except warp_st.SceneError as exc:
    print("SceneError", exc)
warp_st.load({str(stage)!r}, no_references=True)
"""
    proc = subprocess.run([sys.executable, "-c", code], env=child_env(), cwd=str(tmp_path), capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert not marker.exists()


def test_time_segments_fall_back_to_the_coarser_rule_when_memory_is_short():
    """Finely tessellated moving bodies get short time segments (extrude.segment_sweep);
    when that database would not fit under max_memory but the coarser per-body rule
    does, the renderer uses the coarser one instead of refusing, and the image is the
    same (both are exact extrusions of the same surfaces: only box tightness differs)."""
    from warp_st.testing import rest_camera, sphere_grid_scene
    from warp_st.rendering.budget import check_resources
    from warp_st.spacetime.visibility import visibility_windows

    scene = sphere_grid_scene(96, 2)
    fine_r = Renderer(scene, frames=[0.0], width=48, height=27, primitive="prism")
    assert fine_r.fine_segments
    cams = [rest_camera()]
    windows = visibility_windows(scene, cams, infinite=False, max_depth=fine_r.max_depth)
    sizes = {fine: check_resources(scene, windows, width=48, height=27, max_depth=fine_r.max_depth, fine=fine)
             for fine in (True, False)}
    assert sizes[False] < sizes[True]
    coarse_r = Renderer(scene, frames=[0.0], width=48, height=27, max_memory=(sizes[False] + sizes[True]) // 2,
                        primitive="prism")
    assert not coarse_r.fine_segments
    assert coarse_r.stats.tetrahedra < fine_r.stats.tetrahedra
    a, b = fine_r.render(0.0), coarse_r.render(0.0)
    assert (a.object_id > 0).mean() > 0.1
    assert np.array_equal(a.object_id, b.object_id)
    hit = a.object_id > 0
    np.testing.assert_allclose(a.depth[hit], b.depth[hit], rtol=1e-5)  # float32 rounding of two extrusions
    with pytest.raises(SceneError, match="memory limit"):
        Renderer(scene, frames=[0.0], width=48, height=27, max_memory=sizes[False] // 2, primitive="prism")
