"""Acceptance campaigns: verdicts against hand-computed ones, incomplete series, filing.

The hand computation: a bias temperature test of known noise (sigma given, white), data without
noise so the estimate is the truth; its std is ``sigma sqrt((A^T A)^-1)`` of the straight line
over the readings' temperatures, U = 2 std (a known noise: infinite degrees of freedom, k = 2,
GUM G.1.3), and the verdict by ILAC-G8 guarded acceptance (w = U) done here by hand.
"""

from __future__ import annotations

import json
import re
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from history_database import database_at_revision
from inertest.app.acceptance import NOT_TESTED, NOT_VERIFIED, CampaignError, run_campaign
from inertest.cli import main
from inertest.io.data_file import write_table
from inertest.store import HistoryStore
from inertest.store.campaigns import campaigns

LAT = 34.25
W_UP_DEG_H = 7.2921151467e-5 * np.sin(np.radians(LAT)) * 180 / np.pi * 3600
T = np.repeat([-20.0, 0.0, 20.0, 40.0, 60.0], 10)
SIGMA = 0.05          # deg/h per reading, given


def slope_std() -> float:
    """sigma sqrt((A^T A)^-1)_11 of b = B_ref + S (T - 20) over the readings."""
    A = np.column_stack([np.ones_like(T), T - 20.0])
    return float(SIGMA * np.sqrt(np.linalg.inv(A.T @ A)[1, 1]))


def guarded(value: float, U: float, limit: float) -> str:
    """ILAC-G8:09/2019 guarded acceptance of |value| <= limit, w = U, by hand."""
    margin = limit - abs(value)
    if margin >= U:
        return "pass"
    if margin >= 0:
        return "conditional pass"
    return "conditional fail" if margin >= -U else "fail"


def write_unit(d: Path, *, serial: str, slope: float, limit: float, planned: bool = False,
               extra_clause: bool = False) -> Path:
    """A campaign with a thermal test (and optionally a planned test, an unverified clause)."""
    (d / "thermal").mkdir(parents=True)
    (d / "thermal" / "plan.toml").write_text(f"""
[site]
latitude_deg = {LAT}
[instrument]
kind = "rate-gyro"
serial = "{serial}"
output_unit = "deg/h"
[test]
operator = "T. Tester"
date = 2026-11-20
[procedure]
kind = "temperature-sensitivity"
t_ref_c = 20.0
noise_model = "white"
""")
    write_table(d / "thermal" / "steps.csv",
                {"temperature_c": T, "output": 0.3 + slope * (T - 20.0) + W_UP_DEG_H})
    limits = f"""
[spec]
name = "unit test spec"
decision_rule = "guarded"
[[limit]]
id = "tc"
quantity = "temperature_sensitivity"
max_abs = {limit}
unit = "deg/h/degC"
clause = "IEEE Std 952-1997, bias temperature sensitivity"
"""
    if extra_clause or planned:
        limits += """
[[limit]]
id = "rep"
quantity = "turn_on_repeatability"
max = 0.1
unit = "deg/h"
clause = "IEEE Std 952-1997, bias repeatability"
"""
    (d / "spec.toml").write_text(limits)
    tests = f"""
[campaign]
serial = "{serial}"
unit_type = "FOG-T"
spec = "spec.toml"

[[test]]
name = "thermal"
plan = "thermal/plan.toml"
data = "thermal/steps.csv"
verifies = ["tc"]
sigma = {SIGMA}
"""
    if planned:
        (d / "turn_on").mkdir()
        (d / "turn_on" / "plan.toml").write_text(f"""
[site]
latitude_deg = {LAT}
[instrument]
kind = "rate-gyro"
serial = "{serial}"
output_unit = "deg/h"
[procedure]
kind = "turn-on-repeatability"
sample_rate_hz = 1.0
""")
        tests += """
[[test]]
name = "turn-on"
plan = "turn_on/plan.toml"
verifies = ["rep"]
"""
    (d / "campaign.toml").write_text(tests)
    return d / "campaign.toml"


