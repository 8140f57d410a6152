"""Gyro rate-table, 360-degree rotation and navigation-mode calibration through the CLI."""

import json

import numpy as np
import pytest

from inertest.cli import main
from inertest.io.data_file import read_table, write_table


@pytest.fixture
def rotation(examples_dir):
    d = examples_dir / "gyro_triad_rotation"
    return d / "plan.toml", d / "truth.toml"


@pytest.fixture
def rate_table(examples_dir):
    d = examples_dir / "gyro_rate_table"
    return d / "plan.toml", d / "truth.toml"


def test_rate_table_simulate_fit_json_and_report(rate_table, tmp_path, capsys):
    plan, truth = rate_table
    data = tmp_path / "rt.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", "0.5", "--seed", "2"]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "gyro-rate-table"
    assert set(out["identification"]["coefficients"]) == {"K", "B", "K2", "K_pos", "K_neg",
                                                           "asymmetry"}
    k = out["identification"]["coefficients"]["K"]
    assert k["unit"] == "count/deg" and abs(k["value"] - 7200.0) < 5 * k["std"]
    a = out["identification"]["coefficients"]["asymmetry"]
    assert a["unit"] == "ppm" and abs(a["value"] - 25.0) < 5 * a["std"]
    assert out["result"]["nonlinearity"]["unit"] == "ppm of full scale"
    assert out["result"]["earth_rate_along_axis"]["unit"] == "deg/h"
    assert main(["fit", str(plan), str(data), "--report", str(tmp_path / "rep"),
                 "--no-store"]) == 0
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "data:image/png;base64," in html and "Closed form from each pair" in html


def test_rotation_fit_json_has_the_calibration_block(rotation, tmp_path, capsys):
    plan, truth = rotation
    data = tmp_path / "rot.parquet"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", "5", "--seed", "1"]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    gyro = out["result"]["calibration"]["gyroscope"]
    assert np.shape(gyro["matrix"]) == (3, 3) and len(gyro["offset"]) == 3
    assert gyro["unit"] == "rad/s" and gyro["raw_unit"] == "count/s"
    m = out["identification"]["coefficients"]["M_yz"]
    assert m["unit"] == "urad" and abs(m["value"] - 232.711) < 5 * m["std"]
    assert out["identification"]["coefficients"]["B_z"]["unit"] == "deg/h"
    assert main(["fit", str(plan), str(data), "--report", str(tmp_path / "rep"),
                 "--no-store"]) == 0
    assert "Residual counts per window" in (tmp_path / "rep" / "index.html").read_text()


def _drop_counts(d):
    del d["counts_y"]


def _mislabel(d):
    d["axis"][2] = "z"


def _positive_only(d):
    d["rate_deg_s"] = np.abs(d["rate_deg_s"])


@pytest.mark.parametrize("which, spoil, message", [
    ("rotation", _drop_counts, "lacks column(s) counts_y"),
    ("rotation", _mislabel, "labelled a rotation about z, but gyro y counted the turn"),
    ("rate_table", _positive_only, "asymmetry needs both directions: add negative rates"),
])
def test_bad_input_is_a_clean_error(request, tmp_path, capsys, which, spoil, message):
    plan, truth = request.getfixturevalue(which)
    data = tmp_path / "d.csv"
    main(["simulate", str(plan), "--truth", str(truth), "-o", str(data), "--noise", "1"])
    cols = read_table(data)
    spoil(cols)
    write_table(data, cols)
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--report", str(tmp_path / "never")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "never").exists()


def test_navigation_mode_iteration_end_to_end(rotation, tmp_path, capsys):
    plan, truth = rotation
    rot = tmp_path / "rot.csv"
    main(["simulate", str(plan), "--truth", str(truth), "-o", str(rot), "--noise", "30",
          "--seed", "4"])
    main(["fit", str(plan), str(rot), "--json", "--no-store"])
    fit_json = tmp_path / "fit.json"
    fit_json.write_text(capsys.readouterr().out.split("\n", 1)[1])  # after the simulate line
    nav = tmp_path / "nav.parquet"
    assert main(["nav-simulate", str(plan), "--truth", str(truth), "-o", str(nav),
                 "--rate-hz", "20"]) == 0
    capsys.readouterr()
    assert main(["nav-calibrate", str(plan), str(nav), "--initial", str(fit_json), "--json",
                 "--report", str(tmp_path / "navrep")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["result"]["converged"] and len(out["result"]["iterations"]) >= 2
    first = out["result"]["iterations"][0]["attitude_error_rms_arcsec"]
    last = out["result"]["iterations"][-1]["attitude_error_rms_arcsec"]
    assert last < 1e-3 * first
    assert out["identification"]["coefficients"]["K_x"]["value"] == pytest.approx(7200.0, rel=1e-9)
    m_zx = out["identification"]["coefficients"]["M_zx"]
    assert m_zx["unit"] == "urad" and m_zx["value"] == pytest.approx(-145.444, abs=5e-3)
    assert np.shape(out["result"]["calibration"]["gyroscope"]["matrix"]) == (3, 3)
    html = (tmp_path / "navrep" / "index.html").read_text()
    assert "Attitude error and corrections per iteration" in html


def test_navigation_mode_bad_input(rotation, rate_table, tmp_path, capsys):
    plan, truth = rotation
    nav = tmp_path / "nav.csv"
    main(["nav-simulate", str(plan), "--truth", str(truth), "-o", str(nav), "--rate-hz", "5"])
    bad = tmp_path / "bad.json"
    bad.write_text('{"accelerometer": {"matrix": [[1,0,0],[0,1,0],[0,0,1]], "offset": [0,0,0], '
                   '"unit": "m/s^2"}}')
    capsys.readouterr()
    assert main(["nav-calibrate", str(plan), str(nav), "--initial", str(bad)]) == 2
    assert 'has no "gyroscope" block' in capsys.readouterr().err
    assert main(["nav-calibrate", str(rate_table[0]), str(nav), "--initial", str(bad)]) == 2
    assert 'needs a plan of kind "gyro-triad-rotation"' in capsys.readouterr().err
    bad.write_text("{not json")
    assert main(["nav-calibrate", str(plan), str(nav), "--initial", str(bad)]) == 2
    assert "is not JSON" in capsys.readouterr().err


def test_rate_table_fit_json_with_given_sigma(rate_table, tmp_path, capsys):
    """--json --sigma: the given noise is reported (no NaN in the JSON)."""
    plan, truth = rate_table
    data = tmp_path / "rt.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", "0.01", "--seed", "2"]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--sigma", "0.01", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    noise = out["identification"]["noise"]
    assert noise["source"] == "given" and noise["unit"] == "count/s"
    assert noise["sigma"] == pytest.approx(0.01) and noise["model"] == "white"
    (check,) = [c for c in out["checks"] if c["name"] == "noise model fit"]
    assert check["verdict"] == "consistent"
