"""The examples run as smoke tests (their numbers are checked by the analytic tests)."""
from example_scripts import load_example


def test_moving_sphere_example_runs_and_stays_within_the_sagitta(capsys, tmp_path):
    """The example renders, writes its EXR and reports a depth error below the
    tessellation bound it prints (the chord gap of the 128-segment sphere)."""
    out = tmp_path / "sphere.exr"
    assert load_example("moving_sphere_aovs.py").main(["--beta", "0.5", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    last = text.strip().splitlines()[-1]
    worst = float(last.split("difference ")[1].split()[0])
    bound = float(last.split("bound ")[1].rstrip(")"))
    assert worst < bound
    assert out.exists()


def test_terrell_globe_shows_its_meridians_turned_by_asin_beta(capsys, tmp_path):
    """The globe example (a UsdUVTexture on a UV-sphere mesh): the longitude seen at the
    image centre is the closed form -asin(beta) at 0.9c and 0 at rest, to within a texel
    and a half (the map's resolution, 1.4 degrees, plus the facets)."""
    import math

    example = load_example("terrell_globe.py")
    assert example.main(["--beta", "0.9", "--out", str(tmp_path), "--width", "81", "--height", "61"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("beta ")]
    seen = [float(line.split("centre ")[1].split()[0]) for line in rows]
    assert len(seen) == 2
    assert abs(seen[0] - 0.0) < 2.1
    assert abs(seen[1] + math.degrees(math.asin(0.9))) < 2.1
    assert (tmp_path / "terrell_globe.png").exists()


def test_starbow_example_flies_through_the_dome(capsys, tmp_path):
    """The starfield example (a DomeLight sky): the largest Doppler factor in view is the
    head-on sqrt((1 + beta) / (1 - beta)), seen at the centre pixel of an odd-sized image
    looking along the flight (float32: 1e-5 relative)."""
    import math

    example = load_example("starbow.py")
    argv = ["--betas", "0.5", "0.99", "--out", str(tmp_path), "--width", "49", "--height", "49", "--samples", "1"]
    assert example.main(argv) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("beta ")]
    for beta, line in zip((0.5, 0.99), rows):
        top = float(line.rsplit(" to ", 1)[1])
        assert abs(top / math.sqrt((1 + beta) / (1 - beta)) - 1.0) < 1e-2  # printed to 2 decimals
    assert (tmp_path / "starbow.png").exists()


def test_aberration_sky_example_sees_each_sky_direction_where_aberration_puts_it(capsys, tmp_path):
    """The thesis's observers under a dome whose texels encode their own lab direction: every
    sky pixel's decoded direction is the camera's pixel direction carried to the lab by the
    aberration (relativistic and classical), to within the encoding's half-texel diagonal
    (the example exits 1 otherwise)."""
    example = load_example("aberration_sky.py")
    assert example.main(["--out", str(tmp_path), "--width", "48", "--height", "48"]) == 0
    out = capsys.readouterr().out
    assert "Towards_0866_Relativistic" in out and "Left_0866_Classical" in out
