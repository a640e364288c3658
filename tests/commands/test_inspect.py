"""``warp-st inspect``: statistics, one pixel, false-colour PNGs, contact sheets, ``--diff``.

Oracles: the closed-form first hit of a past null ray with a moving sphere
(``warp_st.core.lorentz.sphere_hit``, float64) for ``--pixel`` on a rendered USD stage, with
its proper time derived independently (tests/independent_kinematics.py) and the Doppler
factor's closed form 1/(γ(1 + n·v));
NumPy on the planes written for statistics and ``--diff``; matplotlib's own colour
maps evaluated at the values written for the PNGs.

Tolerances of the analytic pixel (the same derivation as tests/rendering/test_analytic_sphere.py):

- tessellation: the sphere is an authored Mesh of ``SEGMENTS`` longitudes, every vertex on
  the sphere of radius R, so in the body's rest frame ball(R - g) ⊆ mesh ⊆ ball(R), g from
  the mesh (``analytic_scenes.tessellation_gap``, 6.0e-4 R here). The rest-frame position
  along a past null ray is affine in the lookback s, so the hit lies in [s_outer, s_inner]
  of the two balls; t = t_c - s and τ (affine in s) lie between their values there.
- float32: the kernels work in float32 about the camera event: ε_s = 256 eps32 γ(1 + β)(s + R);
  the EXR stores t - t_c and τ as float32: + 2 eps32 |value|. Proper time adds
  64 eps32 γ (|t_c - t_ref| + |c - o|) for forming t - t_ref and x - o. The authored points
  are point3f: each vertex moves by ≤ eps32 R, far inside ε_s.
- Doppler depends only on the pixel direction and v: 64 eps32 (1 + β/|1 + n·v|) + 2 eps32 relative.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from types import SimpleNamespace

import analytic_scenes as AS
import independent_kinematics as IK
import matplotlib
import numpy as np
import pytest

import warp_st
from warp_st.commands import inspect_diff
from warp_st.output import plot
from warp_st.commands.cli import main
from warp_st.core import lorentz, tessellate
from warp_st.output.film import CHANNEL_NAMES, Image, channel_spec

matplotlib.use("Agg")
EPS32 = AS.EPS32


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1 and lines[0].startswith("warp-st: error: "), err
    return lines[0]


# --- --pixel on a known scene -------------------------------------------------------------

RADIUS, SEGMENTS = 1.0, 128
BETA = 0.6
CENTRE = np.array([0.0, 0.0, -6.0])
T_C = 100.0  # the rendered frame = the camera time (no spacetime:time authored)
T_REF = T_C - 6.0  # the centre is seen straight ahead (on the camera's past lightcone)
WIDTH, HEIGHT, FOCAL, H_AP = 64, 48, 39.1, 20.955


def _mesh_text() -> str:
    points, triangles, _ = tessellate.sphere(RADIUS, SEGMENTS)
    pts = ", ".join(f"({x!r}, {y!r}, {z!r})" for x, y, z in points.astype(np.float32).astype(np.float64).tolist())
    idx = ", ".join(str(int(i)) for i in triangles.ravel())
    counts = ", ".join("3" for _ in range(len(triangles)))
    return f"point3f[] points = [{pts}]\n        int[] faceVertexCounts = [{counts}]\n        int[] faceVertexIndices = [{idx}]"


def analytic_stage(path: Path) -> Path:
    """A Mesh sphere moving at 0.6c along +x (Lorentz coupled), a camera at rest at the origin."""
    path.write_text(f"""#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 1
)

def Camera "Cam"
{{
    float focalLength = {FOCAL}
    float horizontalAperture = {H_AP}
    float verticalAperture = {H_AP * HEIGHT / WIDTH}
}}

