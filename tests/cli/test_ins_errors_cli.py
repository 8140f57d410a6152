"""``inertest ins-errors`` through main(argv)."""

import json
import math

import numpy as np
import pytest

from inertest.cli import main

STATES = ["dVE", "dVN", "dL", "dlambda", "phiE", "phiN", "phiU"]


def test_json_contract_and_closed_form_value(capsys):
    """0.1 deg/h north drift alone, 48 h: the longitude error grows at +eN cos L (the drift
    component along the polar axis looks like a faster Earth, so the computed position runs
    east), apart from Schuler and Earth-rate oscillations."""
    assert main(["ins-errors", "--latitude", "39", "--hours", "48", "--step", "60",
                 "--gyro-drift-deg-h", "0,0.1,0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    assert set(out) == {"t", *STATES, "periods", "units", "sign_convention", "linear_model"}
    assert "output errors" in out["sign_convention"]
    t = np.array(out["t"])
    assert t[0] == 0 and t[-1] == 48 * 3600 and np.all(np.diff(t) == 60)
    assert out["units"]["dVE"] == "m/s" and out["units"]["dL"] == "rad"
    assert out["periods"]["foucault"] == pytest.approx(2 * math.pi / (7.2921151467e-5 *
                                                                      math.sin(math.radians(39))))
    lon = np.array(out["dlambda"])
    rate = 0.1 * math.pi / 180 / 3600 * math.cos(math.radians(39))
    # the oscillating part is bounded: the secular growth dominates over 48 h
    assert abs(lon[-1] / (rate * t[-1]) - 1) < 0.1


def test_table_output_with_example_plot_and_report(tmp_path, capsys):
    png, html = tmp_path / "f.png", tmp_path / "r.html"
    assert main(["ins-errors", "--example", "--step", "60", "--plot", str(png),
                 "--report", str(html)]) == 0
    out = capsys.readouterr().out
    assert "84.40 min" in out  # the source chose R for an 84.4 min Schuler period
    assert "Foucault" not in out  # simplified model, as in the source
    assert "eN*cos(L)" in out and "-eN*cos(L)" not in out and "bE/g" in out
    assert "sign convention: errors = computed - true" in out
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "<img src=\"data:image/png;base64," in html.read_text()


def test_scenario_file_with_overrides(examples_dir, capsys):
    path = examples_dir / "ins_errors" / "source_scenario.toml"
    assert main(["ins-errors", "--scenario", str(path), "--hours", "2", "--step", "600",
                 "--coriolis", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    assert out["t"][-1] == 7200
    assert out["periods"]["foucault"] is not None  # --coriolis overrode the file
    # attitude override replaces the file's value; initial phiE shows at t = 0
    assert main(["ins-errors", "--scenario", str(path), "--hours", "1", "--step", "600",
                 "--initial-attitude-arcsec", "10,0,0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    assert out["phiE"][0] == pytest.approx(10 / 3600 * math.pi / 180, rel=1e-12)


def test_random_sources_add_sigma(capsys):
    assert main(["ins-errors", "--latitude", "30", "--hours", "1", "--step", "60",
                 "--gyro-arw-deg-sqrt-h", "0.01", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    assert out["sigma"]["phiE"][0] == 0 and out["sigma"]["phiE"][1] > 0
    assert all(v == 0 for v in out["dVE"])  # no deterministic source given


@pytest.mark.parametrize("argv, match", [
    (["--latitude", "90", "--hours", "1", "--step", "1"], "90 deg"),
    (["--latitude", "-95", "--hours", "1", "--step", "1"], "90 deg"),
    (["--latitude", "39", "--hours", "0", "--step", "1"], "duration must be positive"),
    (["--latitude", "39", "--hours", "1", "--step", "-5"], "step must be positive"),
    (["--latitude", "39", "--hours", "1", "--step", "1", "--gyro-drift-deg-h", "0.1,x,0"],
     "comma-separated numbers"),
    (["--latitude", "39", "--hours", "1", "--step", "1", "--accel-bias-ug", "1,2,3"],
     "expected 2"),
    (["--hours", "1"], "--latitude"),
    (["--latitude", "39", "--gyro-arw-deg-sqrt-h", "-1"], "non-negative"),
])
def test_bad_input_clear_one_line_error(argv, match, capsys, tmp_path):
    png = tmp_path / "never.png"
    assert main(["ins-errors", *argv, "--plot", str(png)]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err
    assert not png.exists()


def test_missing_scenario_file(tmp_path, capsys):
    assert main(["ins-errors", "--scenario", str(tmp_path / "nope.toml")]) == 2
    assert "nope.toml" in capsys.readouterr().err
