"""Shared fuzzing machinery of tests/usd/test_fuzz_usd.py, tests/output/test_fuzz_exr.py and
tests/output/test_fuzz_products.py: budgets, the run's seed, the single-fault base stage,
byte corruption and the child-process worker.

Environment:

- ``WARP_ST_FUZZ_SEED=N``: replay the run whose seed was N. Without it every run draws a
  fresh seed; it is printed in pytest's terminal summary (``fuzz seed: N``) and beside
  every failing test, so a failure found in CI is replayed with
  ``WARP_ST_FUZZ_SEED=N python -m pytest tests/usd/test_fuzz_usd.py``. The seed drives
  hypothesis (``@seed``) and every byte-corruption generator (:func:`fuzz_random`).
- ``WARP_ST_FUZZ_SCALE=X``: multiply every budget (the ``slow`` tests run the figures
  quoted in docs/reliability.md).
- ``WARP_ST_FUZZ_REPORT=FILE``: write the cases tried per generator there (JSON).
"""
from __future__ import annotations

import json
import os
import random
import secrets
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, seed, settings

ROOT = Path(__file__).resolve().parents[1]
SCALE = float(os.environ.get("WARP_ST_FUZZ_SCALE", "1"))
SEED_VARIABLE = "WARP_ST_FUZZ_SEED"


def _run_seed() -> int:
    text = os.environ.get(SEED_VARIABLE, "").strip()
    return int(text, 0) if text else secrets.randbits(32)


#: This run's seed: WARP_ST_FUZZ_SEED, else fresh (printed by tests/conftest.py).
FUZZ_SEED = _run_seed()

#: Cases tried per generator (written to WARP_ST_FUZZ_REPORT by tests/conftest.py).
STATS: dict[str, int] = {}


def budget(n: int) -> int:
    return max(1, int(n * SCALE))


def count(kind: str, n: int = 1) -> None:
    STATS[kind] = STATS.get(kind, 0) + n


def fuzz_settings(n: int):
    """Hypothesis settings for ``budget(n)`` examples drawn from this run's seed."""
    chosen = settings(
        max_examples=budget(n),
        deadline=None,  # the first example compiles the kernels; hangs are caught by the watchdog
        suppress_health_check=list(HealthCheck),
        phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.shrink],
        derandomize=False,
        database=None,
    )

    def apply(test):
        return seed(FUZZ_SEED)(chosen(test))

    return apply


def fuzz_random(tag: str) -> random.Random:
    """A generator for one corruption run, from this run's seed and the run's own tag."""
    return random.Random(f"{FUZZ_SEED}:{tag}")


# --- the single-fault stage ------------------------------------------------------------