def Xform "Ball" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{{
    double3 xformOp:translate = ({CENTRE[0]}, {CENTRE[1]}, {CENTRE[2]})
    uniform token[] xformOpOrder = ["xformOp:translate"]
    custom double4 spacetime:fourVelocity = (1, {BETA}, 0, 0)
    custom double spacetime:referenceTime = {T_REF}

    def Mesh "Surface"
    {{
        {_mesh_text()}
    }}
}}
""")
    return path


def _pixel_values(out: str) -> dict[str, str]:
    values = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0] in CHANNEL_NAMES:
            values[parts[0]] = parts[1]
        if line.strip().startswith("prim: "):
            values["prim"] = line.split("prim: ", 1)[1]
        m = re.search(r"t_c - t = (\S+)\)", line)
        if m and parts[0] == "spacetime.eventTime":
            values["lookback"] = m.group(1)
    return values


@pytest.mark.parametrize("pixel", [(32, 24), (40, 19), (22, 30)])
def test_pixel_prints_the_analytic_event_and_proper_time(tmp_path, capsys, monkeypatch, pixel):
    """real renderer: render the stage through the CLI, then ``inspect --pixel``: the printed
    eventTime, lookback, Z, properTime and Doppler are the closed form's, the prim is /Ball."""
    monkeypatch.chdir(tmp_path)
    stage = analytic_stage(tmp_path / "ball.usda")
    code, _, err = run(capsys, "render", stage, "-o", "ball.exr", "--frame", T_C, "--width", WIDTH,
                       "--height", HEIGHT, "--quiet")
    assert code == 0, err
    x, y = pixel
    code, out, err = run(capsys, "inspect", "ball.exr", "--pixel", x, y)
    assert code == 0, err
    got = _pixel_values(out)
    assert got["prim"] == "/Ball"

    cam = SimpleNamespace(horizontal_aperture=H_AP, focal_length=FOCAL, horizontal_aperture_offset=0.0,
                          vertical_aperture_offset=0.0)
    n = AS.pixel_directions_camera(cam, WIDTH, HEIGHT)[y, x]  # rotation: identity (camera at the origin)
    v = np.array([BETA, 0.0, 0.0])
    gap = AS.tessellation_gap(AS.SphereCase(name="mesh", velocity=tuple(v), radius=RADIUS, segments=SEGMENTS))
    outer, inner = (lorentz.sphere_hit(T_C, np.zeros(3), n, CENTRE, r, v, T_REF) for r in (RADIUS, RADIUS - gap))
    assert np.isfinite(inner.s), "the pixel must see the inner ball too (not near the limb)"
    s_lo, s_hi = float(outer.s), float(inner.s)
    g = 1.0 / math.sqrt(1.0 - BETA * BETA)
    eps_s = 256 * EPS32 * g * (1 + BETA) * (s_hi + RADIUS) + 2 * EPS32 * s_hi

    t = float(got["spacetime.eventTime"])
    assert T_C - s_hi - eps_s <= t <= T_C - s_lo + eps_s, (t, T_C - s_hi, T_C - s_lo)
    assert float(got["lookback"]) == pytest.approx(T_C - t, abs=1e-12)
    z = float(got["Z"])
    assert s_lo - eps_s <= z <= s_hi + eps_s, (z, s_lo, s_hi)

    # docs/spec.md §2 proper time of the two balls' hit events, as their rest-frame time
    # (independent_kinematics: the boost as exp(-φK), not lorentz.proper_time)
    tau = float(got["spacetime.properTime"])
    a, b = (float(IK.proper_time(np.concatenate([[h.event_time], h.position]), CENTRE, T_REF, v)) for h in (outer, inner))
    eps_tau = (g * (1 + BETA) * eps_s + 64 * EPS32 * g * (abs(T_C - T_REF) + float(np.linalg.norm(CENTRE)))
               + 2 * EPS32 * abs(a))
    assert min(a, b) - eps_tau <= tau <= max(a, b) + eps_tau, (tau, a, b)

    # camera at rest, body at v: D = 1 / (γ (1 + n·v)) (the photon moves along -n)
    d = float(got["spacetime.doppler"])
    rel = 64 * EPS32 * (1 + BETA / abs(1 + float(n @ v))) + 2 * EPS32
    assert d == pytest.approx(1.0 / (g * (1.0 + float(n @ v))), rel=rel)


