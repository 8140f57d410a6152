"""``inertest thermal triad PLAN DATA``: table, JSON, bad input (numerics in
tests/procedures/test_thermal_triad.py)."""

import json

import numpy as np

from inertest.cli import main
from inertest.io.data_file import read_table, write_table

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


def steps(rng=0, temps=None, branches=("heating", "cooling")):
    """Ideal triad with B_x = 1 + 0.01 (T - 20) mg, heating and cooling -20..40 degC."""
    gen = np.random.default_rng(rng)
    rows = {k: [] for k in ("temperature_c", "branch", "position", "output_x", "output_y",
                            "output_z")}
    temps = np.arange(-20.0, 41.0, 10.0) if temps is None else np.asarray(temps, dtype=float)
    for branch, seq in (("heating", temps), ("cooling", temps[::-1])):
        if branch not in branches:
            continue
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


def true_f(labels):
    return np.array([[9.8 if c == "U" else -9.8 if c == "D" else 0.0 for c in lb]
                     for lb in labels])


def test_triad_model_out_report_and_apply_to_held_out_steps(tmp_path, capsys):
    """Fit with --model-out and --report; apply corrects held-out temperatures (between the
    steps) so B_x (1 mg +- 0.2 mg over the range) is gone: the mean error per temperature is
    within the noise of that mean, and a row outside the range is refused unless
    --extrapolate."""
    plan, data, model = tmp_path / "plan.toml", tmp_path / "steps.csv", tmp_path / "m.json"
    plan.write_text(PLAN)
    write_table(data, steps())
    rep = tmp_path / "rep"
    assert main(["thermal", "triad", str(plan), str(data), "--degree", "1", "--model-out",
                 str(model), "--report", str(rep)]) == 0
    out = capsys.readouterr().out
    assert "model:" in out and "valid -20 to 40 degC" in out
    doc = json.loads(model.read_text())
    assert doc["kind"] == "thermal-triad-model" and doc["serial"] == "ACC-T2"
    assert doc["laws"]["B_x"]["terms"]["a1"]["unit"] == "mg/degC"
    html = (rep / "index.html").read_text()
    assert "Hysteresis" in html and "not significant" in html and "B_x" in html
    assert html.count("data:image/png;base64,") == 1
    held = tmp_path / "held.csv"
    h = steps(rng=5, temps=[-15.0, 5.0, 25.0, 35.0], branches=("heating",))
    write_table(held, h)
    res = tmp_path / "corrected.csv"
    assert main(["apply", str(model), str(held), "-o", str(res), "--temperature-column",
                 "temperature_c"]) == 0
    got = read_table(res)
    u = np.column_stack([got[f"output_{a}"] for a in "xyz"])
    err = u - true_f(h["position"])
    before = np.column_stack([h[f"output_{a}"] for a in "xyz"]) - true_f(h["position"])
    for T in np.unique(h["temperature_c"]):
        sel = h["temperature_c"] == T
        # 30 readings of 1e-3 m/s^2 noise: the mean is known to 1.8e-4 m/s^2
        assert np.all(np.abs(err[sel].mean(axis=0)) < 4 * 1e-3 / np.sqrt(sel.sum())), T
        assert abs(before[sel, 0].mean()) > 0.005  # B_x 0.65 to 1.15 mg (6.4e-3 m/s^2) before
    assert np.all(got["output_x_correction_std"] > 0)
    assert np.all(got["output_x_correction_std"] < 1e-3)
    hot = tmp_path / "hot.csv"
    write_table(hot, steps(rng=6, temps=[45.0], branches=("heating",)))
    assert main(["apply", str(model), str(hot), "-o", str(tmp_path / "x.csv"),
                 "--temperature-column", "temperature_c"]) != 0
    err_text = capsys.readouterr().err
    assert "outside the temperature range" in err_text and "--extrapolate" in err_text
    assert not (tmp_path / "x.csv").exists()
    assert main(["apply", str(model), str(hot), "-o", str(tmp_path / "x.csv"),
                 "--temperature-column", "temperature_c", "--extrapolate"]) == 0
    assert "warning: extrapolating" in capsys.readouterr().err
    assert main(["apply", str(model), str(hot), "-o", str(tmp_path / "y.csv")]) != 0
    assert "--temperature-column" in capsys.readouterr().err


def test_readme_triad_thermal_flow_on_the_examples(examples_dir, tmp_path, capsys):
    """The README's commands: simulate the chamber from the shipped laws, fit, write the model
    and report, apply to a held-out heating run between the steps."""
    plan = examples_dir / "thermal_triad" / "plan.toml"
    laws = examples_dir / "thermal_triad" / "laws.toml"
    chamber, held = tmp_path / "chamber.csv", tmp_path / "held_out.csv"
    model, out = tmp_path / "triad_model.json", tmp_path / "corrected.csv"
    assert main(["thermal", "triad-simulate", str(plan), str(laws), "-o", str(chamber),
                 "--noise", "2", "--seed", "1"]) == 0
    assert main(["thermal", "triad", str(plan), str(chamber), "--model-out", str(model),
                 "--report", str(tmp_path / "rep")]) == 0
    assert main(["thermal", "triad-simulate", str(plan), str(laws), "-o", str(held),
                 "--noise", "2", "--seed", "2", "--t-min-c", "-35", "--t-max-c", "55",
                 "--branches", "heating"]) == 0
    assert main(["apply", str(model), str(held), "-o", str(out), "--temperature-column",
                 "temperature_c"]) == 0
    capsys.readouterr()
    got, raw = read_table(out), read_table(held)
    u = np.column_stack([got[f"output_{a}"] for a in "xyz"])
    g = np.linalg.norm(u, axis=1)
    # |f| is the site's normal gravity (9.797 m/s^2 at 34.2 deg) at every temperature, within
    # 2 count noise / 1670 count/(m/s^2) = 1.2e-3 m/s^2 per reading
    assert abs(np.mean(g) - 9.7966) < 5e-4 and np.std(g) < 2e-3
    assert sorted(set(raw["temperature_c"])) == list(np.arange(-35.0, 56.0, 10.0))
    assert main(["thermal", "triad-simulate", str(plan), str(laws), "-o", str(held)]) != 0
    assert "already exists" in capsys.readouterr().err
