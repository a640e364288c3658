"""EXR read/write for :class:`warp_st.output.film.Image` (docs/spec.md §4). The only OpenEXR import.

File layout: one scanline part, ZIP compression (lossless for FLOAT and UINT),
channels from the registry :data:`warp_st.output.film.CHANNELS` (FLOAT stored float32,
``objectId`` and ``spacetime.bounces`` UINT). ``spacetime.eventTime`` and
``spacetime.sourceTime`` hold float32 (t - spacetime:timeOrigin). A list of
:class:`~warp_st.output.film.OutputChannel` (a UsdRender product's RenderVars) writes
exactly those channels instead, renamed, FLOAT ones optionally as HALF; the
header is the same.

Header attributes:

- ``spacetime:cameraTime``, ``spacetime:timeOrigin``, ``spacetime:frame``: doubles
  (OpenEXR's Python binding writes a Python float as a 32-bit ``float``
  attribute; a float64 numpy array becomes a ``double`` one).
- ``spacetime:precision`` and ``spacetime:version``: strings.
- ``spacetime:run``: written by a sequence (:func:`warp_st.output.plan.write_outputs`), the
  canonical JSON of what the run that wrote the file rendered (software version, stage
  hash, the options that change pixels, frame, channels; see
  :func:`warp_st.output.plan.run_identity`). ``--resume`` keeps a file only when it equals
  the current run's. An image read back and written again drops it: it is no run's output.
- ``spacetime:<key>``: every ``Image.metadata`` item, as a string.
- ``idManifest``: the standard OpenEXR ID manifest (``Imf::IDManifest``), one
  channel group on the channel(s) holding ``objectId`` (whatever their name; no
  manifest when none is written), component ``primPath``, ids not hashed,
  lifetime "shot" (ids are stage traversal order: stable over the frames of one
  stage). Compositors that read ID manifests find the prim path of each id there.
- ``cryptomatte/<key>/name``, ``/hash``, ``/conversion``, ``/manifest``: strings, for each
  Cryptomatte layer of ``Image.cryptomatte`` whose rank channels the file holds, under the
  name they are written with (:mod:`warp_st.output.cryptomatte`, docs/spec.md §4.4).

Writes are atomic: the file is encoded into ``.NAME.<pid>.tmp`` in the target
directory, fsynced and renamed over the final name, so an interrupted or failed
write never leaves a truncated file under the final name.
"""
from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path

import numpy as np
import OpenEXR

from warp_st.core.native_output import captured_output
from warp_st.core.scene import SceneError
from warp_st.core.version import __version__
from warp_st.output import cryptomatte
from warp_st.output.channels import CHANNEL_NAMES, OutputChannel, channel_spec

__all__ = ["write_exr", "read_file", "read_header", "is_complete_exr", "completeness", "atomic_output",
           "check_output_path", "ATTR_RUN"]

ATTR_PREFIX = "spacetime:"
ATTR_CAMERA_TIME = "spacetime:cameraTime"
ATTR_TIME_ORIGIN = "spacetime:timeOrigin"
ATTR_FRAME = "spacetime:frame"
ATTR_PRECISION = "spacetime:precision"
ATTR_VERSION = "spacetime:version"
ATTR_RUN = "spacetime:run"
ATTR_ID_MANIFEST = "idManifest"
#: ID manifest channel group: the channel it describes and its component name.
MANIFEST_CHANNEL = "objectId"
MANIFEST_COMPONENT = "primPath"

#: Header keys written from Image fields; metadata may not use them.
_RESERVED_KEYS = {"cameraTime", "timeOrigin", "frame", "precision", "idManifest"}
_DOUBLE_ATTRS = {ATTR_CAMERA_TIME: "camera_time", ATTR_TIME_ORIGIN: "time_origin", ATTR_FRAME: "frame"}


# --- atomic output ---------------------------------------------------------------