def test_pixel_background_and_extra_channels(tmp_path, capsys):
    """A background pixel names no prim; an extra (renamed RenderVar) channel prints as stored."""
    h, w = 2, 3
    img = Image(rgba=np.zeros((h, w, 4), np.float32), object_id=np.array([[1, 0, 0], [0, 0, 0]]),
                id_manifest={1: "/A"}, extra={"beauty.R": np.full((h, w), 0.25, np.float16)})
    path = tmp_path / "x.exr"
    img.write_exr(path)
    code, out, err = run(capsys, "inspect", path, "--pixel", 1, 0)
    assert code == 0, err
    assert "prim: none (background)" in out and re.search(r"beauty\.R\s+0\.25", out)
    code, out, _ = run(capsys, "inspect", path, "--pixel", 0, 0)
    assert "prim: /A" in out


# --- statistics -----------------------------------------------------------------------------


def test_statistics_match_numpy(tmp_path, capsys):
    """Per channel: min / max / mean over finite values and the NaN, +inf, -inf counts, as
    NumPy computes them on the planes read back (float32 printed exactly)."""
    rng = np.random.default_rng(7)
    h, w = 9, 11
    depth = rng.uniform(1, 50, (h, w)).astype(np.float32)
    depth[rng.random((h, w)) < 0.3] = np.inf
    depth[0, 0] = -np.inf
    doppler = rng.lognormal(0, 0.5, (h, w)).astype(np.float32)
    doppler[rng.random((h, w)) < 0.25] = np.nan
    img = Image(rgba=rng.random((h, w, 4), dtype=np.float32), depth=depth, doppler=doppler,
                event_time=1e6 - rng.uniform(0, 10, (h, w)), object_id=rng.integers(0, 5, (h, w)),
                camera_time=1e6)
    path = tmp_path / "s.exr"
    img.write_exr(path)
    back = warp_st.read_exr(path)
    code, out, err = run(capsys, "inspect", path)
    assert code == 0, err
    rows = {ln.split()[0]: ln.split() for ln in out.split("channels (")[1].splitlines()[2:]}
    assert set(rows) == set(CHANNEL_NAMES)
    for name in CHANNEL_NAMES:
        plane = back.channel(name)
        row = rows[name]
        if plane.dtype.kind == "f":
            finite = plane[np.isfinite(plane)]
            counts = [int(np.isnan(plane).sum()), int(np.isposinf(plane).sum()), int(np.isneginf(plane).sum())]
        else:
            finite, counts = plane.ravel(), [0, 0, 0]
        assert [int(c) for c in row[5:8]] == counts, name
        if finite.size == 0:
            assert row[2:5] == ["-", "-", "-"], name
            continue
        assert row[2] == str(plane.dtype.type(finite.min())) and row[3] == str(plane.dtype.type(finite.max())), name
        assert float(row[4]) == pytest.approx(float(np.mean(finite, dtype=np.float64)), rel=1e-8), name


# --- PNGs -------------------------------------------------------------------------------------


def _spread_image(h=6, w=8):
    """Every channel with a spread of values and some background pixels."""
    ramp = np.linspace(0.5, 2.0, h * w).reshape(h, w)
    hit = np.ones((h, w), bool)
    hit[:, -2:] = False
    return Image(rgba=np.dstack([ramp / 2] * 3 + [hit.astype(float)]).astype(np.float32),
                 depth=np.where(hit, ramp * 3, np.inf), event_time=np.where(hit, 10 - ramp, np.nan),
                 proper_time=np.where(hit, ramp, np.nan), doppler=np.where(hit, ramp, np.nan),
                 object_id=np.where(hit, 1 + (ramp > 1), 0), source_time=np.where(hit, 9 - ramp, np.nan),
                 bounces=np.where(hit, ramp > 1.5, 0), camera_time=10.0, frame=10, id_manifest={1: "/A", 2: "/B"})


