"""The README's examples run from a clone alone (no ../shared needed)."""

from __future__ import annotations

import json

import numpy as np
import yaml

from inertest.cli import main
from inertest.io.data_file import read_table


def test_readme_ferraris_fit_and_apply_on_the_shipped_session(examples_dir, tmp_path, capsys):
    plan = examples_dir / "ferraris" / "plan_imucal.toml"
    data = examples_dir / "ferraris" / "imucal" / "annotated_session.csv"
    assert (data.parent / "LICENSE").is_file()
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    cal = tmp_path / "cal.json"
    cal.write_text(capsys.readouterr().out)
    assert json.loads(cal.read_text())["kind"] == "ferraris"
    out = tmp_path / "calibrated.parquet"
    assert main(["apply", str(cal), str(data), "-o", str(out), "--gyr-unit", "deg/s"]) == 0
    got = read_table(out)
    # Static faces of the calibrated session: |a| is local gravity (the plan's 9.81 m/s^2).
    raw = read_table(data)
    still = np.isin(raw["part"], ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"])
    acc = np.column_stack([got[c] for c in got if c.startswith("acc")][:3])
    assert abs(np.median(np.linalg.norm(acc[still], axis=1)) - 9.81) < 0.01


def test_readme_noise_examples_on_the_shipped_psins_recording(examples_dir, tmp_path, capsys):
    # inertest noise examples/noise/lasergyro.imu.xz --kalibr imu.yaml --report noise-report
    data = examples_dir / "noise" / "lasergyro.imu.xz"
    assert (data.parent / "LICENSE").is_file()
    kalibr, report = tmp_path / "imu.yaml", tmp_path / "noise-report"
    assert main(["noise", str(data), "--kalibr", str(kalibr), "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "accel_z" in out and "report:" in out
    y = yaml.safe_load(kalibr.read_text())
    assert y["update_rate"] == 100 and y["gyroscope_noise_density"] > 0
    # The record does not follow the five-term model: the yaml says its values are bounds.
    assert kalibr.read_text().count("UPPER BOUND, not a measurement") == 4
    html = (report / "index.html").read_text()
    assert html.count("data:image/png;base64,") >= 6
    # inertest noise examples/noise/lasergyro.imu.xz --compare examples/noise/datasheet.yaml
    assert main(["noise", str(data), "--compare", str(data.parent / "datasheet.yaml"),
                 "--json"]) == 0
    comp = json.loads(capsys.readouterr().out)["result"]["comparison"]
    assert len(comp) == 12 and {c["verdict"] for c in comp} == {"consistent"}
