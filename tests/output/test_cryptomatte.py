"""Cryptomatte (docs/spec.md §4.4): the CryptoObject and CryptoMaterial layers decode to each
object's (material's) pixels.

Oracles:
- the Cryptomatte specification 1.1.0 (Psyop, github.com/Psyop/Cryptomatte,
  ``specification/cryptomatte_specification.rtf``): its example manifests give names with
  their ids (the hash test vectors), its text the id conversion and the file layout. The
  decoder below is written from that text and reads the file with ``OpenEXR`` directly; it
  does not call warp_st's encoder (``warp_st.output.cryptomatte``). Ids are hashed here with
  the ``mmh3`` library itself.
- the beauty: the test stage has no lights, so each object shows its unlit albedo, pure red,
  green or blue, on black. With S samples a pixel's R (G, B) is then (number of samples whose
  first hit is the red (green, blue) object) / S, computed by the kernel's own beauty sum: an
  independent count of the same samples. With S = 16 both are exact multiples of 1/16.
- ``objectId`` with its ``idManifest`` (one ray per pixel, the pixel centre).
- brute force (collections.Counter) for the ranking of arbitrary sample ids.
"""
from __future__ import annotations

import collections
import json
import re

import mmh3
import numpy as np
import OpenEXR
import pytest

from warp_st.commands.cli import main
from warp_st.output import cryptomatte
from warp_st.output.film import CHANNEL_NAMES

STAGE = '''#usda 1.0
(
    startTimeCode = 0
    endTimeCode = 3
)
def Camera "Cam" {
    double3 xformOp:translate = (0, 0, 6)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 20
}
def Scope "Looks" {
    def Material "RedMat" {
        token outputs:surface.connect = </Looks/RedMat/PS.outputs:surface>
        def Shader "PS" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface
        }
    }
    def Material "BlueMat" {
        token outputs:surface.connect = </Looks/BlueMat/PS.outputs:surface>
        def Shader "PS" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0, 0, 1)
            token outputs:surface
        }
    }
}
def Cube "Red" (prepend apiSchemas = ["MaterialBindingAPI"]) {
    rel material:binding = </Looks/RedMat>
    double size = 1.5
    double3 xformOp:translate = (-1, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    color3f[] primvars:displayColor = [(1, 0, 0)]
}
def Sphere "Green" {
    double radius = 1
    double3 xformOp:translate = (0.2, 0.4, -1)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    color3f[] primvars:displayColor = [(0, 1, 0)]
}
def Xform "Fast" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {
    double4 spacetime:fourVelocity = (1, 0.6, 0, 0)
    double3 xformOp:translate = (4, -0.9, 0.5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "Blue" (prepend apiSchemas = ["MaterialBindingAPI"]) {
        rel material:binding = </Looks/BlueMat>
        double size = 1
        color3f[] primvars:displayColor = [(0, 0, 1)]
    }
}
'''
#: body prim path -> the beauty component its albedo lights (the stage above); the same for
#: the bound materials (/Green has none: displayColor).
COLOUR = {"/Red": 0, "/Green": 1, "/Fast": 2}
MATERIAL_COLOUR = {"/Looks/RedMat": 0, "/Looks/BlueMat": 2}
SIZE = ("--width", "48", "--height", "27")


# --- a decoder from the specification's text -------------------------------------------------

def read(path):
    """(header, {channel: (pixel type, pixels)}) straight from OpenEXR."""
    with OpenEXR.File(str(path), separate_channels=True) as f:
        header = dict(f.header())
        chans = {n: (str(c.type()).rsplit(".", 1)[-1], np.array(c.pixels)) for n, c in f.channels().items()}
    return header, chans


def layer(header, typename):
    """(key, manifest) of the layer named ``typename``: "exr/cryptomatte/<key>/name = <typename>",
    its manifest "a JSON dictionary, where the names are the keys and ... the values are the IDs"."""
    keys = [k.split("/")[1] for k, v in header.items()
            if re.fullmatch(r"cryptomatte/[^/]+/name", k) and v == typename]
    assert len(keys) == 1, sorted(header)
    return keys[0], json.loads(header[f"cryptomatte/{keys[0]}/manifest"])