@pytest.mark.parametrize("name", CHANNEL_NAMES)
def test_channel_figure_has_title_units_and_colour_bar(name):
    """Every SPEC channel: the title names the file and channel, the colour bar is labelled
    with the channel's units (film.CHANNELS), the picture shows the values in that map."""
    fig = plot.channel_figure(_spread_image(), "f.exr", name)
    try:
        ax, bar = fig.axes[0], fig.axes[1]
        assert ax.get_title().startswith(f"f.exr: {name}") and "frame 10" in ax.get_title()
        assert channel_spec(name).units in bar.get_ylabel()
        picture = ax.get_images()[0]
        data = plot.shown(name, plot.plane(_spread_image(), name, relative=True))
        assert np.array_equal(np.ma.getmaskarray(picture.get_array()), ~np.isfinite(data))
        if name in ("Z", "objectId") or math.isnan(channel_spec(name).background):
            assert np.ma.getmaskarray(picture.get_array())[:, -2:].all()  # the background: grey
        if channel_spec(name).relative_time:  # drawn as t - t_c
            assert np.nanmax(data) < 0 and "t - t_c" in bar.get_ylabel()
    finally:
        plot._pyplot().close(fig)


def test_object_ids_get_one_colour_each():
    c = plot.colouring("objectId", [np.array([np.nan, 1.0, 2.0, 3.0])], "u")
    rgba = [tuple(c.cmap(c.norm(k))) for k in (1, 2, 3)]
    assert len(set(rgba)) == 3 and all(len(set(x[:3])) > 1 for x in rgba)  # distinct, none grey


def test_doppler_scale_is_logarithmic_and_centred_on_one():
    c = plot.colouring("spacetime.doppler", [np.array([0.5, 1.0, 1.6, np.nan])], "u")
    assert c.norm.vmin == pytest.approx(1 / 2.0) and c.norm.vmax == pytest.approx(2.0)
    assert c.norm(1.0) == pytest.approx(0.5)  # white, the middle of RdBu


def test_png_written_and_pixels_are_the_colour_map(tmp_path, capsys):
    """CLI: the PNG exists, holds the colour map's colours of the values and grey background."""
    img = Image(rgba=np.zeros((4, 8, 4), np.float32), depth=np.array([[1.0] * 4 + [3.0] * 2 + [np.inf] * 2] * 4))
    path = tmp_path / "z.exr"
    img.write_exr(path)
    png = tmp_path / "z.png"
    code, out, err = run(capsys, "inspect", path, "--channel", "Z", "--png", png)
    assert code == 0 and out.strip() == f"wrote {png}", err
    rgb = (matplotlib.image.imread(png)[..., :3] * 255).round().astype(int).reshape(-1, 3)
    viridis = matplotlib.colormaps["viridis"]
    # Z = 1 and 3: the ends of the scale; grey 0.5: the +inf background. A block of each
    # (>= 1000 pixels of a ~500 x 250 picture), to 1 in 255 (matplotlib truncates to 8 bits).
    for want in (viridis(0.0)[:3], viridis(1.0)[:3], (0.5, 0.5, 0.5)):
        close = (np.abs(rgb - np.array(want) * 255) <= 1.0).all(axis=1)
        assert close.sum() > 1000, want


def test_png_bad_input(tmp_path, capsys):
    img = _spread_image()
    path = tmp_path / "a.exr"
    img.write_exr(path)
    code, _, err = run(capsys, "inspect", path, "--channel", "nope", "--png", tmp_path / "n.png")
    assert code == 2 and "unknown channel 'nope'" in one_error_line(err)
    code, _, err = run(capsys, "inspect", path, "--channel", "RGB")
    assert code == 2 and "--png" in one_error_line(err)
    code, _, err = run(capsys, "inspect", path, "--tolerance", "1")
    assert code == 2 and "--diff" in one_error_line(err)
    assert not (tmp_path / "n.png").exists()