#: (slot, prim path, attribute name, expected type, the valid line the slot holds by default)
TARGETS = [
    ("ship_u", "/World/Ship", "spacetime:fourVelocity", "double4", "custom double4 spacetime:fourVelocity = (1, 0.3, 0, 0)"),
    ("ship_life", "/World/Ship", "spacetime:lifetime", "double2", "custom double2 spacetime:lifetime = (-100, 100)"),
    ("ship_tref", "/World/Ship", "spacetime:referenceTime", "double", "custom double spacetime:referenceTime = 0"),
    ("ship_dec", "/World/Ship", "spacetime:lorentzDecoupled", "bool", "custom bool spacetime:lorentzDecoupled = false"),
    ("ship_xf", "/World/Ship", "xformOp:translate", "double3", "double3 xformOp:translate = (2, 0.5, 0)"),
    ("hull_size", "/World/Ship/Hull", "size", "double", "double size = 2"),
    ("ball_r", "/World/Ship/Ball", "radius", "double", "double radius = 0.5"),
    ("ball_xf", "/World/Ship/Ball", "xformOp:scale", "float3", "float3 xformOp:scale = (1, 1, 1)"),
    ("floor_pts", "/World/Floor", "points", "point3f[]", "point3f[] points = [(-6, -2, -4), (6, -2, -4), (6, -2, 3), (-6, -2, 3)]"),
    ("floor_cnt", "/World/Floor", "faceVertexCounts", "int[]", "int[] faceVertexCounts = [4]"),
    ("floor_idx", "/World/Floor", "faceVertexIndices", "int[]", "int[] faceVertexIndices = [0, 1, 2, 3]"),
    ("floor_nrm", "/World/Floor", "normals", "normal3f[]", "normal3f[] normals = [(0, 1, 0), (0, 1, 0), (0, 1, 0), (0, 1, 0)]"),
    ("floor_col", "/World/Floor", "primvars:displayColor", "color3f[]", "color3f[] primvars:displayColor = [(0.2, 0.5, 0.2)]"),
    ("floor_ori", "/World/Floor", "orientation", "token", 'uniform token orientation = "rightHanded"'),
    ("cam_focal", "/World/Cam", "focalLength", "float", "float focalLength = 30"),
    ("cam_hap", "/World/Cam", "horizontalAperture", "float", "float horizontalAperture = 36"),
    ("cam_vap", "/World/Cam", "verticalAperture", "float", "float verticalAperture = 24"),
    ("cam_hoff", "/World/Cam", "horizontalApertureOffset", "float", "float horizontalApertureOffset = 0"),
    ("cam_proj", "/World/Cam", "projection", "token", 'token projection = "perspective"'),
    ("cam_time", "/World/Cam", "spacetime:time", "double", "custom double spacetime:time = 0"),
    ("cam_c", "/World/Cam", "spacetime:lightSpeed", "token", 'custom token spacetime:lightSpeed = "finite"'),
    ("cam_u", "/World/Cam", "spacetime:fourVelocity", "double4", "custom double4 spacetime:fourVelocity = (1, 0, 0, 0.1)"),
    ("cam_xf", "/World/Cam", "xformOp:translate", "double3", "double3 xformOp:translate = (0, 0, 8)"),
    ("sun_i", "/World/Sun", "inputs:intensity", "float", "float inputs:intensity = 6.2831855"),  # E = 2 pi at angle 0
    ("sun_e", "/World/Sun", "inputs:exposure", "float", "float inputs:exposure = 0"),
    ("sun_c", "/World/Sun", "inputs:color", "color3f", "color3f inputs:color = (1, 0.9, 0.8)"),
    ("sun_k", "/World/Sun", "inputs:colorTemperature", "float", "float inputs:colorTemperature = 6500"),
    ("lamp_i", "/World/Lamp", "inputs:intensity", "float", "float inputs:intensity = 30"),
    ("lamp_xf", "/World/Lamp", "xformOp:translate", "double3", "double3 xformOp:translate = (2, 3, 4)"),
    ("mat_d", "/World/Looks/Red/PS", "inputs:diffuseColor", "color3f", "color3f inputs:diffuseColor = (0.8, 0.1, 0.1)"),
    ("mat_e", "/World/Looks/Red/PS", "inputs:emissiveColor", "color3f", "color3f inputs:emissiveColor = (0, 0, 0)"),
    ("mat_m", "/World/Looks/Red/PS", "inputs:metallic", "float", "float inputs:metallic = 0.5"),
    ("set_res", "/Render/Settings", "resolution", "int2", "uniform int2 resolution = (8, 6)"),
    ("set_depth", "/Render/Settings", "spacetime:maxDepth", "int", "custom int spacetime:maxDepth = 2"),
    ("set_samples", "/Render/Settings", "spacetime:samples", "int", "custom int spacetime:samples = 1"),
    ("set_shutter", "/Render/Settings", "spacetime:shutter", "double", "custom double spacetime:shutter = 0"),
    ("set_prec", "/Render/Settings", "spacetime:precision", "token", 'custom token spacetime:precision = "float32"'),
    ("set_bg", "/Render/Settings", "spacetime:background", "color3f", "custom color3f spacetime:background = (0.1, 0.2, 0.3)"),
    ("set_dop", "/Render/Settings", "spacetime:dopplerColor", "bool", "custom bool spacetime:dopplerColor = false"),
]
SLOTS = {t[0]: t for t in TARGETS}

SINGLE_STAGE = """#usda 1.0
(
    upAxis = "Y"
    renderSettingsPrimPath = "/Render/Settings"
)

def Xform "World"
{
    def Camera "Cam" (
        prepend apiSchemas = ["SpacetimeCameraAPI", "SpacetimeBodyAPI"]
    )
    {
        {cam_xf}
        uniform token[] xformOpOrder = ["xformOp:translate"]
        {cam_focal}
        {cam_hap}
        {cam_vap}
        {cam_hoff}
        {cam_proj}
        {cam_time}
        {cam_c}
        {cam_u}
    }

    def DistantLight "Sun"
    {
        float inputs:angle = 0
        {sun_i}
        {sun_e}
        {sun_c}
        bool inputs:enableColorTemperature = true
        {sun_k}
    }

    def SphereLight "Lamp"
    {
        float inputs:radius = 1
        bool treatAsPoint = true
        {lamp_i}
        {lamp_xf}
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }

    def Xform "Ship" (
        prepend apiSchemas = ["SpacetimeBodyAPI"]
    )
    {
        {ship_xf}
        uniform token[] xformOpOrder = ["xformOp:translate"]
        {ship_u}
        {ship_life}
        {ship_tref}
        {ship_dec}

        def Cube "Hull" (
            prepend apiSchemas = ["MaterialBindingAPI"]
        )
        {
            {hull_size}
            rel material:binding = </World/Looks/Red>
        }

        def Sphere "Ball"
        {
            {ball_r}
            double3 xformOp:translate = (1.5, 0, 0)
            {ball_xf}
            uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        }
    }

    def Mesh "Floor"
    {
        {floor_pts}
        {floor_cnt}
        {floor_idx}
        {floor_nrm}
        {floor_col}
        {floor_ori}
    }

    def Scope "Looks"
    {
        def Material "Red"
        {
            token outputs:surface.connect = </World/Looks/Red/PS.outputs:surface>

            def Shader "PS"
            {
                uniform token info:id = "UsdPreviewSurface"
                {mat_d}
                {mat_e}
                {mat_m}
                token outputs:surface
            }
        }
    }
}

def Scope "Render"
{
    def RenderSettings "Settings"
    {
        rel camera = </World/Cam>
        {set_res}
        {set_depth}
        {set_samples}
        {set_shutter}
        {set_prec}
        {set_bg}
        {set_dop}
    }
}
"""


