"""Cryptomatte layers (docs/spec.md §4.4): ids, the ranking of a pixel's samples, the header.

Follows the Cryptomatte specification 1.1.0 (Psyop, ``specification/cryptomatte_specification``
of github.com/Psyop/Cryptomatte). A layer ``{typename}`` is ``GROUPS`` float32 RGBA channel
groups ``{typename}00 .. {typename}02``; group g holds rank 2g (R: id, G: coverage) and rank
2g + 1 (B: id, A: coverage), ranks sorted by coverage, largest first. A name's id is the
MurmurHash3_32 (x86, seed 0) of its UTF-8 bytes, made a float32 by copying the bits with the
exponent clamped to [1, 254] (never NaN, inf, zero or denormal). An empty rank holds id 0.0
and coverage 0.0. The header carries, per layer, ``cryptomatte/<key>/name``, ``/hash``
(``MurmurHash3_32``), ``/conversion`` (``uint32_to_float32``) and ``/manifest`` (JSON, name ->
8 hex digits of the id's float32 bits); the key is the first 7 hex digits of the hash of the
layer's name.
"""
from __future__ import annotations

import json
import re

import mmh3
import numpy as np

__all__ = ["LAYERS", "GROUPS", "RANKS", "HASH", "CONVERSION", "hash32", "id_float", "id_hex", "layer_key",
           "rank_channels", "is_rank_channel", "manifest", "rank_samples", "header_attributes",
           "written_layers", "read_layers", "resolve_layers", "image_layers"]

#: The layers warp_st writes. Their names (what the ids hash): CryptoObject, the prim path of
#: the body a sample hits first; CryptoMaterial, that of the triangle's bound material.
LAYERS = ("CryptoObject", "CryptoMaterial")
#: RGBA channel groups per layer (the specification's suggested default: 6 ranks).
GROUPS = 3
RANKS = 2 * GROUPS
HASH = "MurmurHash3_32"
CONVERSION = "uint32_to_float32"
_COMPONENTS = ("R", "G", "B", "A")
_BLOCK_SAMPLES = 1 << 20
_ATTR = re.compile(r"cryptomatte/([^/]+)/(name|hash|conversion|manifest)")


def hash32(name: str) -> int:
    """MurmurHash3_32 (seed 0) of ``name``'s UTF-8 bytes, unsigned."""
    return mmh3.hash(name.encode("utf-8"), 0, signed=False)


def id_float(hashes) -> np.ndarray:
    """uint32 hashes -> their float32 ids: the same bits, the exponent clamped to [1, 254]."""
    bits = np.asarray(hashes, dtype=np.uint32)
    exponent = np.clip((bits >> np.uint32(23)) & np.uint32(0xFF), 1, 254).astype(np.uint32)
    bits = (bits & np.uint32(0x807FFFFF)) | (exponent << np.uint32(23))
    return bits.view(np.float32)


def id_hex(name: str) -> str:
    """The manifest's text for ``name``: 8 hex digits of its float32 id's bits."""
    return f"{int(id_float(np.uint32(hash32(name))).view(np.uint32)):08x}"


def layer_key(typename: str) -> str:
    """The header key of a layer: the first 7 hex digits of its name's hash."""
    return f"{hash32(typename):08x}"[:7]


def rank_channels(typename: str, groups: int = GROUPS) -> tuple[str, ...]:
    """``{typename}00.R .. {typename}NN.A``, group by group."""
    return tuple(f"{typename}{g:02d}.{c}" for g in range(groups) for c in _COMPONENTS)


def is_rank_channel(channel: str, typename: str) -> bool:
    """True when ``channel`` is one of ``typename``'s rank channels (any number of groups)."""
    return re.fullmatch(re.escape(typename) + r"\d\d\.[RGBA]", channel) is not None


def manifest(names) -> dict[str, str]:
    """The manifest of ``names``: name -> :func:`id_hex`."""
    return {str(name): id_hex(str(name)) for name in names}


def _ranked(ids: np.ndarray, ranks: int) -> tuple[np.ndarray, np.ndarray]:
    """(index, coverage), each (N, ranks), of the ids (N, S) of N pixels (see rank_samples)."""
    n, s = ids.shape
    ids = np.sort(ids, axis=1)
    starts = np.ones(ids.shape, dtype=bool)
    starts[:, 1:] = ids[:, 1:] != ids[:, :-1]
    rows, cols = np.nonzero(starts)  # row-major: each pixel's runs of equal ids, in order
    ends = np.append(cols[1:], s)
    ends[np.append(rows[1:] != rows[:-1], True)] = s
    values, counts = ids[rows, cols], ends - cols
    hit = values != 0
    rows, values, counts = rows[hit], values[hit], counts[hit]
    # One sort key: pixel, then count (largest first), then id; rows are already in order.
    span = int(values.max(initial=0)) + 1
    order = np.argsort((rows * (s + 1) + (s - counts)) * span + values, kind="stable")
    rows, values, counts = rows[order], values[order], counts[order]
    rank = np.arange(len(rows)) - np.searchsorted(rows, rows, side="left")
    kept = rank < ranks
    index = np.zeros((n, ranks), dtype=np.int64)
    coverage = np.zeros((n, ranks), dtype=np.float32)
    index[rows[kept], rank[kept]] = values[kept]
    coverage[rows[kept], rank[kept]] = (counts[kept] / s).astype(np.float32)
    return index, coverage


