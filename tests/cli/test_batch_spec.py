"""``inertest batch`` with spec and equipment per run (issue 20): budget and verdicts filed.

References: the verdicts follow from the simulated truth against the example limits, decided by
hand (B_z = 21 mg against |B_z| <= 5 mg under simple acceptance is a fail whatever U of
~0.02 mg; a truth with biases of 1 mg and no misalignment is inside every limit by 4 mg >> U).
The runs stored are read back with the standard library's sqlite3.
"""

from __future__ import annotations

import json
import sqlite3
import tomllib

import pytest

import inertest
from inertest.cli import main
from inertest.io.data_file import write_table

NOISE = 2.0  # count per reading, as the demo's triad


@pytest.fixture
def manifest(examples_dir, tmp_path):
    """Three triad runs: one inside the limits, one failing B_z, one without a spec."""
    plan = examples_dir / "triad_multiposition" / "plan.toml"
    shipped = tomllib.loads((examples_dir / "triad_multiposition" / "truth.toml").read_text())
    inside = {**{k: v for k, v in shipped["coefficients"].items() if k.startswith("K_")},
              "B_x": 1.0, "B_y": -1.0, "B_z": 1.0}
    for name, truth, seed in (("good", inside, 1), ("bad", shipped["coefficients"], 2),
                              ("plain", inside, 3)):
        write_table(tmp_path / f"{name}.csv",
                    inertest.simulate(plan, truth, noise=NOISE, rng=seed))
    spec = examples_dir / "specs" / "accelerometer_triad.toml"
    lab = examples_dir / "lab" / "equipment.toml"
    path = tmp_path / "batch.toml"
    path.write_text(
        f'[defaults]\nequipment = "{lab}"\n\n'
        f'[[run]]\nplan = "{plan}"\ndata = "good.csv"\nspec = "{spec}"\n\n'
        f'[[run]]\nplan = "{plan}"\ndata = "bad.csv"\nspec = "{spec}"\n\n'
        f'[[run]]\nplan = "{plan}"\ndata = "plain.csv"\n')
    return path


def test_each_run_is_filed_with_its_budget_and_verdicts(manifest, tmp_path, capsys):
    db = tmp_path / "h.db"
    assert main(["batch", str(manifest), "--db", str(db), "--json"]) == 0
    runs = json.loads(capsys.readouterr().out)["runs"]
    assert [r["error"] for r in runs] == [None] * 3
    good, bad, plain = runs
    assert good["conformance"]["overall"] == "pass"
    assert bad["conformance"]["overall"] == "fail"
    failing = {v["quantity"] for v in bad["conformance"]["verdicts"] if v["verdict"] == "fail"}
    assert failing == {"B_x", "B_y", "B_z"}  # 12.5, -8.3, 21 mg against 5 mg
    assert plain["conformance"] is None
    # the lab file of [defaults] gives every run its budget, with the equipment's Type B
    for r in runs:
        assert r["uncertainty_budget"]["sources"] == ["RT-02 tilt_urad", "GRAV-01 gravity_mgal"]
        q = r["uncertainty_budget"]["quantities"]["B_z"]
        assert q["type_a"]["std"] > 0 and abs(q["type_b"][0]["contribution"]) > 0
    # the stored envelopes carry the same blocks
    with sqlite3.connect(db) as con:
        docs = [json.loads(t) for (t,) in con.execute("SELECT result_json FROM runs ORDER BY id")]
    assert [(d.get("conformance") or {}).get("overall") for d in docs] == ["pass", "fail", None]
    assert all("uncertainty_budget" in d for d in docs)
    assert [e["equipment"][0]["id"] for e in (d["test"] for d in docs)] == ["RT-02"] * 3


def test_summary_line_per_run_names_the_overall_verdict_and_worst_quantity(manifest, capsys):
    assert main(["batch", str(manifest), "--no-store"]) == 0
    lines = [x for x in capsys.readouterr().out.splitlines() if x.startswith("run ")]
    assert len(lines) == 3
    assert "good.csv): verdict pass (4 of 4 limits)" in lines[0]
    assert "bad.csv): verdict fail: worst B_z = 21" in lines[1]  # the furthest outside
    assert "(3 of 4 limits fail)" in lines[1]
    assert "plain.csv): verdict - (no specification)" in lines[2]


@pytest.mark.parametrize("text, message", [
    ('[[run]]\nplan = "p.toml"\ndata = "d.csv"\nspek = "s.toml"\n',
     'unknown key(s) spek (did you mean "spec"?)'),
    ('[defaults]\nequipmnt = "lab.toml"\n[[run]]\nplan = "p.toml"\ndata = "d.csv"\n',
     'unknown key(s) equipmnt (did you mean "equipment"?)'),
    ('[default]\nspec = "s.toml"\n[[run]]\nplan = "p.toml"\ndata = "d.csv"\n',
     'unknown table(s) default (did you mean "defaults"?)'),
])
def test_unknown_manifest_keys_are_refused_with_a_hint(tmp_path, capsys, text, message):
    (tmp_path / "m.toml").write_text(text)
    assert main(["batch", str(tmp_path / "m.toml"), "--db", str(tmp_path / "h.db")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "h.db").exists()


def test_bad_spec_file_stops_the_batch_before_anything_is_stored(manifest, tmp_path, capsys):
    bad = tmp_path / "bad_spec.toml"
    bad.write_text('[[limit]]\nquantity = "B_x"\nmax_abs = -1\nunit = "mg"\nclause = "x"\n')
    manifest.write_text(manifest.read_text().replace("[defaults]\n",
                                                     f'[defaults]\nspec = "{bad}"\n'))
    db = tmp_path / "h.db"
    assert main(["batch", str(manifest), "--db", str(db)]) == 2
    err = capsys.readouterr().err
    assert "bad_spec.toml" in err and err.count("\n") == 1
    assert not db.exists()


def test_json_runs_are_the_fit_envelope_with_messages_and_warnings_go_to_stderr(
        manifest, tmp_path, capsys):
    """Each run of --json is what `fit --json` prints (test block, messages); the warnings
    (here: equipment named without a lab file) reach stderr once, with their count. The
    batch's JSON dropped them (found by an independent review)."""
    bare = tmp_path / "bare.toml"
    plan = tomllib.loads(manifest.read_text())["run"][0]["plan"]
    bare.write_text(f'[[run]]\nplan = "{plan}"\ndata = "good.csv"\n\n'
                    f'[[run]]\nplan = "{plan}"\ndata = "plain.csv"\n')
    assert main(["batch", str(bare), "--no-store", "--json"]) == 0
    out = capsys.readouterr()
    runs = json.loads(out.out)["runs"]
    assert main(["fit", plan, str(tmp_path / "good.csv"), "--no-store", "--json"]) == 0
    single = json.loads(capsys.readouterr().out)
    assert runs[0]["result"]["messages"] == single["messages"]
    assert any("no lab equipment file" in m for m in single["messages"])
    assert runs[0]["result"]["test"]["data_sha256"] == single["test"]["data_sha256"]
    assert all(any("no lab equipment file" in w for w in r["warnings"]) for r in runs)
    lines = [x for x in out.err.splitlines() if "no lab equipment file" in x]
    assert len(lines) == 1 and "(2 of 2 runs)" in lines[0]
