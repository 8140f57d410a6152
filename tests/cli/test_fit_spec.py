"""`inertest fit --spec --equipment`: verdicts and the uncertainty budget in the JSON envelope,
the terminal, the report and the stored run (issue 20)."""

from __future__ import annotations

import json
import math
import re

import pytest

from inertest.cli import main
from inertest.store import HistoryStore


@pytest.fixture
def tumble(tmp_path, examples_dir):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    data = tmp_path / "tumble.csv"
    assert main(["simulate", str(plan), "--truth", str(examples_dir / "polar_tumble" /
                 "truth.toml"), "-o", str(data), "--noise", "0.002", "--seed", "3"]) == 0
    return plan, data


def test_fit_spec_equipment_json_has_budget_and_verdicts(tumble, examples_dir, capsys):
    plan, data = tumble
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--no-store",
                 "--equipment", str(examples_dir / "lab" / "equipment.toml"),
                 "--spec", str(examples_dir / "specs" / "floated_gyro.toml")]) == 0
    doc = json.loads(capsys.readouterr().out)
    keys = list(doc)
    assert keys.index("result") < keys.index("uncertainty_budget") < keys.index("conformance")
    budget = doc["uncertainty_budget"]
    ident = doc["identification"]
    di = budget["quantities"]["DI"]
    # Type A is the fit's std; the combined std is the root sum of squares (GUM 5.1.2)
    assert di["type_a"]["std"] == ident["coefficients"]["DI"]["std"]
    rss = math.sqrt(di["type_a"]["std"] ** 2 + sum(c["contribution"] ** 2
                                                   for c in di["type_b"]))
    assert di["combined_std"] == pytest.approx(rss, rel=1e-12)
    assert di["expanded"] == pytest.approx(di["coverage_factor"] * rss, rel=1e-12)
    sources = {c["source"] for c in di["type_b"]}
    # the plan names RT-02 and GRAV-01: tilt (both directions of the table axis) and encoder
    # angle of the table, measured gravity
    assert sources == {"RT-02 tilt_urad (meridian)", "RT-02 tilt_urad (east-west)",
                       "RT-02 angle_arcsec", "GRAV-01 gravity_mgal"}
    # the table accepts a squareness the lab file does not state: named, not silently dropped
    assert any("not included" in a and "squareness_urad" in a for a in budget["assumptions"])
    assert any("rate_ppm" in n for n in budget["not_applicable"])
    assert any("independent" in a for a in budget["assumptions"])
    conf = doc["conformance"]
    assert "ILAC-G8" in conf["rule"]
    assert [v["quantity"] for v in conf["verdicts"]] == ["DI", "DO", "DS"]
    for v in conf["verdicts"]:
        assert v["expanded_uncertainty"] == pytest.approx(
            budget["quantities"][v["quantity"]]["expanded"])
        assert v["coverage_factor"] == pytest.approx(
            budget["quantities"][v["quantity"]]["coverage_factor"])
        # truth DI 0.85, DO -0.62, DS 0.31 deg/h/g: inside by far more than U
        assert v["verdict"] == "pass"
    assert conf["overall"] == "pass"


def test_fit_spec_terminal_report_and_store(tumble, examples_dir, tmp_path, capsys):
    plan, data = tumble
    db, rep = tmp_path / "h.db", tmp_path / "rep"
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--db", str(db), "--report", str(rep),
                 "--spec", str(examples_dir / "specs" / "floated_gyro.toml")]) == 0
    out = capsys.readouterr().out
    assert "verdicts against Example spec, navigation-grade floated gyro" in out
    assert "decision rule: ILAC-G8" in out
    assert "uncertainty budget" in out
    html = re.sub(r"<[^>]+>", "", (rep / "index.html").read_text(encoding="utf-8"))
    assert "Conformance and uncertainty budget" in html and "IEEE Std 517-1974" in html
    assert "Type B: site gravity" in html  # the plan's gravity is the normal formula
    store = HistoryStore(str(db))
    try:
        (run,) = store.runs("FG-0417", procedure="polar-tumble")
    finally:
        store.close()
    assert run.result["conformance"]["overall"] == "pass"
    assert "DI" in run.result["uncertainty_budget"]["quantities"]


