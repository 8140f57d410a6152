"""The fleet example (issue 31): a production lot as one batch, its lot statistics against the
generator's own truth (``truth.csv``: each unit's errors, drawn independently of inertest)."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import numpy as np

from inertest.cli import main

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "fleet"


def _make_fleet():
    spec = importlib.util.spec_from_file_location("make_fleet", EXAMPLE / "make_fleet.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.make_fleet


def test_a_lot_of_60_units_gives_the_true_spread_and_finds_the_far_out_units(tmp_path, capsys):
    manifest = _make_fleet()(tmp_path / "lot", 60, seed=7)
    assert (EXAMPLE / "README.md").is_file()
    db = tmp_path / "h.db"
    assert main(["batch", str(manifest), "--workers", "2", "--db", str(db), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["lot", "--db", str(db), "--procedure", "triad-multiposition", "--spec",
                 str(EXAMPLE / "spec.toml"), "--json"]) == 0
    lot = json.loads(capsys.readouterr().out)["result"]
    with (tmp_path / "lot" / "truth.csv").open(newline="") as fh:
        truth = list(csv.DictReader(fh))
    assert len(lot["units"]) == 60
    got = {q["quantity"]: q for q in lot["quantities"]}
    for name in ("K_x", "K_y", "M_xy", "M_zx", "B_x", "B_z"):
        true = [float(t[name]) for t in truth]
        lo, hi = got[name]["unit_to_unit_std_interval_95"]
        assert lo <= np.std(true, ddof=1) <= hi, name  # the units' own spread, noise removed
        assert abs(got[name]["mean"] - np.mean(true)) < 4 * got[name]["mean_std"], name
    for axis in "xyz":  # the generator's tail (a bias of 45-60 mg) is what stands out
        far = {t["serial"] for t in truth if abs(float(t[f"B_{axis}"])) > 40}
        assert {s["serial"] for s in got[f"B_{axis}"]["stand_out"]} == far, axis
    assert any(abs(float(t[f"B_{a}"])) > 40 for t in truth for a in "xyz")
    # each unit's value carries its test date (the runs' plans name no test identity)
    assert all(v["tested_at"] for v in got["B_x"]["values"])