# --- contact sheets ---------------------------------------------------------------------------

PURE = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0, 0.0), (0.0, 1.0, 1.0)]


def _solid_sequence(tmp_path, colours, pattern="seq.%04d.exr"):
    paths = []
    for k, colour in enumerate(colours):
        rgba = np.zeros((6, 8, 4), np.float32)
        rgba[...] = (*colour, 1.0)
        depth = np.full((6, 8), float(k + 1))
        p = tmp_path / (pattern % (10 * k))
        Image(rgba=rgba, depth=depth, frame=10 * k, camera_time=10 * k).write_exr(p)
        paths.append(p)
    return paths


def _centroids(png, colours):
    """Centre (row, column) of the pixels of each colour in the PNG (to 1 in 255: 8 bits)."""
    rgb = matplotlib.image.imread(png)[..., :3] * 255
    out = []
    for colour in colours:
        ys, xs = np.nonzero((np.abs(rgb - np.array(colour) * 255) <= 1.0).all(axis=-1))
        assert ys.size > 100, f"thumbnail of colour {colour} not found"
        out.append((ys.mean(), xs.mean()))
    return out


@pytest.mark.parametrize("columns, grid", [(None, (2, 3)), (2, (3, 2)), (5, (1, 5))])
def test_contact_sheet_grid(tmp_path, capsys, columns, grid):
    """Five solid-colour frames: the sheet reports the grid and each thumbnail sits in its
    row-major cell (rows and columns recovered from the colour centroids)."""
    paths = _solid_sequence(tmp_path, PURE)
    sheet = tmp_path / "sheet.png"
    argv = ["inspect", *paths, "--contact-sheet", sheet] + (["--columns", columns] if columns else [])
    code, out, err = run(capsys, *argv)
    assert code == 0, err
    assert f"{grid[0]} x {grid[1]} grid" in out
    cents = _centroids(sheet, PURE)
    rows_of = np.unique(np.round([c[0] for c in cents], -1))
    assert len(rows_of) == grid[0]
    for k, (cy, cx) in enumerate(cents):
        row, col = divmod(k, grid[1])
        same_row = [cents[j] for j in range(len(cents)) if divmod(j, grid[1])[0] == row]
        same_col = [cents[j] for j in range(len(cents)) if divmod(j, grid[1])[1] == col]
        assert all(abs(c[0] - cy) < 2 for c in same_row) and all(abs(c[1] - cx) < 2 for c in same_col)
        if col:
            assert cx > cents[k - 1][1]
        if row:
            assert cy > cents[k - grid[1]][0]


def test_contact_sheet_shares_one_colour_scale(tmp_path, capsys):
    """Z = 1, 2, 3 in three frames: the thumbnails are viridis(0), viridis(0.5), viridis(1)."""
    paths = _solid_sequence(tmp_path, PURE[:3])
    sheet = tmp_path / "z.png"
    code, out, err = run(capsys, "inspect", str(tmp_path / "seq.####.exr"), "--channel", "Z", "--contact-sheet", sheet)
    assert code == 0 and "Z of 3 EXR(s)" in out, err
    viridis = matplotlib.colormaps["viridis"]
    _centroids(sheet, [viridis(x)[:3] for x in (0.0, 0.5, 1.0)])
    del paths


