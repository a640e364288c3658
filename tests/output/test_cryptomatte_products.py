"""Cryptomatte requested by the stage (docs/usd_render_products.md): a RenderVar with sourceName
CryptoObject writes the layer under its aov name, equal to the command line's --cryptomatte.

Oracles: the files are opened with ``OpenEXR`` directly; the product's rank channels are
compared bit for bit with those of an ``-o --cryptomatte`` render of the same view (the
renderer is deterministic); the header attributes against the ``mmh3`` library's hash.
"""
from __future__ import annotations

import mmh3
import numpy as np
from test_cryptomatte import SIZE, STAGE, read

from warp_st.commands.cli import main


def render_settings(var: str) -> str:
    return f'''
def Scope "Render" {{
    def RenderSettings "Settings" {{
        uniform int2 resolution = (48, 27)
        rel camera = </Cam>
        rel products = [</Render/File>]
    }}
    def RenderProduct "File" {{
        token productName = "mattes.exr"
        rel orderedVars = [</Render/Beauty>, </Render/Mattes>]
    }}
    def RenderVar "Beauty" {{
        uniform string sourceName = "color"
        uniform token dataType = "color4f"
    }}
    def RenderVar "Mattes" {{
{var}
    }}
}}
'''


def test_render_var_writes_the_layer_under_its_aov_name(tmp_path, monkeypatch):
    """Law: the product holds Beauty.R .G .B .A and objmatte00..02 .R .G .B .A (FLOAT), bit-equal to
    the CryptoObject channels of an -o --cryptomatte render, and the header names the layer
    objmatte (key: mmh3 of "objmatte") with the full render's manifest."""
    var = ('        uniform string sourceName = "CryptoObject"\n'
           '        uniform string driver:parameters:aov:name = "objmatte"')
    (tmp_path / "s.usda").write_text(STAGE + render_settings(var))
    monkeypatch.chdir(tmp_path)
    assert main(["render", "s.usda", "--samples", "4", "--quiet"]) == 0
    assert main(["render", "s.usda", "--samples", "4", "-o", "full.exr", "--cryptomatte", *SIZE, "--quiet"]) == 0
    header, chans = read(tmp_path / "mattes.exr")
    full_header, full = read(tmp_path / "full.exr")
    ranks = [f"{g:02d}.{c}" for g in range(3) for c in "RGBA"]
    assert {n: t for n, (t, _) in chans.items()} == dict.fromkeys([f"Beauty.{c}" for c in "RGBA"] + [f"objmatte{r}" for r in ranks],
                                                                  "FLOAT")
    for r in ranks:
        np.testing.assert_array_equal(chans[f"objmatte{r}"][1].view(np.uint32),
                                      full[f"CryptoObject{r}"][1].view(np.uint32), err_msg=r)
    key = f"{mmh3.hash(b'objmatte', 0, signed=False):08x}"[:7]
    full_key = f"{mmh3.hash(b'CryptoObject', 0, signed=False):08x}"[:7]
    assert header[f"cryptomatte/{key}/name"] == "objmatte"
    assert header[f"cryptomatte/{key}/manifest"] == full_header[f"cryptomatte/{full_key}/manifest"]
    assert sorted(k for k in header if k.startswith("cryptomatte/")) == sorted(
        f"cryptomatte/{key}/{a}" for a in ("name", "hash", "conversion", "manifest"))


def test_half_cryptomatte_var_is_bad_input(tmp_path, monkeypatch, capsys):
    """Law: a Cryptomatte RenderVar stored as HALF (ids would be lost) is exit 2 with a one-line
    error naming the file, the var and dataType; nothing is written."""
    var = ('        uniform string sourceName = "CryptoObject"\n'
           '        uniform token dataType = "color4h"')
    (tmp_path / "s.usda").write_text(STAGE + render_settings(var))
    monkeypatch.chdir(tmp_path)
    assert main(["render", "s.usda", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "s.usda" in err and "/Render/Mattes" in err and "dataType" in err, err
    assert not list(tmp_path.glob("*.exr"))