def single_stage(slot: str | None = None, line: str | None = None) -> str:
    text = SINGLE_STAGE
    for key, (_, _, _, _, good) in SLOTS.items():
        value = line if key == slot else good
        text = text.replace("{" + key + "}", value.replace("\n", "\n        "))
    return text


# --- byte corruption, in a child process ---------------------------------------------------

#: Runs in a child: for each case, the real command line in-process (exit 0, or 2 with one
#: stderr line naming the file and no output), then the output's image law. One JSON line per
#: case is appended to the results file *before* (start) and after (end) it runs, so a crash
#: or a hang is pinned on the case that was running.
WORKER = r'''
import contextlib, io, json, os, resource, sys, tempfile, traceback, warnings
import numpy as np
resource.setrlimit(resource.RLIMIT_AS, (int(os.environ["FUZZ_RLIMIT_AS"]),) * 2)
cases, results_path, kind = json.load(open(sys.argv[1])), sys.argv[2], sys.argv[3]
import warp_st
from warp_st.commands import cli
from warp_st.core.scene import SceneError
warnings.simplefilter("ignore")

def emit(record):
    with open(results_path, "a") as fh:
        fh.write(json.dumps(record) + "\n")
        fh.flush()
        os.fsync(fh.fileno())

@contextlib.contextmanager
def captured_fds():
    """Everything written on fds 1 and 2 (Python and native) during the block."""
    out = []
    sys.stdout.flush(); sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as o, tempfile.TemporaryFile() as e:
        os.dup2(o.fileno(), 1); os.dup2(e.fileno(), 2)
        try:
            yield out
        finally:
            sys.stdout.flush(); sys.stderr.flush()
            os.dup2(saved[0], 1); os.dup2(saved[1], 2)
            os.close(saved[0]); os.close(saved[1])
            o.seek(0); e.seek(0)
            out.append(o.read().decode("utf-8", "replace"))
            out.append(e.read().decode("utf-8", "replace"))

def check_image(img):
    bg = img.object_id == 0
    assert not np.isnan(img.rgba).any(), "NaN in the beauty"
    assert np.isposinf(img.depth[bg]).all(), "Z != inf on background"
    assert np.isnan(img.event_time[bg]).all(), "eventTime not NaN on background"
    assert np.isfinite(img.depth[~bg]).all(), "Z not finite on a hit"

def run_cli(argv):
    with captured_fds() as text:
        code = cli.main(argv)
    return code, text[0], text[1]

for case in cases:
    path = case["path"]
    emit({"case": path, "state": "start"})
    problem = None
    try:
        name = os.path.basename(path)
        if kind == "usd":
            out = path + ".out.exr"
            code, stdout, stderr = run_cli(["render", path, "-o", out, "--width", "8", "--height", "6",
                                            "--quiet", "--max-memory", "1G"])
            lines = [ln for ln in stderr.splitlines() if ln.strip()]
            if code == 0:
                check_image(warp_st.read_exr(out))
            elif code == 2:
                assert len(lines) == 1 and name in lines[0], f"exit 2 must print one line naming {name}: {stderr!r}"
                assert not os.path.exists(out), "exit 2 left an output file"
            else:
                raise AssertionError(f"exit {code}: {stderr.strip()[-600:]}")
        else:  # exr
            outcomes = []
            for argv in (["inspect", path], ["inspect", path, "--pixel", "0", "0"],
                         ["inspect", path, "--channel", "Z"]):
                code, stdout, stderr = run_cli(argv)
                lines = [ln for ln in stderr.splitlines() if ln.strip()]
                assert code in (0, 2), f"{argv}: exit {code}: {stderr.strip()[-600:]}"
                if code == 2:  # one line naming the file, or the pixel that is outside the image
                    assert len(lines) == 1 and lines[0].startswith("warp-st: error: "), f"{argv}: {stderr!r}"
                    pixel = argv[2:3] == ["--pixel"] and "pixel (0, 0) is outside" in lines[0]
                    assert name in lines[0] or pixel, f"{argv}: exit 2 must name {name}: {stderr!r}"
                outcomes.append(code)
            try:
                with captured_fds():
                    img = warp_st.read_exr(path)
                assert img.rgba.ndim == 3
            except SceneError as exc:
                assert name in str(exc) and "\n" not in str(exc), str(exc)
            with captured_fds():
                complete = warp_st.output.exr.is_complete_exr(path)
            assert isinstance(complete, bool)
            try:
                with captured_fds():
                    warp_st.output.exr.read_header(path)
            except SceneError as exc:
                assert name in str(exc), str(exc)
        outcome = "ok" if code == 0 else "error"
        message = stderr.strip()[-300:] if code != 0 else None
    except BaseException as exc:  # noqa: BLE001 - the law under test: nothing escapes
        problem = "".join(traceback.format_exception(exc))[-2000:]
        outcome, message = "bug", None
    emit({"case": path, "state": "end", "outcome": outcome, "problem": problem, "message": message})
'''


