"""CLI of the accelerometer tests: dividing-head multipoint and triad multi-position."""

import json

import numpy as np
import pytest

from inertest.cli import main
from inertest.io.data_file import read_table, write_table


def _run(examples_dir, tmp, name, noise, capsys, fmt="csv"):
    plan = examples_dir / name / "plan.toml"
    truth = examples_dir / name / "truth.toml"
    data = tmp / f"data.{fmt}"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", str(noise), "--seed", "3"]) == 0
    capsys.readouterr()
    return plan, data


def test_multipoint_simulate_fit_json(examples_dir, tmp_path, capsys):
    plan, data = _run(examples_dir, tmp_path, "accelerometer_multipoint", 1e-6, capsys, "parquet")
    assert set(read_table(data)) == {"mounting", "angle_deg", "output"}
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "accelerometer-multipoint"
    k1 = out["identification"]["coefficients"]["K1"]
    assert k1["unit"] == "mA/g" and abs(k1["value"] - 1.2345) < 5 * k1["std"]
    assert out["identification"]["coefficients"]["dO"]["unit"] == "urad"
    d_o = out["identification"]["coefficients"]["dO"]
    assert abs(d_o["value"] - 45.0) < 5 * d_o["std"]
    assert "KPO" not in out["identification"]["coefficients"]
    assert any(s.startswith("KPO: not excited") for s in out["identification"]["not_separable"])
    assert set(out["result"]["fourier"]) == {"IA-PA", "IA-OA"}


def test_triad_simulate_fit_json_and_report(examples_dir, tmp_path, capsys):
    plan, data = _run(examples_dir, tmp_path, "triad_multiposition", 2.0, capsys)
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    cal = out["result"]["calibration"]["accelerometer"]
    assert np.shape(cal["matrix"]) == (3, 3) and cal["unit"] == "m/s^2"
    for k, v in {"K_x": 1671.2, "M_yz": 1200.0, "B_z": 21.0}.items():
        e = out["identification"]["coefficients"][k]
        assert abs(e["value"] - v) < 5 * e["std"], k
    assert out["result"]["triads"]["accelerometer"]["scale_factor_ppm"]["K_x"]["unit"] == "ppm"
    assert main(["fit", str(plan), str(data), "--no-store", "--report", str(tmp_path / "r")]) == 0
    html = (tmp_path / "r" / "index.html").read_text()
    assert "data:image/png;base64," in html and "matrix @ (raw" in html


def _swap(d):
    d["output_x"], d["output_y"] = d["output_y"], d["output_x"]


def _only_xy(d):
    keep = np.isin(d["position"], ["UEN/z+45", "UEN/z-45", "DWN/z+45", "DWN/z-45"])
    for k in d:
        d[k] = d[k][keep]


def _drop(d):
    d.pop("output_z")


@pytest.mark.parametrize("spoil, message", [
    (_swap, "swap output_x and output_y"),
    (_only_xy, "K_z and the misalignments M_xz/M_yz/M_zz"),
    (_drop, "lacks column(s) output_z"),
])
def test_triad_bad_data_is_a_clean_error(examples_dir, tmp_path, capsys, spoil, message):
    plan, data = _run(examples_dir, tmp_path, "triad_multiposition", 2.0, capsys)
    cols = read_table(data)
    spoil(cols)
    write_table(data, cols)
    rep = tmp_path / "never"
    assert main(["fit", str(plan), str(data), "--report", str(rep), "--no-store"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not rep.exists()


def test_multipoint_without_ia_mounting_is_a_clean_error(examples_dir, tmp_path, capsys):
    plan, data = _run(examples_dir, tmp_path, "accelerometer_multipoint", 1e-6, capsys)
    cols = read_table(data)
    cols["mounting"] = np.full(len(cols["output"]), "PA-OA")
    write_table(data, cols)
    assert main(["fit", str(plan), str(data), "--no-store"]) == 2
    err = capsys.readouterr().err
    assert "K1 cannot be found" in err and "add an IA-PA or IA-OA mounting" in err


def test_multipoint_bad_plan(tmp_path, capsys):
    plan = tmp_path / "p.toml"
    plan.write_text('[site]\nlatitude_deg = 30\n[instrument]\nkind = "accelerometer"\n'
                    'output_unit = "V"\n[procedure]\nkind = "accelerometer-multipoint"\n'
                    'positions = 6\n')
    truth = tmp_path / "t.toml"
    truth.write_text("K1 = 1.0\n")
    out = tmp_path / "d.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(out)]) == 2
    assert "positions must be an integer >= 8" in capsys.readouterr().err
    assert not out.exists()


def test_multipoint_fit_json_with_given_sigma(examples_dir, tmp_path, capsys):
    """--json --sigma: the given noise is reported (no NaN in the JSON)."""
    plan, data = _run(examples_dir, tmp_path, "accelerometer_multipoint", 0.01, capsys)
    assert main(["fit", str(plan), str(data), "--json", "--sigma", "0.01", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    noise = out["identification"]["noise"]
    assert noise == {"sigma": 0.01, "unit": "mA", "source": "given", "model": "white",
                     "components": {"white": 0.01}}
    (check,) = [c for c in out["checks"] if c["name"] == "noise model fit"]
    assert check["verdict"] == "consistent"
