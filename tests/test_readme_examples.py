"""The README's examples run from a clone alone (no ../shared needed)."""

from __future__ import annotations

import json

import numpy as np

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
