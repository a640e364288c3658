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
  Here the outcome is known in advance: a SceneError exactly when a docs/spec.md §4
  channel has the wrong pixel type (UINT against FLOAT) or a header time is not a
  number; otherwise the Image carries the header doubles as the file stores them (a
  Python float is written as an EXR float, a float64 array as a double) and the event
  times are channel + timeOrigin; ``inspect`` exits 0 on such a file (2 for ``--channel
  Z`` exactly when there is no Z), and 2 naming the file on the others.

Seeds: a fresh one each run, printed in the terminal summary; ``WARP_ST_FUZZ_SEED=N``
replays run N (tests/fuzz_helpers.py).
"""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import fuzz_helpers as fuzz
import numpy as np
import OpenEXR
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

import warp_st
from warp_st.commands import cli
from warp_st.core.scene import SceneError
from warp_st.output.film import CHANNEL_NAMES, Image, channel_spec

ROOT = Path(__file__).resolve().parents[2]


def _seeds(directory: Path) -> list[Path]:
    """A rendered warp_st frame (every channel, idManifest, metadata) and foreign files."""
    stage = directory / "seed.usda"
    stage.write_text(fuzz.single_stage())
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


def _corruption_run(tmp_path: Path, n: int, tag: str, timeout: float) -> dict:
    rng = fuzz.fuzz_random(tag)
    seeds = _seeds(tmp_path)
    paths = []
    for i in range(n):
        src = seeds[i % len(seeds)]
        data, op = fuzz.corrupt(src.read_bytes(), rng, hot=512)
        path = tmp_path / f"case{i:05d}_{op}.exr"
        path.write_bytes(data)
        paths.append(path)
    counts = fuzz.run_worker("exr", paths, tmp_path / "results.jsonl", timeout)
    fuzz.count("corrupt.exr", n)
    return counts


def test_corrupted_exr_bytes(tmp_path):
    """Random byte corruption of EXR files: read_exr / read_header / is_complete_exr and
    three ``warp-st inspect`` forms obey the law, in a child process."""
    counts = _corruption_run(tmp_path, fuzz.budget(40), "exr", timeout=300)
    assert sum(counts.values()) == fuzz.budget(40)


@pytest.mark.slow
def test_corrupted_exr_bytes_many(tmp_path):
    counts = _corruption_run(tmp_path, fuzz.budget(3000), "exr-many", timeout=3000)
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


#: The header doubles read_exr returns, and what it returns when the file has none.
_HEADER_DOUBLES = {"spacetime:timeOrigin": 0.0, "spacetime:cameraTime": None, "spacetime:frame": float("nan")}


def _expected_header(header: dict, planes: dict):
    """(time origin, camera time, frame) read_exr must return, or None for a SceneError.

    None when a docs/spec.md §4 channel has the wrong kind of pixels (UINT against FLOAT)
    or a header time is a string. The values are what the file stores: the binding
    writes a Python float as an EXR float (so 1e300 becomes inf) and a float64 array
    as a double; the camera time defaults to the time origin."""
    for name, plane in planes.items():
        if name in CHANNEL_NAMES and (channel_spec(name).pixel_type == "UINT") != (plane.dtype == np.uint32):
            return None
    values = []
    for key, default in _HEADER_DOUBLES.items():
        value = header.get(key)
        if isinstance(value, str):
            return None
        if value is None:
            values.append(values[0] if default is None else default)
        elif isinstance(value, np.ndarray):
            values.append(float(value[0]))
        else:
            with np.errstate(over="ignore"):
                values.append(float(np.float32(value)))
    return tuple(values)


def _same(a: float, b: float) -> bool:
    return a == b or (np.isnan(a) and np.isnan(b))


def _odd_case(directory: Path, header: dict, planes: dict) -> None:
    path = directory / "odd.exr"
    if not planes:
        return  # OpenEXR writes no file without channels
    expected = _expected_header(header, planes)
    stored_times = planes.get("spacetime.eventTime")
    has_z = "Z" in planes
    OpenEXR.File(dict(header), dict(planes)).write(str(path))
    try:
        img = warp_st.read_exr(path)
    except SceneError as exc:
        assert expected is None, f"read_exr refused a readable file: {exc}"
        assert path.name in str(exc) and "\n" not in str(exc), str(exc)
        img = None
    if img is not None:
        assert expected is not None, "read_exr accepted a file with a wrong channel type or header time"
        origin, camera, frame = expected
        assert isinstance(img, Image)
        assert _same(img.time_origin, origin) and _same(img.camera_time, camera) and _same(img.frame, frame), (
            (img.time_origin, img.camera_time, img.frame), expected)
        if stored_times is not None:  # absolute = stored float32 + timeOrigin (docs/spec.md §4)
            with np.errstate(invalid="ignore"):
                want = stored_times.astype(np.float32).astype(np.float64) + origin
            np.testing.assert_array_equal(img.event_time, want)
    assert isinstance(warp_st.output.exr.is_complete_exr(path), bool)
    for argv in ((path,), (path, "--pixel", 0, 0), (path, "--channel", "Z")):
        code, err = _inspect(*argv)
        want = 0 if img is not None else 2
        if img is not None and argv[1:2] == ("--channel",) and not has_z:
            want = 2
        assert code == want, (argv, code, err)
        if code == 2:
            lines = err.strip().splitlines()
            assert len(lines) == 1 and path.name in lines[0], err
    fuzz.count("odd.exr")


#: Always tried first: a double timeOrigin far from 0 and no cameraTime, a float frame.
_EXPLICIT = ({"type": OpenEXR.scanlineimage, "compression": OpenEXR.ZIP_COMPRESSION,
              "spacetime:timeOrigin": np.array([1e6 + 0.25]), "spacetime:frame": 7.0},
             {"spacetime.eventTime": np.full((2, 3), -1.5, np.float32), "objectId": np.ones((2, 3), np.uint32)})


@fuzz.fuzz_settings(60)
@example(case=_EXPLICIT)
@given(case=odd_exr())
def test_odd_but_well_formed_exr(tmp_path_factory, case):
    """Random channel subsets / pixel types / header values: an Image or a SceneError naming
    the file; ``inspect`` exits 0 or 2 with one line."""
    header, planes = case
    _odd_case(tmp_path_factory.mktemp("odd"), header, planes)