def rank_samples(sample_ids: np.ndarray, names, groups: int = GROUPS) -> dict[str, np.ndarray]:
    """A layer's rank planes from per-sample ids.

    sample_ids: (H, W, S) integers, 0 for a sample that hit nothing, i >= 1 for one whose
        first hit is ``names[i - 1]``. Each sample weighs 1 / S (the beauty's box filter).
    Returns ``{suffix: (H, W) float32}`` for the suffixes ``00.R .. NN.A``: per pixel the
    distinct names its samples hit, by coverage (ties: the lower index first), as
    (id, coverage) pairs; samples that hit nothing are in no rank. Pixels are ranked in
    blocks of about a million samples (bounded host memory).
    """
    h, w, s = sample_ids.shape
    ranks = 2 * groups
    flat = np.asarray(sample_ids).reshape(h * w, s)
    block = max(1, _BLOCK_SAMPLES // s)
    parts = [_ranked(flat[i:i + block].astype(np.int64), ranks) for i in range(0, h * w, block)]
    index = np.concatenate([p[0] for p in parts])
    coverage = np.concatenate([p[1] for p in parts])
    table = np.concatenate([np.zeros(1, np.float32), id_float([hash32(str(n)) for n in names])])
    id_planes = table[index]
    planes = {}
    for r in range(ranks):  # 00.R, 00.G, 00.B, 00.A, 01.R, ...
        g, second = divmod(r, 2)
        planes[f"{g:02d}.{_COMPONENTS[2 * second]}"] = id_planes[:, r].reshape(h, w)
        planes[f"{g:02d}.{_COMPONENTS[2 * second + 1]}"] = coverage[:, r].reshape(h, w)
    return planes


def header_attributes(typename: str, names: dict[str, str]) -> dict[str, str]:
    """The four header attributes of a layer written as ``typename`` with manifest ``names``."""
    key = f"cryptomatte/{layer_key(typename)}/"
    return {key + "name": typename, key + "hash": HASH, key + "conversion": CONVERSION,
            key + "manifest": json.dumps(names, sort_keys=True, separators=(",", ":"))}


def written_layers(layers, channels) -> dict[str, str]:
    """``{written typename: layer}`` of the (EXR name, source channel) pairs of a file: a
    layer is written under the name its rank channels carry (a renamed RenderVar)."""
    found = {}
    for name, source in channels:
        for layer in layers:
            if is_rank_channel(source, layer) and name.endswith(source[len(layer):]):
                found[name[: len(name) - len(source) + len(layer)]] = layer
    return found


def read_layers(header: dict) -> dict[str, dict[str, str]]:
    """``{typename: manifest}`` of the Cryptomatte layers a header describes (a manifest
    that is absent or not a JSON object of strings reads as empty)."""
    fields: dict[str, dict[str, str]] = {}
    for attr, value in header.items():
        match = _ATTR.fullmatch(str(attr))
        if match and isinstance(value, str):
            fields.setdefault(match[1], {})[match[2]] = value
    layers = {}
    for entry in fields.values():
        if "name" not in entry:
            continue
        try:
            names = json.loads(entry.get("manifest", "{}"))
        except ValueError:
            names = {}
        if not isinstance(names, dict):
            names = {}
        layers[entry["name"]] = {str(k): str(v) for k, v in names.items()}
    return layers


def resolve_layers(value, products=()) -> tuple[str, ...]:
    """The layers a render computes: ``value`` True (all of :data:`LAYERS`), False (none), a
    layer name or names; None: those the stage's render ``products`` name as a RenderVar
    sourceName. ValueError for an unknown name."""
    if value is None:
        named = {var.source_name for product in products for var in product.vars}
        return tuple(layer for layer in LAYERS if layer in named)
    if isinstance(value, (bool, np.bool_)):
        return LAYERS if value else ()
    names = (value,) if isinstance(value, str) else tuple(value)
    unknown = [n for n in names if n not in LAYERS]
    if unknown:
        raise ValueError(f"unknown Cryptomatte layer {unknown[0]!r}; known: {', '.join(LAYERS)}")
    return tuple(layer for layer in LAYERS if layer in names)


def image_layers(sample_tris: np.ndarray, layers, tri_body, body_paths, tri_material,
                 material_paths) -> tuple[dict[str, np.ndarray], dict[str, dict]]:
    """(rank planes by channel name, {layer: manifest}) of ``layers``.

    sample_tris: (H, W, S), 1 + the triangle each sample hits first, 0: none. tri_body,
    tri_material: per triangle, the index into ``body_paths`` / ``material_paths`` (a
    material path "" is no material: its samples are in no CryptoMaterial rank).
    """
    sample_tris = np.asarray(sample_tris, dtype=np.int32)
    planes, manifests = {}, {}
    for layer in layers:
        if layer == "CryptoObject":
            names = list(body_paths)
            lookup = np.asarray(tri_body, dtype=np.int32) + 1
        else:
            names = sorted({p for p in material_paths if p})
            index = {p: i + 1 for i, p in enumerate(names)}
            lookup = np.array([index.get(p, 0) for p in material_paths], dtype=np.int32)[
                np.asarray(tri_material, dtype=np.int64)]
        ids = np.concatenate([np.zeros(1, np.int32), lookup])[sample_tris]
        planes.update({layer + suffix: plane for suffix, plane in rank_samples(ids, names).items()})
        manifests[layer] = manifest(names)
    return planes, manifests