def id_from_hex(text: str) -> np.float32:
    """"the hashes are hexadecimal versions of bytes making up the 32-bit float hashes": the
    C++ sample copies the float's bits into a uint32 and prints it with %08x."""
    assert re.fullmatch(r"[0-9a-f]{8}", text), text
    return np.array([int(text, 16)], dtype=np.uint32).view(np.float32)[0]


def spec_hash_to_float(name: str) -> np.float32:
    """The specification's hash_to_float of MurmurHash3_x86_32(name, seed 0): the bits copied,
    the exponent clamped to [1, 254]."""
    h = mmh3.hash(name.encode(), 0, signed=False)
    exponent = min(max((h >> 23) & 0xFF, 1), 254)
    bits = (h & 0x80000000) | (exponent << 23) | (h & 0x7FFFFF)
    return np.array([bits], dtype=np.uint32).view(np.float32)[0]


def matte(chans, typename, hex_id):
    """Sum over the ranks of the coverage where the rank's id is ``hex_id``'s
    ("{typename}00.r - ID rank 0, {typename}00.g - Coverage for ID rank 0, .b - ID rank 1,
    .a - Coverage for ID rank 1", and so on for 01, 02, ...)."""
    target = id_from_hex(hex_id)
    groups = sorted({n[len(typename):len(typename) + 2] for n in chans
                     if re.fullmatch(re.escape(typename) + r"\d\d\.[RGBA]", n)})
    assert groups, sorted(chans)
    total = None
    for g in groups:
        for id_c, cov_c in (("R", "G"), ("B", "A")):
            ids, cov = chans[f"{typename}{g}.{id_c}"][1], chans[f"{typename}{g}.{cov_c}"][1]
            part = np.where(ids == target, cov, np.float32(0.0))
            total = part if total is None else total + part
    return total


def id_manifest(header) -> dict[int, str]:
    m = header["idManifest"]
    return {int(e.id()): "/".join(e.text()) for i in range(m.size()) for e in m[i]}


# --- renders ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """The stage rendered with --cryptomatte at 1 and 16 samples, and without it."""
    out = tmp_path_factory.mktemp("crypto")
    (out / "tiny.usda").write_text(STAGE)
    files = {}
    for name, extra in (("one", ["--cryptomatte"]), ("sixteen", ["--cryptomatte", "--samples", "16"]),
                        ("plain", ["--samples", "16"])):
        files[name] = out / f"{name}.exr"
        assert main(["render", str(out / "tiny.usda"), "-o", str(files[name]), *SIZE, *extra, "--quiet"]) == 0
    return files


def test_specification_hash_vectors():
    """Law: the specification's example manifests, names -> ids, literally: {"bunny":"13851a76",
    "default":"42c9679f"} and {"bunny_porcelain_mat":"b24b26d4"} (Cryptomatte specification
    1.1.0, EXR File, Metadata)."""
    vectors = {"bunny": "13851a76", "default": "42c9679f", "bunny_porcelain_mat": "b24b26d4"}
    assert {name: cryptomatte.id_hex(name) for name in vectors} == vectors
    assert cryptomatte.manifest(vectors) == vectors


def test_conversion_clamps_the_exponent_only():
    """Law (specification, Floating point conversion): the float32 id is the hash's bits with
    the exponent clamped to [1, 254]: sign and mantissa kept, never NaN, inf, zero or
    denormal. Hashes with exponent 0 and 255 and both signs, against the spec's formula."""
    hashes = [0x00000000, 0x00000001, 0x807FFFFF, 0x7F800000, 0xFFFFFFFF, 0x3F800000, 0x13851A76]
    got = cryptomatte.id_float(np.array(hashes, dtype=np.uint32))
    for h, value in zip(hashes, got):
        exponent = min(max((h >> 23) & 0xFF, 1), 254)
        expected = (h & 0x80000000) | (exponent << 23) | (h & 0x7FFFFF)
        assert int(np.array([value]).view(np.uint32)[0]) == expected, hex(h)
    assert np.all(np.isfinite(got)) and np.all(np.abs(got) >= np.finfo(np.float32).tiny)