def test_contact_sheet_inputs(tmp_path, capsys):
    """A #### pattern with --frames, without (every match, in frame order), a glob; bad input exit 2."""
    _solid_sequence(tmp_path, PURE)
    sheet = tmp_path / "s.png"
    code, out, err = run(capsys, "inspect", tmp_path / "seq.####.exr", "--frames", "0-20x10", "--contact-sheet", sheet)
    assert code == 0 and "of 3 EXR(s)" in out, err
    code, out, err = run(capsys, "inspect", tmp_path / "seq.####.exr", "--contact-sheet", sheet)
    assert code == 0 and "of 5 EXR(s)" in out, err
    code, out, err = run(capsys, "inspect", str(tmp_path / "seq.00[0-2]0.exr"), "--contact-sheet", sheet)
    assert code == 0 and "of 3 EXR(s)" in out, err
    sheet.unlink()
    code, _, err = run(capsys, "inspect", tmp_path / "seq.####.exr", "--frames", "0-50x10", "--contact-sheet", sheet)
    assert code == 2 and "seq.0050.exr" in one_error_line(err) and not sheet.exists()
    code, _, err = run(capsys, "inspect", tmp_path / "none.*.exr", "--contact-sheet", sheet)
    assert code == 2 and "no file matches" in one_error_line(err)
    code, _, err = run(capsys, "inspect", tmp_path / "seq.0000.exr", tmp_path / "seq.0010.exr")
    assert code == 2 and "--contact-sheet" in one_error_line(err)


def test_grid_shape():
    assert [plot.grid_shape(n) for n in (1, 2, 4, 5, 9, 10)] == [(1, 1), (1, 2), (2, 2), (2, 3), (3, 3),
                                                                          (3, 4)]
    assert plot.grid_shape(7, 3) == (3, 3) and plot.grid_shape(2, 9) == (1, 2)


# --- --diff -----------------------------------------------------------------------------------


def _pair(tmp_path):
    """Two EXRs that differ by known amounts on Z and eventTime; equal NaN / inf backgrounds."""
    rng = np.random.default_rng(3)
    h, w = 7, 9
    hit = rng.random((h, w)) < 0.7
    z = np.where(hit, rng.uniform(1, 9, (h, w)), np.inf).astype(np.float32)
    t = np.where(hit, 50 - z, np.nan)
    base = dict(rgba=np.zeros((h, w, 4), np.float32), camera_time=50.0, object_id=hit.astype(int))
    a = Image(depth=z, event_time=t, **base)
    dz = np.where(hit, rng.normal(0, 1e-3, (h, w)), 0.0).astype(np.float32)
    b = Image(depth=z + dz, event_time=t + np.where(hit, 2e-3, 0.0), **base)
    pa, pb = tmp_path / "a.exr", tmp_path / "b.exr"
    a.write_exr(pa)
    b.write_exr(pb)
    return pa, pb


def _diff_rows(out):
    return {ln.split()[0]: ln.split() for ln in out.splitlines() if ln.startswith("  ") and ln.split()[0] != "channel"}


def test_diff_metrics_against_numpy(tmp_path, capsys):
    """Printed max-abs, rms, differing count and fraction are NumPy's on the planes read
    back (NaN == NaN and inf == inf count as equal), per channel."""
    pa, pb = _pair(tmp_path)
    a, b = warp_st.read_exr(pa), warp_st.read_exr(pb)
    code, out, err = run(capsys, "inspect", pa, "--diff", pb, "--tolerance", "1", "--threshold", "5e-4")
    assert code == 0, err
    rows = _diff_rows(out)
    assert set(rows) == set(CHANNEL_NAMES)
    for name in CHANNEL_NAMES:
        x, y = a.channel(name).astype(np.float64), b.channel(name).astype(np.float64)
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        with np.errstate(invalid="ignore"):  # inf - inf on the equal backgrounds, masked by `same`
            d = np.where(same, 0.0, np.abs(x - y))
        assert np.isfinite(d).all()
        want = (d.max(), math.sqrt(np.mean(d ** 2)), int((d > 5e-4).sum()), (d > 5e-4).mean())
        row = rows[name]
        assert float(row[1]) == pytest.approx(want[0], rel=1e-5, abs=1e-300), name
        assert float(row[2]) == pytest.approx(want[1], rel=1e-5, abs=1e-300), name
        assert int(row[3]) == want[2] and float(row[4]) == pytest.approx(want[3], rel=1e-3), name  # 4 digits
        assert row[5] == "ok"
    assert rows["Z"][1] != "0" and rows["spacetime.eventTime"][3] == str(int(np.isfinite(a.event_time).sum()))


