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