@pytest.mark.parametrize("block", [None, 3 * 12])
def test_ranking_matches_brute_force(monkeypatch, block):
    """Law: per pixel, the distinct non-zero sample ids by count (ties: the lower id first),
    each with coverage count / S; at most 6 ranks (3 groups); empty ranks 0, 0.
    Oracle: collections.Counter per pixel. Pixels of 12 samples over ids 0..8 (up to 8
    distinct objects: more than 6 ranks) and all-background pixels; in one block, and in
    blocks of 3 pixels (the last one shorter)."""
    if block is not None:
        monkeypatch.setattr(cryptomatte, "_BLOCK_SAMPLES", block)
    rng = np.random.default_rng(7)
    ids = rng.integers(0, 9, size=(5, 7, 12))
    ids[0, 0] = 0
    names = [f"/Obj{i}" for i in range(1, 9)]
    planes = cryptomatte.rank_samples(ids, names)
    table = {i: spec_hash_to_float(n) for i, n in enumerate(names, 1)}
    for y in range(5):
        for x in range(7):
            counts = collections.Counter(int(v) for v in ids[y, x] if v != 0)
            ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))[:6]
            ranked += [(None, 0)] * (6 - len(ranked))
            for r, (obj, count) in enumerate(ranked):
                g, second = divmod(r, 2)
                id_c, cov_c = ("R", "G") if second == 0 else ("B", "A")
                want = np.float32(0.0) if obj is None else table[obj]
                assert planes[f"{g:02d}.{id_c}"][y, x] == want, (y, x, r)
                assert planes[f"{g:02d}.{cov_c}"][y, x] == np.float32(count / 12), (y, x, r)


def test_file_opens_as_a_compositor_reads_it(renders):
    """Law: OpenEXR reads the file; CryptoObject00..02 .R .G .B .A are FLOAT (32-bit); the
    header names the layer with the hash and conversion the specification requires, under a
    key of 7 hex digits of the layer name's MurmurHash3 (mmh3 itself); the manifest is JSON."""
    header, chans = read(renders["sixteen"])
    for typename in ("CryptoObject", "CryptoMaterial"):
        expected = [f"{typename}{g:02d}.{c}" for g in range(3) for c in "RGBA"]
        assert {n: chans[n][0] for n in expected} == dict.fromkeys(expected, "FLOAT")
        assert all(chans[n][1].dtype == np.float32 for n in expected)
        key, names = layer(header, typename)
        assert key == f"{mmh3.hash(typename.encode(), 0, signed=False):08x}"[:7]
        assert header[f"cryptomatte/{key}/hash"] == "MurmurHash3_32"
        assert header[f"cryptomatte/{key}/conversion"] == "uint32_to_float32"
        assert isinstance(names, dict) and names


@pytest.mark.parametrize("render", ["one", "sixteen"])
def test_manifest_matches_the_id_manifest(renders, render):
    """Law: the manifest names exactly the idManifest's prim paths, each with the hex of the
    specification's float conversion of its MurmurHash3."""
    header, _ = read(renders[render])
    _, names = layer(header, "CryptoObject")
    assert set(names) == set(id_manifest(header).values()) == set(COLOUR)
    for path, hex_id in names.items():
        assert id_from_hex(hex_id).view(np.uint32) == spec_hash_to_float(path).view(np.uint32), path


def test_one_sample_mattes_are_the_object_id_pixels(renders):
    """Law: with one sample a pixel's matte of an object is 1 where objectId names it and 0
    elsewhere, and equals the beauty component of the object's colour (ray 0 is the sample)."""
    header, chans = read(renders["one"])
    _, names = layer(header, "CryptoObject")
    object_id = chans["objectId"][1]
    for oid, path in id_manifest(header).items():
        m = matte(chans, "CryptoObject", names[path])
        np.testing.assert_array_equal(m, (object_id == oid).astype(np.float32), err_msg=path)
        np.testing.assert_array_equal(m, chans["RGB"[COLOUR[path]]][1], err_msg=path)
        assert (m == 1).sum() > 50, path  # the object is seen


