"""``inertest thermal triad PLAN DATA``: table, JSON, bad input (numerics in
tests/procedures/test_thermal_triad.py)."""

import json

import numpy as np

from inertest.cli import main
from inertest.io.data_file import write_table

PLAN = """
[site]
latitude_deg = 34.0
gravity = 9.8
[instrument]
kind = "accelerometer-triad"
serial = "ACC-T2"
output_unit = "m/s^2"
[procedure]
kind = "triad-multiposition"
positions = "6"
samples_per_position = 5
noise_model = "white"
"""


def steps(rng=0):
    """Ideal triad with B_x = 1 + 0.01 (T - 20) mg, heating and cooling -20..40 degC."""
    gen = np.random.default_rng(rng)
    rows = {k: [] for k in ("temperature_c", "branch", "position", "output_x", "output_y",
                            "output_z")}
    temps = np.arange(-20.0, 41.0, 10.0)
    for branch, seq in (("heating", temps), ("cooling", temps[::-1])):
        for T in seq:
            b = np.array([1.0 + 0.01 * (T - 20.0), 0.0, 0.0]) * 9.80665e-3
            for label in ("UEN", "DWN", "NUE", "SDE", "ENU", "WND"):
                f = np.array([9.8 if c == "U" else -9.8 if c == "D" else 0.0 for c in label])
                for _ in range(5):
                    y = f + b + gen.normal(0.0, 1e-3, 3)
                    rows["temperature_c"].append(T)
                    rows["branch"].append(branch)
                    rows["position"].append(label)
                    for i, a in enumerate("xyz"):
                        rows[f"output_{a}"].append(y[i])
    return {k: np.array(v) for k, v in rows.items()}


def test_triad_table_and_json(tmp_path, capsys):
    plan, data = tmp_path / "plan.toml", tmp_path / "steps.csv"
    plan.write_text(PLAN)
    write_table(data, steps())
    assert main(["thermal", "triad", str(plan), str(data), "--degree", "1", "--t-ref-c",
                 "20"]) == 0
    out = capsys.readouterr().out
    assert "B_x" in out and "mg/degC" in out and "heating - cooling" in out
    assert main(["thermal", "triad", str(plan), str(data), "--degree", "1", "--t-ref-c", "20",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["kind"] == "thermal-triad"
    terms = doc["result"]["laws"]["B_x"]["terms"]
    assert abs(terms["a0"]["value"] - 1.0) < 4 * terms["a0"]["std"]
    assert abs(terms["a1"]["value"] - 0.01) < 4 * terms["a1"]["std"]
    assert doc["checks"][0]["verdict"] == "not significant"
    assert len(doc["result"]["steps"]) == 14


def test_triad_bad_input(tmp_path, capsys):
    plan, data = tmp_path / "plan.toml", tmp_path / "steps.csv"
    plan.write_text(PLAN)
    d = steps()
    write_table(data, {k: v for k, v in d.items() if k != "branch"})
    assert main(["thermal", "triad", str(plan), str(data)]) != 0
    err = capsys.readouterr().err
    assert "lack column branch" in err and "Traceback" not in err
