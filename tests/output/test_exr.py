"""EXR I/O (docs/spec.md §4): exact round trips, the file a compositor sees, atomic writes.

Every comparison here is exact (bitwise): ZIP compression is lossless for FLOAT
and UINT channels, doubles in the header are stored as doubles, and event /
source times are stored relative to the time origin, so nothing may change
between an Image and the Image read back from its file.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import OpenEXR
import pytest

import warp_st
from warp_st.core.scene import SceneError
from warp_st.output import exr
from warp_st.output.film import (
    CHANNEL_NAMES,
    CHANNELS,
    REQUIRED_CHANNELS,
    Image,
    absolute_time,
    quantize_time,
    relative_f32,
)

H, W = 24, 32
ORIGIN = 1.0e9 + 0.1  # not representable in float32: must travel as a double


def bits(a: np.ndarray) -> np.ndarray:
    """The raw bit patterns of an array, so NaN == NaN and -0 != +0 when comparing."""
    a = np.ascontiguousarray(a)
    return a.view({4: np.uint32, 8: np.uint64}[a.dtype.itemsize]) if a.dtype.kind == "f" else a


def assert_bitwise(a: np.ndarray, b: np.ndarray, what: str) -> None:
    assert a.dtype == b.dtype, what
    assert a.shape == b.shape, what
    np.testing.assert_array_equal(bits(a), bits(b), err_msg=what)


def random_image(seed: int = 0, *, origin: float = ORIGIN, **kwargs) -> Image:
    """An Image with every plane random and NaN / +-inf / background at random places."""
    rng = np.random.default_rng(seed)
    hit = rng.random((H, W)) < 0.7  # ~30 % background pixels

    rgba = rng.random((H, W, 4)).astype(np.float32) * 5
    rgba[..., 3] = np.where(hit, 1.0, 0.0)
    rgba[0, 0, 0] = np.inf  # a blown-out highlight must survive too
    rgba[0, 1, 1] = -0.0

    def f32(scale, bg):
        v = (rng.standard_normal((H, W)) * scale).astype(np.float32)
        return np.where(hit, v, np.float32(bg)).astype(np.float32)

    depth = np.abs(f32(100.0, np.inf))
    lookback = rng.random((H, W)) * 50.0
    event_time = quantize_time(np.where(hit, origin - lookback, np.nan), origin)
    source_time = quantize_time(np.where(hit, origin - lookback * 2.5, np.nan), origin)
    proper_time = f32(30.0, np.nan)
    proper_time[1, 2] = -np.inf
    doppler = np.abs(f32(2.0, np.nan))
    object_id = np.where(hit, rng.integers(1, 2**32 - 1, (H, W), dtype=np.uint64), 0).astype(np.uint32)
    bounces = np.where(hit, rng.integers(0, 5, (H, W)), 0).astype(np.uint32)
    args = dict(
        rgba=rgba, depth=depth, event_time=event_time, proper_time=proper_time, doppler=doppler,
        object_id=object_id, source_time=source_time, bounces=bounces,
        camera_time=origin, time_origin=origin, frame=920.25, precision="float64",
        id_manifest={1: "/World/Ship", 2: "/World/Ship/Hull", 7: "/World/Größe/ünicode", 2**32 - 1: "/Max"},
        metadata={"stage": "usd_scenes/ship.usda", "options": "width=32 height=24 samples=4"},
    )
    args.update(kwargs)
    return Image(**args)


def test_round_trip_every_channel_and_header(tmp_path):
    """write -> read is the identity on every plane (bitwise, NaN/inf placements included)
    and every header value (doubles exact, idManifest, metadata plus the writer's version)."""
    img = random_image()
    path = tmp_path / "frame.exr"
    img.write_exr(path)
    back = warp_st.read_exr(path)

    for spec in CHANNELS:
        assert_bitwise(img.channel(spec.name), back.channel(spec.name), spec.name)
    for field in ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id", "source_time", "bounces"):
        assert_bitwise(getattr(img, field), getattr(back, field), field)
    assert back.event_time.dtype == np.float64 and back.source_time.dtype == np.float64
    assert back.camera_time == img.camera_time == ORIGIN
    assert back.time_origin == img.time_origin
    assert back.frame == 920.25
    assert back.precision == "float64"
    assert back.id_manifest == img.id_manifest
    assert back.metadata == {**img.metadata, "version": warp_st.__version__}
    assert back.channels is None  # all channels present
    assert (back.width, back.height) == (W, H)

    # Reading then writing again reproduces the same Image (the version key is not duplicated).
    back.write_exr(tmp_path / "again.exr")
    again = warp_st.read_exr(tmp_path / "again.exr")
    assert again.metadata == back.metadata
    for spec in CHANNELS:
        assert_bitwise(back.channel(spec.name), again.channel(spec.name), spec.name)


def test_absolute_times_survive_at_huge_times(tmp_path):
    """Event times near t = 1e9 come back exactly because the file holds t - timeOrigin.

    Stored absolute as float32 they would be rounded to multiples of 64 time units; the
    eighths used here are exact in float64 and in float32 relative to the origin.
    """
    origin = 1.0e9
    offsets = (0.0 - np.arange(H * W, dtype=np.float64).reshape(H, W)) / 8.0  # 0, -0.125, ... (+0, not -0)
    times = origin + offsets
    assert np.any(times.astype(np.float32).astype(np.float64) != times)  # absolute float32 would lose them
    img = Image(rgba=np.ones((H, W, 4)), event_time=times, source_time=times - 0.5,
                camera_time=origin + 0.375, time_origin=origin)
    path = tmp_path / "late.exr"
    exr.write_exr(img, path)
    back = warp_st.read_exr(path)
    assert_bitwise(back.event_time, times, "eventTime")
    assert_bitwise(back.source_time, times - 0.5, "sourceTime")
    assert back.camera_time == origin + 0.375 and back.time_origin == origin
    # In the file: float32 offsets from the origin, as docs/spec.md §4 says.
    with OpenEXR.File(str(path), separate_channels=True) as f:
        stored = f.channels()["spacetime.eventTime"].pixels
    assert_bitwise(stored, offsets.astype(np.float32), "stored relative eventTime")


@pytest.mark.parametrize("origin", [0.0, 1.0e-3, 920.0, -3.5e6, 1.0e9 + 0.1, 4.5e15])
def test_quantize_time_is_idempotent(origin):
    """q(t) = float64(float32(t - o)) + o is a projection: q(q(t)) = q(t), bitwise.

    That is what makes a renderer-produced Image (times passed through q) round-trip
    exactly through the file; the lookbacks span 1e-6 .. 1e8 to cover both the case
    where the sum t - o is exact and the case where it rounds.
    """
    rng = np.random.default_rng(42)
    lookback = 10.0 ** rng.uniform(-6, 8, 5000) * rng.choice([-1.0, 1.0], 5000)
    t = origin + lookback
    q = quantize_time(t, origin)
    assert_bitwise(quantize_time(q, origin), q, "q(q(t))")
    assert_bitwise(absolute_time(relative_f32(q, origin), origin), q, "read(write(q))")
    assert np.isnan(quantize_time(np.nan, origin)) and quantize_time(np.inf, origin) == np.inf


def test_channel_subset(tmp_path):
    """A subset is written as exactly those channels; reading fills the others with
    their background values (Z +inf, times NaN, ids 0) and records the subset."""
    img = random_image(seed=3, channels=("objectId", "R", "G", "B", "A", "Z"))
    path = tmp_path / "subset.exr"
    img.write_exr(path)
    with OpenEXR.File(str(path), separate_channels=True) as f:
        assert set(f.channels()) == {"R", "G", "B", "A", "Z", "objectId"}
    back = warp_st.read_exr(path)
    assert back.channels == ("R", "G", "B", "A", "Z", "objectId")  # SPEC order
    for name in back.channels:
        assert_bitwise(img.channel(name), back.channel(name), name)
    assert np.all(np.isnan(back.event_time)) and np.all(np.isnan(back.source_time))
    assert np.all(np.isnan(back.proper_time)) and np.all(np.isnan(back.doppler))
    assert np.all(back.bounces == 0)
    # Writing it again keeps the subset.
    back.write_exr(tmp_path / "subset2.exr")
    assert warp_st.read_exr(tmp_path / "subset2.exr").channels == back.channels


def test_subset_needs_known_names_only(tmp_path):
    """Any subset of SPEC names is an image (RenderVar files need not hold R, G, B, A);
    an unknown name is a KeyError naming it."""
    img = random_image(channels=("R", "G", "B", "Z"))
    img.write_exr(tmp_path / "rgbz.exr")
    with OpenEXR.File(str(tmp_path / "rgbz.exr"), separate_channels=True) as f:
        assert set(f.channels()) == {"R", "G", "B", "Z"}
    with pytest.raises(KeyError, match="spacetime.nope"):
        random_image(channels=("R", "G", "B", "A", "spacetime.nope"))


def test_image_defaults_are_background():
    """Planes left out are background: Z +inf, times NaN, ids 0; time_origin = camera_time."""
    img = Image(rgba=np.zeros((2, 3, 4)), camera_time=5.0)
    assert (img.width, img.height) == (3, 2)
    assert img.time_origin == 5.0
    for spec in CHANNELS:
        plane = img.channel(spec.name)
        assert plane.shape == (2, 3)
        np.testing.assert_array_equal(plane, np.full((2, 3), spec.background))
    assert img.event_time.dtype == np.float64 and img.object_id.dtype == np.uint32
    with pytest.raises(ValueError, match="depth"):
        Image(rgba=np.zeros((2, 3, 4)), depth=np.zeros((3, 2)))


def test_compositor_view(tmp_path):
    """The file opens as a plain EXR: SPEC channel names, FLOAT / UINT pixel types, ZIP,
    scanline, double header times, and a standard idManifest on channel objectId."""
    img = random_image(seed=5)
    path = tmp_path / "comp.exr"
    img.write_exr(path)
    with OpenEXR.File(str(path), separate_channels=True) as f:
        part = f.parts[0]
        assert part.compression() == OpenEXR.ZIP_COMPRESSION
        assert part.type() == OpenEXR.scanlineimage
        channels = f.channels()
        assert set(channels) == set(CHANNEL_NAMES)
        for spec in CHANNELS:
            expected = OpenEXR.UINT if spec.pixel_type == "UINT" else OpenEXR.FLOAT
            assert channels[spec.name].type() == expected, spec.name
        assert {n for n in CHANNEL_NAMES if channels[n].type() == OpenEXR.UINT} == {"objectId", "spacetime.bounces"}
        header = f.header()
        for key in ("spacetime:cameraTime", "spacetime:timeOrigin", "spacetime:frame"):
            value = header[key]
            assert isinstance(value, np.ndarray) and value.dtype == np.float64, key  # a double attribute
        assert float(header["spacetime:cameraTime"][0]) == ORIGIN
        assert header["spacetime:precision"] == "float64"
        assert header["spacetime:version"] == warp_st.__version__
        assert header["spacetime:stage"] == "usd_scenes/ship.usda"
        manifest = header["idManifest"]
        assert isinstance(manifest, OpenEXR.IDManifest)
        group = manifest[manifest.find("objectId")]
        assert set(group.getChannels()) == {"objectId"}
        assert group.getHashScheme() == "none"
        assert {int(e.id()): list(e.text()) for e in group} == {k: [v] for k, v in img.id_manifest.items()}


def test_no_id_manifest_when_empty(tmp_path):
    """An image without bodies writes no idManifest and reads back an empty mapping."""
    img = Image(rgba=np.zeros((4, 4, 4)))
    img.write_exr(tmp_path / "empty.exr")
    with OpenEXR.File(str(tmp_path / "empty.exr"), header_only=True) as f:
        assert "idManifest" not in f.header()
    assert warp_st.read_exr(tmp_path / "empty.exr").id_manifest == {}


def test_metadata_reserved_keys_rejected(tmp_path):
    """Metadata may not shadow the typed header attributes."""
    img = Image(rgba=np.zeros((2, 2, 4)), metadata={"cameraTime": "7"})
    with pytest.raises(ValueError, match="cameraTime"):
        img.write_exr(tmp_path / "x.exr")
    assert not (tmp_path / "x.exr").exists()


class _FailingFile:
    """Stands in for OpenEXR.File: writes half a file, then fails like a full disk or ^C."""

    error: type[BaseException] = RuntimeError

    def __init__(self, header, channels):
        pass

    def write(self, fh):
        fh.write(b"v/1\x01" + b"\x00" * 4096)
        raise self.error("simulated failure in the middle of writing")


@pytest.mark.parametrize("error", [RuntimeError, OSError, KeyboardInterrupt])
def test_atomic_write_leaves_previous_file(tmp_path, monkeypatch, error):
    """A failure mid-write leaves the final name exactly as it was and no temp file."""
    path = tmp_path / "frame.0001.exr"
    path.write_bytes(b"previous render")
    monkeypatch.setattr(_FailingFile, "error", error)
    monkeypatch.setattr(exr.OpenEXR, "File", _FailingFile)
    with pytest.raises(error, match="simulated"):
        random_image().write_exr(path)
    assert path.read_bytes() == b"previous render"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frame.0001.exr"]


def test_atomic_write_creates_nothing_on_failure(tmp_path, monkeypatch):
    """With no previous file, a failed write leaves no file at all."""
    monkeypatch.setattr(exr.OpenEXR, "File", _FailingFile)
    with pytest.raises(RuntimeError):
        random_image().write_exr(tmp_path / "new.exr")
    assert list(tmp_path.iterdir()) == []


def test_write_replaces_existing_file(tmp_path):
    """A successful write replaces an older file under the same name."""
    path = tmp_path / "f.exr"
    path.write_bytes(b"old")
    random_image().write_exr(path)
    assert exr.is_complete_exr(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.exr"]


def test_write_into_missing_directory(tmp_path):
    """A missing directory is an OSError naming the output path; nothing is created."""
    path = tmp_path / "nope" / "f.exr"
    with pytest.raises(FileNotFoundError, match="nope"):
        random_image().write_exr(path)
    assert not (tmp_path / "nope").exists()


def test_write_into_read_only_directory(tmp_path, monkeypatch):
    """A directory without write permission is a PermissionError naming the path. Root
    may write anywhere, so there the permission check (os.access) is made to answer as
    it does for an ordinary user on a 0o555 directory."""
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        real_access = os.access
        monkeypatch.setattr(exr.os, "access", lambda p, mode: False if Path(p) == ro else real_access(p, mode))
    try:
        with pytest.raises(PermissionError, match="not writable"):
            random_image().write_exr(ro / "f.exr")
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o755)


def _corrupt_variants(good: bytes) -> dict[str, bytes]:
    rng = np.random.default_rng(7)
    noisy = bytearray(good)
    for i in rng.integers(len(good) // 3, len(good), 40):
        noisy[i] ^= 0xFF
    return {
        "empty.exr": b"",
        "random.exr": rng.integers(0, 256, 4096, dtype=np.uint8).tobytes(),
        "text.exr": b"this is not an EXR file\n" * 20,
        "magic_only.exr": good[:8],
        "header_cut.exr": good[:200],
        "half.exr": good[: len(good) // 2],
        "last_byte_missing.exr": good[:-1],
        "flipped.exr": bytes(noisy),
    }


def test_corrupt_files_raise_scene_error(tmp_path, capfd):
    """Truncated, random or damaged bytes: one-line SceneError naming the file, and the
    OpenEXR library's own warnings are not let through to stdout / stderr."""
    good_path = tmp_path / "good.exr"
    random_image().write_exr(good_path)
    good = good_path.read_bytes()
    capfd.readouterr()
    for name, data in _corrupt_variants(good).items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(SceneError) as info:
            warp_st.read_exr(path)
        message = str(info.value)
        assert name in message and "\n" not in message, message
        assert not exr.is_complete_exr(path), name
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_missing_file_and_missing_channels(tmp_path):
    """No file is a SceneError naming the file; an EXR without R, G, B, A reads with
    them at their fill value 0, and is complete unless the caller asks for them."""
    with pytest.raises(SceneError, match="absent.exr"):
        warp_st.read_exr(tmp_path / "absent.exr")
    assert not exr.is_complete_exr(tmp_path / "absent.exr")

    path = tmp_path / "depth_only.exr"
    header = {"type": OpenEXR.scanlineimage, "compression": OpenEXR.ZIP_COMPRESSION}
    depth = np.arange(16, dtype=np.float32).reshape(4, 4)
    OpenEXR.File(header, {"Z": depth}).write(str(path))
    back = warp_st.read_exr(path)
    assert back.channels == ("Z",) and back.channel_names == ("Z",)
    assert_bitwise(back.depth, depth, "Z")
    assert not back.rgba.any()
    assert exr.is_complete_exr(path) and exr.is_complete_exr(path, ("Z",))
    assert not exr.is_complete_exr(path, REQUIRED_CHANNELS)

    path = tmp_path / "float_ids.exr"
    planes = {n: np.zeros((4, 4), np.float32) for n in ("R", "G", "B", "A", "objectId")}
    OpenEXR.File(dict(header), planes).write(str(path))
    with pytest.raises(SceneError, match="objectId is FLOAT, expected UINT"):
        warp_st.read_exr(path)


def test_foreign_rgba_exr_reads(tmp_path):
    """A plain RGBA EXR from another tool reads, with the spacetime channels at background."""
    path = tmp_path / "plain.exr"
    rgba = np.random.default_rng(1).random((4, 5, 4)).astype(np.float32)
    header = {"type": OpenEXR.scanlineimage, "compression": OpenEXR.ZIP_COMPRESSION}
    OpenEXR.File(header, {c: rgba[..., i].copy() for i, c in enumerate("RGBA")}).write(str(path))
    back = warp_st.read_exr(path)
    assert_bitwise(back.rgba, rgba, "rgba")
    assert back.channels == REQUIRED_CHANNELS
    assert back.id_manifest == {} and back.metadata == {}
    assert exr.is_complete_exr(path)


def test_is_complete_exr(tmp_path):
    """--resume trusts exactly the files that decode completely."""
    path = tmp_path / "ok.exr"
    random_image().write_exr(path)
    assert exr.is_complete_exr(path) and exr.is_complete_exr(path, CHANNEL_NAMES)
    assert not exr.is_complete_exr(path, ("R", "beauty.R"))
    data = path.read_bytes()
    path.write_bytes(data[:-16])
    assert not exr.is_complete_exr(path)