def test_sixteen_sample_mattes_are_the_beauty_coverage(renders):
    """Law: with 16 samples each object's matte equals, bit for bit, the beauty component its
    colour lights (the fraction of the pixel's samples that hit it, counted by the kernel's
    beauty): 1 inside the object, fractional (k/16) on its edges; the mattes sum to the alpha."""
    header, chans = read(renders["sixteen"])
    _, names = layer(header, "CryptoObject")
    total = np.zeros_like(chans["A"][1])
    for path, hex_id in names.items():
        m = matte(chans, "CryptoObject", hex_id)
        np.testing.assert_array_equal(m, chans["RGB"[COLOUR[path]]][1], err_msg=path)
        edge = (m > 0) & (m < 1)
        assert (m == 1).sum() > 50 and edge.sum() > 10, path
        np.testing.assert_array_equal(m * 16, np.round(m * 16), err_msg=path)  # k / 16 exactly
        total = total + m
    np.testing.assert_array_equal(total, chans["A"][1])


@pytest.mark.parametrize("render", ["one", "sixteen"])
def test_material_mattes_are_their_objects_coverage(renders, render):
    """Law: CryptoMaterial names the bound materials' prim paths (not /Green's displayColor),
    and each material's matte equals the beauty component of its colour; pixels of the
    unbound /Green are in no material rank (the material mattes sum to R + B)."""
    header, chans = read(renders[render])
    _, names = layer(header, "CryptoMaterial")
    assert set(names) == set(MATERIAL_COLOUR)
    total = np.zeros_like(chans["A"][1])
    for path, hex_id in names.items():
        assert id_from_hex(hex_id).view(np.uint32) == spec_hash_to_float(path).view(np.uint32), path
        m = matte(chans, "CryptoMaterial", hex_id)
        np.testing.assert_array_equal(m, chans["RGB"[MATERIAL_COLOUR[path]]][1], err_msg=path)
        assert (m == 1).sum() > 50, path
        total = total + m
    np.testing.assert_array_equal(total, chans["R"][1] + chans["B"][1])


def test_prism_path_mattes_are_the_beauty_coverage(tmp_path):
    """Law: the float64 prism path (its own triangle tables) gives the same laws: each object's
    and material's matte is the beauty component of its colour (16 samples)."""
    import warp_st

    (tmp_path / "tiny.usda").write_text(STAGE)
    image = warp_st.render(warp_st.load(tmp_path / "tiny.usda"), width=48, height=27, samples=16,
                           precision="float64", cryptomatte=True)
    image.write_exr(tmp_path / "f64.exr")
    header, chans = read(tmp_path / "f64.exr")
    for typename, colours in (("CryptoObject", COLOUR), ("CryptoMaterial", MATERIAL_COLOUR)):
        _, names = layer(header, typename)
        assert set(names) == set(colours)
        for path, hex_id in names.items():
            m = matte(chans, typename, hex_id)
            np.testing.assert_array_equal(m, chans["RGB"[colours[path]]][1], err_msg=path)
            assert ((m > 0) & (m < 1)).sum() > 10, path


def test_shared_material_merges_its_objects():
    """Law: two bodies bound to one material are one CryptoMaterial id whose coverage is the
    sum of theirs; a triangle without a material (path "") is in no rank."""
    # triangles 0, 1: body 0 and 1 with material 0 (/M); triangle 2: body 2, no material
    sample_tris = np.array([[[1, 2, 3, 0], [1, 1, 1, 3]]])
    planes, manifests = cryptomatte.image_layers(sample_tris, ("CryptoObject", "CryptoMaterial"), [0, 1, 2],
                                                 ["/A", "/B", "/C"], [0, 0, 1], ["/M", ""])
    assert manifests["CryptoMaterial"] == {"/M": f"{int(spec_hash_to_float('/M').view(np.uint32)):08x}"}
    np.testing.assert_array_equal(planes["CryptoMaterial00.R"], [[spec_hash_to_float("/M")] * 2])
    np.testing.assert_array_equal(planes["CryptoMaterial00.G"], [[0.5, 0.75]])
    np.testing.assert_array_equal(planes["CryptoMaterial00.A"], [[0.0, 0.0]])  # nothing else
    np.testing.assert_array_equal(planes["CryptoObject00.G"], [[0.25, 0.75]])  # /A alone, then 3 x /A