def test_fit_spec_naming_an_unknown_quantity_is_a_clean_error(tumble, tmp_path, capsys):
    plan, data = tumble
    spec = tmp_path / "spec.toml"
    spec.write_text('[[limit]]\nquantity = "DX"\nmax_abs = 1.0\nunit = "deg/h/g"\n'
                    'clause = "IEEE Std 517-1974"\n')
    db, rep = tmp_path / "h.db", tmp_path / "rep"
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--db", str(db), "--report", str(rep),
                 "--spec", str(spec)]) != 0
    err = capsys.readouterr().err
    assert 'quantity "DX" is not a quantity of polar-tumble' in err and "Traceback" not in err
    assert not rep.exists() and not db.exists()


def test_demo_report_shows_a_budget_per_result_and_verdicts_where_a_spec_is_named(
        tmp_path, examples_dir):
    import tomllib

    from inertest.demo import run_campaign, write_campaign_report

    campaign = tomllib.loads((examples_dir / "demo.toml").read_text())["test"]
    tests = run_campaign(examples_dir / "demo.toml")
    html = write_campaign_report(tests, tmp_path / "rep").read_text(encoding="utf-8")
    assert html.count("conformance and uncertainty budget") == len(campaign)
    assert html.count("Verdicts against") == sum("spec" in t for t in campaign) >= 8
    for t in tests:
        doc = t.to_dict()
        assert doc["uncertainty_budget"]["quantities"]
        assert ("conformance" in doc) == (t.conformance is not None)


def test_overdue_calibration_and_unchecked_equipment_are_in_the_json_messages(
        tumble, examples_dir, tmp_path, capsys):
    plan, data = tumble
    # DH-01's calibration ran out on 2026-09-15, before the plan's test date 2026-11-16
    overdue = tmp_path / "plan.toml"
    overdue.write_text(plan.read_text().replace('equipment = ["RT-02", "GRAV-01"]',
                                                'equipment = ["RT-02", "DH-01"]'))
    capsys.readouterr()
    assert main(["fit", str(overdue), str(data), "--json", "--no-store",
                 "--equipment", str(examples_dir / "lab" / "equipment.toml")]) == 0
    cap = capsys.readouterr()
    (msg,) = [m for m in json.loads(cap.out)["messages"] if "Calibration of DH-01" in m]
    assert "2026-09-15" in msg and "Calibration of DH-01" in cap.err
    # without a lab file the plan's ids cannot be checked and no Type B is included: said so
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    cap = capsys.readouterr()
    (msg,) = [m for m in json.loads(cap.out)["messages"] if "no lab equipment file" in m]
    assert "RT-02, GRAV-01" in msg and "not checked" in msg and "Type-B" in msg
    assert "no lab equipment file" in cap.err


def test_fit_spec_limit_on_an_inseparable_coefficient_is_not_determined(tumble, tmp_path,
                                                                       capsys):
    # DF is in the polar tumble's model but determined only in DF + (g/g0)^2 DII: the fit
    # goes on, DF gets "not determined", DI is judged
    plan, data = tumble
    spec = tmp_path / "spec.toml"
    spec.write_text('[[limit]]\nquantity = "DF"\nmax_abs = 2.0\nunit = "deg/h"\nclause = "c"\n'
                    '[[limit]]\nquantity = "DI"\nmax_abs = 1.0\nunit = "deg/h/g"\n'
                    'clause = "c"\n')
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--no-store", "--spec", str(spec)]) == 0
    out = capsys.readouterr().out
    assert "not determined: DF is not determined by this test" in out
    assert "determined instead: DF + 0.99" in out and "pass" in out
    # the rule states the k the verdicts used (320 readings: k = t_95.45(nu_eff) > 2)
    assert "expanded uncertainty, k = 2.0" in out and "k = 2)" not in out