@pytest.mark.parametrize("where", [5.0, 0.5, -0.5, -5.0])   # margin in units of U
def test_verdicts_match_the_hand_computed_ones(tmp_path, where):
    """Pass, conditional pass, conditional fail, fail: the limit placed at |S| + where x U."""
    U = 2.0 * slope_std()
    slope = 0.004
    limit = slope + where * U
    out = run_campaign(write_unit(tmp_path, serial="U-1", slope=slope, limit=limit))
    (row,) = out.clauses
    assert row.value == pytest.approx(slope, rel=1e-9)
    assert row.expanded == pytest.approx(U, rel=1e-9)
    assert row.coverage_factor == 2.0
    assert row.verdict == guarded(slope, U, limit)
    assert out.overall == row.verdict and out.complete


def test_a_planned_test_and_an_unverified_clause_are_said_so(tmp_path):
    out = run_campaign(write_unit(tmp_path / "a", serial="U-2", slope=0.004, limit=0.1,
                                  planned=True))
    verdicts = {c.clause_id: c.verdict for c in out.clauses}
    assert verdicts == {"tc": "pass", "rep": NOT_TESTED}
    assert not out.complete and out.overall == NOT_TESTED
    assert any("planned, not performed" in m for m in out.messages)
    out = run_campaign(write_unit(tmp_path / "b", serial="U-3", slope=0.004, limit=0.1,
                                  extra_clause=True))
    verdicts = {c.clause_id: c.verdict for c in out.clauses}
    assert verdicts == {"tc": "pass", "rep": NOT_VERIFIED}
    assert any("verified by no test" in m for m in out.messages)
    # a fail outranks an incomplete series
    out = run_campaign(write_unit(tmp_path / "c", serial="U-4", slope=0.05, limit=0.01,
                                  extra_clause=True))
    assert out.overall == "fail"


def test_the_series_is_filed_as_one_campaign_and_a_failure_withdraws_it(tmp_path):
    db = tmp_path / "h.db"
    manifest = write_unit(tmp_path / "u", serial="U-5", slope=0.004, limit=0.1)
    out = run_campaign(manifest, store=str(db), report_dir=tmp_path / "rep")
    store = HistoryStore(str(db))
    (camp,) = campaigns(store)
    assert camp.serial == "U-5" and camp.unit_type == "FOG-T" and camp.overall == "pass"
    (run_uuid, test), = camp.runs
    assert test == "thermal" and run_uuid == out.tests[0].outcome.stored_run
    assert store.runs("U-5")[0].result["conformance"]["verdicts"][0]["verdict"] == "pass"
    cert = json.loads((tmp_path / "rep" / "certificate.json").read_text())
    assert cert["certificate_schema"] == "inertest-acceptance-certificate"
    assert cert["clauses"][0]["verdict"] == "pass"
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "Conformance of the series" in html and "page \" counter(page)" in html
    # the manifest and no lab file state no laboratory, customer or item: said so
    assert "not stated (give customer in the manifest&#x27;s [campaign])" in html
    assert "not stated (give name in the lab file&#x27;s [laboratory])" in html
    assert "The results relate only to the item tested." in html
    assert cert["campaign"]["customer"] is None and cert["campaign"]["deviations"] is None
    assert cert["laboratory"]["name"] is None
    # the same data again: refused before anything is stored
    with pytest.raises(CampaignError, match="already filed"):
        run_campaign(manifest, store=str(db))
    assert len(campaigns(store)) == 1 and len(store.runs("U-5")) == 1
    store.close()
    # a report folder that cannot be written: nothing stored in a new database
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    db2 = tmp_path / "new.db"
    with pytest.raises(Exception, match="busy"):
        run_campaign(manifest, store=str(db2), report_dir=tmp_path / "busy")
    assert not db2.exists()