def test_without_the_option_the_channels_are_as_before(renders):
    """Law: a render without --cryptomatte (and no product asking for it) writes exactly the
    docs/spec.md §4 channels and no cryptomatte header; with it, the SPEC channels are the
    same bit for bit."""
    header, chans = read(renders["plain"])
    assert set(chans) == set(CHANNEL_NAMES)
    assert not [k for k in header if k.startswith("cryptomatte/")]
    _, with_crypto = read(renders["sixteen"])
    assert set(with_crypto) - set(chans) == {*cryptomatte.rank_channels("CryptoObject"),
                                             *cryptomatte.rank_channels("CryptoMaterial")}
    for name in CHANNEL_NAMES:
        np.testing.assert_array_equal(with_crypto[name][1], chans[name][1], err_msg=name)


def test_resume_keeps_a_cryptomatte_file(tmp_path, capsys):
    """Law: --resume keeps an all-channel file that holds the run's Cryptomatte layer (it is
    the same run's output), and renders it again when the run no longer asks for it."""
    (tmp_path / "tiny.usda").write_text(STAGE)
    argv = ["render", str(tmp_path / "tiny.usda"), "-o", str(tmp_path / "c.exr"), *SIZE, "--cryptomatte"]
    assert main(argv + ["--quiet"]) == 0
    capsys.readouterr()
    assert main(argv + ["--resume"]) == 0
    assert "already complete" in capsys.readouterr().out
    assert main(argv[:-1] + ["--resume"]) == 0
    assert "already complete" not in capsys.readouterr().out
    _, chans = read(tmp_path / "c.exr")
    assert set(chans) == set(CHANNEL_NAMES)


def test_unknown_layer_is_bad_input(tmp_path):
    """Law: the Python API refuses a layer it does not compute, naming the option."""
    import warp_st

    (tmp_path / "tiny.usda").write_text(STAGE)
    scene = warp_st.load(tmp_path / "tiny.usda")
    with pytest.raises(warp_st.SceneError, match="cryptomatte.*CryptoAsset"):
        warp_st.render(scene, width=8, height=8, cryptomatte="CryptoAsset")


def test_read_back_keeps_the_layer(renders, tmp_path):
    """Law: read_exr -> write_exr keeps the rank channels bit for bit and the manifest."""
    import warp_st

    image = warp_st.read_exr(renders["sixteen"])
    assert set(image.cryptomatte) == {"CryptoObject", "CryptoMaterial"}
    image.write_exr(tmp_path / "again.exr")
    h1, c1 = read(renders["sixteen"])
    h2, c2 = read(tmp_path / "again.exr")
    for typename in image.cryptomatte:
        assert layer(h1, typename) == layer(h2, typename)
        for name in cryptomatte.rank_channels(typename):
            np.testing.assert_array_equal(c1[name][1].view(np.uint32), c2[name][1].view(np.uint32), err_msg=name)


def test_material_with_an_unsupported_shader_keeps_its_name(tmp_path):
    """Law: a gprim bound to a material warp_st cannot shade (not a UsdPreviewSurface; drawn
    with displayColor) is still named by that material in CryptoMaterial; a gprim with only
    displayColor has no material name. Oracle: the stage's own binding paths."""
    import warp_st

    (tmp_path / "s.usda").write_text(STAGE.replace('uniform token info:id = "UsdPreviewSurface"\n'
                                                   '            color3f inputs:diffuseColor = (0, 0, 1)',
                                                   'uniform token info:id = "SomeOtherShader"'))
    scene = warp_st.load(tmp_path / "s.usda")
    paths = {b.prim_path: b.surfaces[0].material.prim_path for b in scene.bodies}
    assert paths == {"/Red": "/Looks/RedMat", "/Green": "", "/Fast": "/Looks/BlueMat"}
    assert scene.bodies[2].surfaces[0].material.diffuse == (0.0, 0.0, 1.0)  # its displayColor
