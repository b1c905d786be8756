"""`skinviewer profile`: JSON structure, preset round trip through skinviewer.ground.settings, errors."""
import argparse
import json

import pytest

from skinviewer.cli import profile as profile_cli
from skinviewer.ground.settings import load_preset, profile_warnings


def run(argv, capsys):
    parser = argparse.ArgumentParser(prog="skinviewer")
    profile_cli.add_parser(parser.add_subparsers(dest="command"))
    code = profile_cli.run(parser.parse_args(["profile", *argv]))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_json_output_structure(capsys):
    code, out, err = run(["--model", "dipole", "--material", "marble", "--fit", "4", "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert data["k"] == 4 and data["shared_variances"] is True
    for ch in "rgb":
        c = data["channels"][ch]
        assert len(c["variances"]) == 4 and len(c["weights"]) == 4
        assert c["variances"] == sorted(c["variances"])
        assert all(w >= 0 for w in c["weights"]) and 0 < c["error"] < 0.05
        assert 0 < c["target_total"] <= 1
    assert len(data["preset_table"]) == 4


def test_preset_out_is_a_loadable_deon_preset(tmp_path, capsys):
    p = tmp_path / "skin1.json"
    plot = tmp_path / "skin1.png"
    code, out, err = run(["--material", "Skin1", "--fit", "6", "--preset-out", str(p), "--plot", str(plot)], capsys)
    assert code == 0, err
    assert "error (eq. 3.1)" in out and "R_d profile" in out
    s = load_preset(p)
    assert s.technique == "deon" and len(s.deon.gaussians) == 6
    assert profile_warnings(s.deon) == []  # ascending, weights sum to 1 per channel
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [x for x in tmp_path.iterdir() if x.name.startswith(".")]  # no temp files left


def test_raw_weights_and_fixed_variances(tmp_path, capsys):
    p = tmp_path / "raw.json"
    code, _, err = run(["--sigma-s-prime", "0.74,0.88,1.01", "--sigma-a", "0.032,0.17,0.48", "--eta", "1.3",
                        "--fixed-variances", "0.0064,0.0484,0.187,0.567,1.99,7.41", "--no-normalize",
                        "--preset-out", str(p)], capsys)
    assert code == 0, err
    g = load_preset(p).deon.gaussians
    assert [x.variance for x in g] == [0.0064, 0.0484, 0.187, 0.567, 1.99, 7.41]
    assert 0.2 < sum(x.weights[0] for x in g) < 0.7  # raw weights: R_d of Skin1 red, not 1


def test_multipole_and_burley_models(capsys):
    code, out, err = run(["--model", "multipole", "--layer", "0.25:8,9,10:0.05,0.15,0.4",
                          "--layer", "inf:0.74,0.88,1.01:0.032,0.17,0.48", "--fit", "5", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["k"] == 5
    code, out, err = run(["--model", "burley", "--albedo", "0.8,0.5,0.3", "--mfp", "1,0.5,0.25",
                          "--fit", "3", "--per-channel", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["shared_variances"] is False


@pytest.mark.parametrize("argv, needle", [
    (["--material", "unobtainium"], "unknown material"),
    (["--sigma-s-prime", "1,x,2", "--sigma-a", "0.1"], "--sigma-s-prime"),
    (["--sigma-s-prime", "1,2", "--sigma-a", "0.1"], "1 or 3"),
    (["--sigma-s-prime", "0", "--sigma-a", "0"], "must be > 0"),
    (["--model", "burley", "--albedo", "1.5", "--mfp", "1"], "albedo"),
    (["--model", "burley", "--material", "Spectralon"], "sigma_a > 0"),
    (["--material", "Skin1", "--fit", "0"], "--fit"),
    (["--material", "Skin1", "--fixed-variances", "1,-1"], "positive"),
    (["--material", "Skin1", "--fit", "3", "--per-channel", "--preset-out", "/tmp/never.json"], "at most 8"),
    (["--model", "multipole", "--layer", "inf:1,1,1:0.1,0.1,0.1", "--layer", "1:1,1,1:0.1,0.1,0.1"], "last layer"),
])
def test_bad_input_exits_2_with_one_line(argv, needle, capsys):
    code, out, err = run(argv, capsys)
    assert code == 2
    assert needle in err and err.count("\n") == 1 and "Traceback" not in err


def test_plot_arrays_r_times_burley_is_finite_and_continuous_at_zero():
    """r R(r) -> 2 A / (8 pi d) at r = 0 for Burley (R ~ 1/r): the first plotted point is that limit."""
    import math

    from skinviewer.cli.profile_plot import plot_arrays
    from skinviewer.physics import profiles as P
    b = P.Burley(0.6, 1.0)
    data = plot_arrays(b, r_max=5.0, n=501)
    lim = 2 * 0.6 / (8 * math.pi * b.d)
    assert abs(data["rR"][0, 0] - lim[0]) < 1e-6 * lim[0]
    assert abs(data["rR"][1, 0] - data["rR"][0, 0]) < 0.05 * lim[0]


def test_thin_layer_is_flagged(capsys):
    code, out, err = run(["--model", "multipole", "--layer", "0.3:2,3,4:0.01,0.02,0.03", "--layer",
                          "inf:1,1,1:0.05,0.1,0.2", "--fit", "2", "--json"], capsys)
    assert code == 0
    assert "layer 1 is 0.3 mm thick, under one mean free path" in err