def test_the_manifest_and_lab_file_state_the_job_item_and_laboratory(tmp_path):
    """[campaign] customer, receipt, condition, deviations, data origin and the lab file's
    [laboratory] (ISO/IEC 17025:2017 7.8.2.1 b, e, f, h; 7.8.3.1 a): on the certificate, in its
    JSON and in each test's own test block (stored with its run)."""
    manifest = write_unit(tmp_path / "u", serial="U-8", slope=0.004, limit=0.1)
    (tmp_path / "u" / "lab.toml").write_text("""
[laboratory]
name = "Example Lab"
address = "1 Example Street"
accreditation = "EX-0000"
[[equipment]]
id = "TC-01"
name = "Thermal chamber"
""")
    manifest.write_text(manifest.read_text().replace('spec = "spec.toml"\n', '''spec = "spec.toml"
equipment = "lab.toml"
customer = "Example Avionics Ltd"
customer_contact = "J. Buyer"
receipt_date = 2026-11-16
condition_on_receipt = "sealed, no damage"
deviations = ["thermal: five steps, not six"]
data_origin = "simulated"
'''))
    db = tmp_path / "h.db"
    out = run_campaign(manifest, store=str(db), report_dir=tmp_path / "rep")
    html = (tmp_path / "rep" / "index.html").read_text()
    for text in ("Example Lab", "1 Example Street", "EX-0000", "Example Avionics Ltd",
                 "J. Buyer", "2026-11-16", "sealed, no damage", "thermal: five steps, not six",
                 "simulated, not measured on a real unit", "The data of this report are "
                 "simulated", "The results relate only to the item tested."):
        assert text in html, text
    assert "not stated" not in html.split("Conformance of the series")[0]
    cert = json.loads((tmp_path / "rep" / "certificate.json").read_text())
    assert cert["laboratory"] == {"name": "Example Lab", "address": "1 Example Street",
                                  "accreditation": "EX-0000"}
    assert cert["statement"] == "The results relate only to the item tested."
    item = {"customer": "Example Avionics Ltd", "customer_contact": "J. Buyer",
            "receipt_date": "2026-11-16", "condition_on_receipt": "sealed, no damage",
            "deviations": ["thermal: five steps, not six"], "data_origin": "simulated"}
    assert {k: cert["campaign"][k] for k in item} == item
    (test,) = cert["tests"]
    assert {k: test["certificate"]["test"][k] for k in item} == item
    assert test["certificate"]["laboratory"] == cert["laboratory"]
    store = HistoryStore(str(db))
    stored = store.runs("U-8")[0].result["test"]
    assert stored["customer"] == "Example Avionics Ltd"
    assert stored["laboratory"]["name"] == "Example Lab"
    store.close()
    assert out.to_dict()["result"]["campaign"]["data_origin"] == "simulated"
    # a wrong value is refused before any fit
    manifest.write_text(manifest.read_text().replace('"simulated"', '"simulation"'))
    with pytest.raises(CampaignError, match="data_origin"):
        run_campaign(manifest)


def test_a_database_of_the_previous_schema_is_migrated_and_its_runs_read(tmp_path):
    """A history database at revision 0002 (before campaigns) opens, migrates to the newest,
    keeps its runs and files a campaign."""
    old = tmp_path / "old.db"
    database_at_revision(old, "0002")
    manifest = write_unit(tmp_path / "u", serial="U-6", slope=0.004, limit=0.1)
    assert main(["fit", str(tmp_path / "u" / "thermal" / "plan.toml"),
                 str(tmp_path / "u" / "thermal" / "steps.csv"), "--db", str(old),
                 "--sigma", "0.05"]) == 0
    with sqlite3.connect(old) as conn:
        assert conn.execute("select version_num from alembic_version").fetchone()[0] == "0004"
    run_campaign(manifest, store=str(old), allow_duplicate=True)
    store = HistoryStore(str(old))
    assert len(store.runs("U-6")) == 2 and len(campaigns(store, serial="U-6")) == 1
    store.close()