def corrupt(data: bytes, rng: random.Random, *, hot: int = 256) -> tuple[bytes, str]:
    """One random corruption of ``data``: flipped bits, zeroed / 0xFF runs, truncation,
    inserted or duplicated chunks. Half the edits land in the first or last ``hot`` bytes
    (headers, tables of contents), the rest anywhere."""
    b = bytearray(data)
    n = len(b)

    def where() -> int:
        if rng.random() < 0.5:
            return rng.randrange(min(hot, n)) if rng.random() < 0.5 else max(0, n - 1 - rng.randrange(min(hot, n)))
        return rng.randrange(n)

    op = rng.choice(["flip", "flip", "zero", "ff", "truncate", "insert", "duplicate", "bytes"])
    if op == "flip":
        for _ in range(rng.randint(1, 8)):
            i = where()
            b[i] ^= 1 << rng.randrange(8)
    elif op in ("zero", "ff"):
        i = where()
        b[i:i + rng.randint(1, 16)] = bytes([0 if op == "zero" else 255]) * len(b[i:i + 16])
    elif op == "truncate":
        b = b[:where()]
    elif op == "insert":
        i = where()
        b[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
    elif op == "duplicate":
        i = where()
        b[i:i] = b[i:i + rng.randint(1, 64)]
    else:
        i = where()
        b[i] = rng.randrange(256)
    return bytes(b), op


def run_worker(kind: str, paths: list[Path], results: Path, timeout: float) -> dict:
    """Run WORKER over ``paths``; fail naming the case on a crash, a hang or a bug."""
    # The address-space cap turns a runaway allocation of ours into a MemoryError (a bug
    # found). USD's crate reader reserves (untouched) gigabytes for corrupt counts and
    # aborts on std::bad_alloc under a cap below ~16 GiB, hence the larger cap for stages.
    cap = (32 if kind == "usd" else 8) << 30
    env = dict(os.environ, PYTHONPATH=str(ROOT), FUZZ_RLIMIT_AS=str(cap), WARP_ST_DEBUG="")
    env.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))
    cases = results.with_name("cases.json")
    cases.write_text(json.dumps([{"path": str(p)} for p in paths]))
    try:
        proc = subprocess.run([sys.executable, "-c", WORKER, str(cases), str(results), kind], env=env,
                              capture_output=True, text=True, timeout=timeout, cwd=str(results.parent))
        died = proc.returncode != 0 and f"child exited {proc.returncode}: {proc.stderr[-1500:]}"
    except subprocess.TimeoutExpired:
        died = f"child timed out after {timeout} s"
    records = [json.loads(line) for line in results.read_text().splitlines()] if results.exists() else []
    ended = {r["case"]: r for r in records if r["state"] == "end"}
    started = [r["case"] for r in records if r["state"] == "start"]
    if died:
        culprit = next((c for c in started if c not in ended), None)
        pytest.fail(f"{died}; case running: {culprit}")
    bugs = {c: r["problem"] for c, r in ended.items() if r["outcome"] == "bug"}
    if bugs:
        kinds = sorted({p.strip().splitlines()[-1][:200] for p in bugs.values()})
        pytest.fail(f"{len(bugs)} of {len(paths)} cases broke the law; kinds: {kinds}\n\n"
                    + "\n\n".join(f"{c}:\n{p}" for c, p in list(bugs.items())[:3]))
    assert len(ended) == len(paths)
    counts = {}
    for r in ended.values():
        counts[r["outcome"]] = counts.get(r["outcome"], 0) + 1
    return counts
