"""Servo-table test through the command line: ``inertest simulate`` then ``inertest fit``."""

import json

import numpy as np

from inertest.cli import main
from inertest.io.data_file import read_table

TRUTH = ("[coefficients]\nDF = 1.2\nDI = 0.85\nDO = -0.62\nDS = 0.31\nDIO = 0.12\n"
         "DOS = -0.08\nDSI = 0.05\nDII = 0.04\nDOO = -0.03\nDSS = 0.02\n")


def test_servo_table_simulate_fit_json(tmp_path, examples_dir, capsys):
    # Done criterion of issue 17: a day-long polar servo run at 45 deg, 0.5 arcsec encoder noise.
    plan = examples_dir / "servo_table" / "plan.toml"
    truth = tmp_path / "truth.toml"
    truth.write_text(TRUTH)
    data = tmp_path / "servo.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", "0.5", "--seed", "17"]) == 0
    capsys.readouterr()
    cols = read_table(data)
    assert set(cols) == {"mounting", "time_s", "table_angle_deg"}
    assert set(np.unique(cols["mounting"])) == {"I+H", "I-H"}
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "servo-table"
    coef = out["identification"]["coefficients"]
    assert set(coef) == {"DI", "DO", "DS", "DIO", "DSI", "DOS"}
    t = dict(DF=1.2, DI=0.85, DO=-0.62, DS=0.31, DIO=0.12, DOS=-0.08, DSI=0.05, DII=0.04,
             DOO=-0.03, DSS=0.02)
    for n, e in coef.items():
        assert abs(e["value"] - t[n]) < 4 * e["std"], n
    for c in out["identification"]["combinations"]:
        value = sum(w * t[n] for n, w in c["terms"].items())
        assert abs(c["value"] - value) < 4 * c["std"], c["name"]
    assert out["identification"]["noise"]["unit"] == "arcsec"
    res = out["result"]
    assert res["table_axis"] == "polar"
    assert set(res["harmonics"]["I+H"]) == {"B0", "S1", "C1", "S2", "C2"}
    assert res["stability"]["I-H"]["allan"]["tau_h"][0] == 1.0


def test_servo_table_fit_report(tmp_path, examples_dir, capsys):
    plan = examples_dir / "servo_table" / "plan.toml"
    truth = examples_dir / "servo_table" / "truth.toml"
    data = tmp_path / "servo.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--seed", "3"]) == 0
    assert main(["fit", str(plan), str(data), "--no-store", "--report",
                 str(tmp_path / "rep")]) == 0
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "Long-term drift stability" in html and "DOO - DSS" in html