def check_output_path(path) -> Path:
    """Fail early (an OSError naming ``path``) if ``path`` cannot be written.

    The directory must exist and be writable and ``path`` must not be a directory.
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise FileNotFoundError(errno.ENOENT, f"cannot write {path}: directory {directory} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise PermissionError(errno.EACCES, f"cannot write {path}: directory {directory} is not writable")
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, f"cannot write {path}: it is a directory")
    return path


def _temp_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


@contextlib.contextmanager
def atomic_output(path):
    """Open a temporary binary file next to ``path``; on success rename it onto ``path``.

    Usage: ``with atomic_output(p) as fh: fh.write(...)``. The temp file is
    fsynced before ``os.replace``; on any exception (KeyboardInterrupt included) it
    is removed and ``path`` is left as it was.
    """
    path = check_output_path(path)
    tmp = _temp_name(path)
    try:
        fh = open(tmp, "wb")
    except OSError as exc:
        raise type(exc)(exc.errno, f"cannot write {path}: {exc.strerror}") from exc
    try:
        with fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.errno is not None and str(path) not in str(exc):
            raise type(exc)(exc.errno, f"cannot write {path}: {exc.strerror or exc}") from exc
        raise
    # Make the rename itself durable; not all platforms allow fsync on a directory.
    with contextlib.suppress(OSError):
        dir_fd = os.open(path.parent if str(path.parent) else ".", os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)


# --- writing -------------------------------------------------------------------


def _id_manifest(id_manifest: dict[int, str], channels: set[str]):
    manifest = OpenEXR.IDManifest()
    group = manifest.add(channels)
    group.setComponent(MANIFEST_COMPONENT)
    group.setHashScheme(OpenEXR.ID_MANIFEST_NOTHASHED)
    group.setEncodingScheme(OpenEXR.ID_MANIFEST_ID_SCHEME)
    group.setLifetime(OpenEXR.LIFETIME_SHOT)
    for object_id, prim_path in sorted(id_manifest.items()):
        group.insert(int(object_id), str(prim_path))
    return manifest


def _header(image, id_channels: set[str], run: str | None = None) -> dict:
    header = {
        "type": OpenEXR.scanlineimage,
        "compression": OpenEXR.ZIP_COMPRESSION,
        "lineOrder": OpenEXR.INCREASING_Y,
    }
    for attr, field_name in _DOUBLE_ATTRS.items():
        header[attr] = np.array([getattr(image, field_name)], dtype=np.float64)
    header[ATTR_PRECISION] = str(image.precision)
    for key, value in image.metadata.items():
        if key in ("version", "run"):
            continue  # read back from a file; the writer's own version (and run record) win
        if not key or key in _RESERVED_KEYS:
            raise ValueError(f"Image.metadata key {key!r} is empty or reserved")
        header[ATTR_PREFIX + key] = str(value)
    header[ATTR_VERSION] = str(__version__)
    if run is not None:
        header[ATTR_RUN] = str(run)
    if image.id_manifest and id_channels:
        header[ATTR_ID_MANIFEST] = _id_manifest(image.id_manifest, id_channels)
    return header


def _encode(header: dict, channels: dict, fh) -> None:
    """Encode one scanline EXR into the open binary file ``fh``."""
    OpenEXR.File(header, channels).write(fh)


def _file_planes(image, channels) -> tuple[dict[str, np.ndarray], set[str]]:
    """({EXR name: stored array}, names holding objectId) of an OutputChannel list (None: all)."""
    if channels is None:
        channels = [OutputChannel(name, name) for name in image.channel_names]
    planes: dict[str, np.ndarray] = {}
    for channel in map(OutputChannel._make, channels):
        if not channel.name or channel.name in planes:
            raise ValueError(f"EXR channel name {channel.name!r} is empty or given twice")
        plane = image.file_channel(channel.source)
        if channel.half:
            if plane.dtype.kind != "f":
                raise ValueError(f"channel {channel.source} is {plane.dtype}, it cannot be stored as HALF")
            with np.errstate(over="ignore"):  # beyond 65504: +-inf, as any HALF writer
                plane = plane.astype(np.float16)
        planes[channel.name] = plane
    if not planes:
        raise ValueError("no channels to write")
    ids = {c.name for c in map(OutputChannel._make, channels) if c.source == MANIFEST_CHANNEL}
    return planes, ids


def _cryptomatte_header(image, channels) -> dict[str, str]:
    """The ``cryptomatte/<key>/*`` attributes of the layers the channels write."""
    pairs = ([(name, name) for name in image.channel_names] if channels is None
             else [(c.name, c.source) for c in map(OutputChannel._make, channels)])
    attrs: dict[str, str] = {}
    for typename, layer in cryptomatte.written_layers(image.cryptomatte, pairs).items():
        attrs.update(cryptomatte.header_attributes(typename, image.cryptomatte[layer]))
    return attrs


def write_exr(image, path, channels=None, *, run: str | None = None) -> None:
    """Write ``image`` to ``path`` (docs/spec.md §4), atomically.

    channels: None writes ``image.channel_names`` under their own names; otherwise
    :class:`~warp_st.output.film.OutputChannel` items (name, source, half); OpenEXR stores
    the channels sorted by name. run: the ``spacetime:run`` record (None: none).
    Raises an OSError naming ``path`` if its directory is missing or not writable;
    a failure while encoding leaves ``path`` untouched and no temporary file.
    """
    planes, id_channels = _file_planes(image, channels)
    header = {**_header(image, id_channels, run), **_cryptomatte_header(image, channels)}
    with atomic_output(path) as fh:
        _encode(header, planes, fh)


# --- reading -------------------------------------------------------------------


def _native_detail(captured: list[str], exc: BaseException) -> str:
    """A short one-line reason from the library's exception and its printed text."""
    lines = [ln.strip() for text in captured for ln in text.splitlines() if ln.strip()]
    for ln in lines:
        if "EXR_ERR" in ln:
            return ln.split(": ", 1)[-1]
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def _open_pixels(path: Path):
    """(header dict, {name: OpenEXR.Channel}) of part 0; SceneError on any failure."""
    if not path.exists():
        raise SceneError(f"{path}: no such file")
    if path.is_dir():
        raise SceneError(f"{path}: is a directory, not an EXR file")
    with captured_output((1, 2), python_streams=True) as captured:
        try:
            with OpenEXR.File(str(path), separate_channels=True) as f:
                header = dict(f.header())
                channels = dict(f.channels())
                planes = {name: np.array(ch.pixels) for name, ch in channels.items()}
                types = {name: ch.type() for name, ch in channels.items()}
                parts = len(f.parts)
            error = None
        except Exception as exc:  # the binding raises RuntimeError / ValueError
            error = exc
    if error is not None:
        raise SceneError(f"{path}: not a readable EXR file ({_native_detail(captured, error)})") from None
    return header, planes, types, parts


def _header_float(header: dict, key: str, default: float) -> float:
    if key not in header:
        return default
    try:
        return float(np.asarray(header[key], dtype=np.float64).ravel()[0])
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"header attribute {key} is not a number: {_safe_display(header[key])}") from None


def _read_manifest(manifest) -> dict[int, str]:
    """The prim paths of the group on ``objectId``, else of the first ``primPath`` group
    (objectId written under another name)."""
    result: dict[int, str] = {}
    if manifest is None:
        return result
    if not isinstance(manifest, OpenEXR.IDManifest):
        raise ValueError(f"header attribute {ATTR_ID_MANIFEST} is damaged ({type(manifest).__name__})")
    index = manifest.find(MANIFEST_CHANNEL)
    if index >= manifest.size():
        index = next((i for i in range(manifest.size())
                      if list(manifest[i].getComponents()) == [MANIFEST_COMPONENT]), manifest.size())
    if index >= manifest.size():
        return result
    for entry in manifest[index]:
        text = list(entry.text())
        result[int(entry.id())] = text[0] if len(text) == 1 else "/".join(text)
    return result


def read_file(path) -> dict:
    """Decode an EXR written by :func:`write_exr` (or any other scanline EXR) into the
    keyword arguments of :meth:`warp_st.output.film.Image.from_file_channels`.

    ``planes`` holds the SPEC channels present (stored values, times still relative);
    ``extra`` every other channel (renamed RenderVars) as stored. A missing, corrupt or
    non-EXR file, or a damaged header, raises :class:`warp_st.SceneError` naming the file.
    """
    path = Path(path)
    header, planes, types, _ = _open_pixels(path)
    if not planes:
        raise SceneError(f"{path}: has no channels")
    known = {}
    extra = {name: plane for name, plane in planes.items() if name not in CHANNEL_NAMES}
    for name in CHANNEL_NAMES:
        if name not in planes:
            continue
        spec = channel_spec(name)
        kind = str(types[name]).rsplit(".", 1)[-1]
        if spec.pixel_type == "UINT" and kind != "UINT":
            raise SceneError(f"{path}: channel {name} is {kind}, expected UINT")
        if spec.pixel_type == "FLOAT" and kind == "UINT":
            raise SceneError(f"{path}: channel {name} is UINT, expected FLOAT")
        known[name] = planes[name]  # HALF from other tools is widened to float32 by the Image
    metadata = {
        key[len(ATTR_PREFIX):]: value
        for key, value in header.items()
        if key.startswith(ATTR_PREFIX) and isinstance(value, str) and key != ATTR_PRECISION
    }
    try:
        time_origin = _header_float(header, ATTR_TIME_ORIGIN, 0.0)
        return dict(
            planes=known,
            time_origin=time_origin,
            camera_time=_header_float(header, ATTR_CAMERA_TIME, time_origin),
            frame=_header_float(header, ATTR_FRAME, float("nan")),
            precision=str(header.get(ATTR_PRECISION, "")),
            id_manifest=_read_manifest(header.get(ATTR_ID_MANIFEST)),
            metadata=metadata,
            cryptomatte=cryptomatte.read_layers(header),
            extra=extra,
        )
    except (KeyError, ValueError, TypeError) as exc:  # a damaged or foreign header
        raise SceneError(f"{path}: {exc}") from None


def _display(value) -> str:
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "f" and value.size == 1:
            return repr(float(value.ravel()[0]))
        return np.array2string(value, separator=", ")
    if isinstance(value, tuple):
        return "(" + ", ".join(_display(v) for v in value) + ")"
    if isinstance(value, (OpenEXR.Compression, OpenEXR.LineOrder, OpenEXR.Storage)):
        return str(value).rsplit(".", 1)[-1]
    if isinstance(value, OpenEXR.IDManifest):
        groups = [sorted(value[i].getChannels()) for i in range(value.size())]
        return f"ID manifest, {value.size()} channel group(s): {groups}"
    if isinstance(value, list):  # the channel list
        return ", ".join(getattr(c, "name", str(c)) for c in value)
    return str(value)


def _safe_display(value) -> str:
    """_display, or a placeholder for a value a damaged file makes undisplayable (bad UTF-8)."""
    try:
        return _display(value)
    except Exception:  # noqa: BLE001 - display only
        return f"<unreadable {type(value).__name__}>"


def read_header(path) -> dict[str, str]:
    """Every header attribute of part 0 as display text (for ``warp-st inspect``).

    Doubles print with repr (shortest exact form). SceneError if unreadable.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"{path}: no such file")
    with captured_output((1, 2), python_streams=True) as captured:
        try:
            with OpenEXR.File(str(path), header_only=True) as f:
                header = dict(f.header())
            error = None
        except Exception as exc:
            error = exc
    if error is not None:
        raise SceneError(f"{path}: not a readable EXR file ({_native_detail(captured, error)})") from None
    return {key: _safe_display(header[key]) for key in sorted(header)}


def completeness(path, channels=()) -> tuple[str | None, dict, tuple[str, ...]]:
    """``(None, header, channel names)`` if ``path`` is a readable EXR whose pixels all
    decode, all channels the same non-empty size, holding every name in ``channels``;
    else ``(why not, {}, ())``, the reason a short phrase (``missing``, ``not a readable
    EXR file (...)``, ...). Used by ``--resume`` (:func:`warp_st.output.plan.resume_check`).
    """
    path = Path(path)
    if not path.exists():
        return "missing", {}, ()
    try:
        header, planes, _, parts = _open_pixels(path)
    except SceneError as exc:
        return str(exc).removeprefix(f"{path}: "), {}, ()
    if parts < 1 or not planes:
        return "has no channels", {}, ()
    absent = [n for n in channels if n not in planes]
    if absent:
        return f"lacks the channel(s) {', '.join(absent)}", {}, ()
    shapes = {plane.shape for plane in planes.values()}
    if len(shapes) != 1 or not all(s > 0 for s in next(iter(shapes))):
        return "has channels of different or empty sizes", {}, ()
    return None, header, tuple(sorted(planes))


def is_complete_exr(path, channels=()) -> bool:
    """True if ``path`` is a complete EXR holding every name in ``channels`` (see
    :func:`completeness`)."""
    return completeness(path, channels)[0] is None