@pytest.mark.parametrize("metric", inspect_diff.METRICS)
def test_diff_tolerance_sets_the_exit_status(tmp_path, capsys, metric):
    """Exit 0 at a tolerance equal to the largest metric value, 1 just below it."""
    pa, pb = _pair(tmp_path)
    a, b = warp_st.read_exr(pa), warp_st.read_exr(pb)
    worst = max(inspect_diff.channel_diff(n, a.channel(n), b.channel(n)).metric(metric) for n in CHANNEL_NAMES)
    assert worst > 0
    code, out, _ = run(capsys, "inspect", pa, "--diff", pb, "--metric", metric, "--tolerance", repr(worst))
    assert code == 0 and "within the tolerance" in out
    code, out, _ = run(capsys, "inspect", pa, "--diff", pb, "--metric", metric, "--tolerance", repr(worst * 0.999))
    assert code == 1 and "OVER" in out
    code, out, _ = run(capsys, "inspect", pa, "--diff", pa, "--metric", metric)  # identical: 0 at tolerance 0
    assert code == 0


def test_channel_diff_non_finite_rules():
    a = np.array([np.nan, np.inf, -np.inf, 1.0, np.nan, np.inf, 2.0])
    b = np.array([np.nan, np.inf, -np.inf, 1.0, 0.0, -np.inf, 2.5])
    d = inspect_diff.channel_diff("x", a, b)
    assert d.max_abs == math.inf and d.rms == math.inf and d.differing == 3 and d.pixels == 7
    d = inspect_diff.channel_diff("x", a[:4], b[:4])
    assert (d.max_abs, d.rms, d.differing) == (0.0, 0.0, 0)
    d = inspect_diff.channel_diff("x", a[6:], b[6:], threshold=0.5)
    assert (d.max_abs, d.differing) == (0.5, 0)


def test_diff_structure_and_bad_input(tmp_path, capsys):
    """Different sizes or channel sets: exit 1 with a message; a missing --channel or an
    unreadable file: exit 2 (bad input)."""
    pa, _ = _pair(tmp_path)
    small = tmp_path / "small.exr"
    Image(rgba=np.zeros((3, 3, 4), np.float32)).write_exr(small)
    code, out, _ = run(capsys, "inspect", pa, "--diff", small)
    assert code == 1 and "sizes differ" in out and "9 x 7" in out and "3 x 3" in out
    img = warp_st.read_exr(pa)
    fewer = tmp_path / "fewer.exr"
    img.replace(channels=("R", "G", "B", "A", "Z")).write_exr(fewer)
    code, out, _ = run(capsys, "inspect", pa, "--diff", fewer)
    assert code == 1 and re.search(r"only in \S*a\.exr.*spacetime\.eventTime", out)
    code, out, _ = run(capsys, "inspect", pa, "--diff", fewer, "--channel", "Z")
    assert code == 0 and "within the tolerance 0 on all 1 channel(s)" in out
    code, _, err = run(capsys, "inspect", pa, "--diff", fewer, "--channel", "spacetime.eventTime")
    assert code == 2 and "fewer.exr" in one_error_line(err)
    code, _, err = run(capsys, "inspect", pa, "--diff", tmp_path / "missing.exr")
    assert code == 2 and "missing.exr" in one_error_line(err)
    code, _, err = run(capsys, "inspect", pa, "--diff", fewer, "--png", tmp_path / "x.png", "--channel", "Z")
    assert code == 2 and "--diff" in one_error_line(err)


def test_printed_values_are_exact_whatever_numpy_prints():
    """colour-science switches NumPy's printing to its 1.13 legacy mode (12 digits for a
    float64, 8 for a float32) when imported; inspect's text stays the shortest exact one."""
    from warp_st.commands.inspect import _fmt

    with np.printoptions(legacy="1.13"):
        assert _fmt(np.float64(5.187856674200006), np.float64) == "5.187856674200006"
        assert _fmt(np.float32(0.0022515059), np.float32) == "0.0022515059"