@pytest.mark.slow
def test_the_example_fog_campaign_runs_from_the_cli(tmp_path, examples_dir, capsys):
    """examples/fog_acceptance: every clause judged, the series certificate written."""
    src = examples_dir / "fog_acceptance" / "campaign.toml"
    report = tmp_path / "atp"
    assert main(["campaign", str(src), "--no-store", "--report", str(report), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["kind"] == "acceptance" and doc["result"]["complete"]
    verdicts = {c["clause"]: c["verdict"] for c in doc["result"]["clauses"]}
    assert set(verdicts) == {
        "bias", "bias-repeatability", "bias-stability-100s", "bias-instability", "arw",
        "warm-up-time", "sf-repeatability", "sf-asymmetry", "sf-nonlinearity",
        "bias-temperature-sensitivity"}
    assert all(v in ("pass", "conditional pass") for v in verdicts.values()), verdicts
    assert (report / "index.html").is_file() and (report / "certificate.json").is_file()
    cert = json.loads((report / "certificate.json").read_text())
    assert [t["name"] for t in cert["tests"]] == ["turn-on", "warm-up", "in-run",
                                                  "scale-factor", "thermal"]
    # the decision rule under the clause table: k per clause, not the first test's for all
    ks = sorted({f"{c['coverage_factor']:.2f}" for c in cert["clauses"]})
    assert len(ks) > 1
    rule = cert["specification"]["rule"]
    assert "k per clause as in its row: " + ", ".join(ks[:-1]) + f" and {ks[-1]}" in rule
    html = (report / "index.html").read_text()
    first = next(line for line in html.split("<p") if "Decision rule" in line)
    assert "k per clause" in first
    # the warm-up time in the limit's unit (min) beside its seconds; the JSON keeps seconds
    warm = next(c for c in cert["clauses"] if c["clause"] == "warm-up-time")
    assert warm["unit"] == "s" and warm["limit_unit"] == "min"
    assert re.search(r"\d+\.\d+\s±\s\d\.\d+\smin\s=\s\d+\s±\s\d+\ss\s\(k\s=\s\d\.\d\d\)", html)
    # the example: an example laboratory and customer, and its data simulated
    assert cert["campaign"]["data_origin"] == "simulated"
    assert cert["laboratory"]["name"].startswith("Example")
    assert cert["campaign"]["customer"].startswith("Example")
    assert "Simulated data, not a test of a real unit." in html


def test_plan_check_of_a_campaign_predicts_each_clause_before_testing(tmp_path, capsys):
    """A white-noise bias temperature test: the predicted U of the slope is 2 sigma sqrt((A^T
    A)^-1) of the plan's simulated steps (six steps of 60 readings by default), within the
    Monte Carlo's scatter; a clause no test verifies is "not verified"; exit 1 then."""
    manifest = write_unit(tmp_path, serial="U-7", slope=0.004, limit=0.01, extra_clause=True)
    (tmp_path / "thermal" / "truth.toml").write_text(
        "[coefficients]\nB_ref = 0.3\ntemperature_sensitivity = 0.004\n")
    manifest.write_text(manifest.read_text() + f"noise = {SIGMA}\n")
    assert main(["plan-check", str(manifest), "--json", "--seed", "3"]) == 1
    doc = json.loads(capsys.readouterr().out)
    rows = {r["clause"]: r for r in doc["clauses"]}
    T6 = np.repeat([-40.0, -20.0, 0.0, 20.0, 40.0, 60.0], 60)
    A = np.column_stack([np.ones_like(T6), T6 - 20.0])
    want = 2 * SIGMA * np.sqrt(np.linalg.inv(A.T @ A)[1, 1])
    assert rows["tc"]["predicted_expanded"] == pytest.approx(want, rel=0.35)
    assert rows["tc"]["status"] == "verifiable"
    assert rows["rep"]["status"] == "not verified" and rows["rep"]["test"] is None
