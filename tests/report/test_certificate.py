"""The machine-readable certificate (certificate.json) against its shipped JSON Schema.

Validated with the ``jsonschema`` package (a peer implementation of JSON Schema draft 2020-12,
a test dependency), so the schema, not our reading of it, decides what is valid.
"""

from __future__ import annotations

import copy
import hashlib
import html
import json
import tomllib
from pathlib import Path

import pytest

from inertest.cli import main
from inertest.report.certificate import (
    CERTIFICATE_VERSION,
    RESULTS_STATEMENT,
    SCHEMA_PATH,
    load_schema,
)

jsonschema = pytest.importorskip("jsonschema", reason="jsonschema is a test dependency")

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def certified(tmp_path_factory):
    """A polar-tumble run with lab file and spec, stored, reported: (folder, envelope)."""
    examples = REPO / "examples"
    tmp = tmp_path_factory.mktemp("cert")
    plan = examples / "polar_tumble" / "plan.toml"
    data = tmp / "d.csv"
    assert main(["simulate", str(plan), "--truth", str(plan.parent / "truth.toml"), "-o",
                 str(data), "--noise", "0.002", "--seed", "5"]) == 0
    assert main(["fit", str(plan), str(data), "--db", str(tmp / "h.db"), "--equipment",
                 str(examples / "lab" / "equipment.toml"), "--spec",
                 str(examples / "specs" / "floated_gyro.toml"), "--report",
                 str(tmp / "r")]) == 0
    return tmp / "r", data


def _validator():
    schema = load_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_the_schema_ships_with_the_package():
    doc = tomllib.loads((REPO / "pyproject.toml").read_text())
    data = doc["tool"]["setuptools"]["package-data"]["inertest"]
    assert "report/schemas/*.json" in data
    assert SCHEMA_PATH.is_file() and SCHEMA_PATH.parent.parent.name == "report"
    assert load_schema()["properties"]["certificate_version"]["const"] == CERTIFICATE_VERSION


def test_certificate_of_a_run_is_valid_and_complete(certified):
    folder, data = certified
    cert = json.loads((folder / "certificate.json").read_text())
    errors = sorted(_validator().iter_errors(cert), key=str)
    assert errors == []
    # the report it certifies, by SHA-256
    files = {f["name"]: f["sha256"] for f in cert["report"]["files"]}
    assert files == {"index.html": hashlib.sha256((folder / "index.html").read_bytes())
                     .hexdigest()}
    assert cert["test"]["data_sha256"] == hashlib.sha256(data.read_bytes()).hexdigest()
    assert cert["instrument"] == {"kind": "sdf-gyro", "serial": "FG-0417"}
    assert cert["test"]["date"] == "2026-11-16" and cert["test"]["date_source"] == "plan"
    assert cert["test"]["filed_at"] is not None
    # traceability: every item with its certificate and status on the test date
    assert {e["id"]: e["status_on_test_date"] for e in cert["equipment"]} == {
        "RT-02": "valid", "GRAV-01": "valid"}
    assert cert["equipment"][0]["calibration_certificate"] == "DKD-K-12345 2026-03"
    # results with U and k from the budget, at full precision (the envelope's numbers)
    by_name = {r["quantity"]: r for r in cert["results"]}
    di = by_name["DI"]
    assert di["unit"] == "deg/h/g" and di["coverage_factor"] > 1.9
    assert di["expanded_uncertainty"] == pytest.approx(
        di["coverage_factor"] * di["standard_uncertainty"], rel=1e-12)
    assert len(repr(di["value"])) > 8  # not rounded for display
    assert cert["conformance"]["decision_rule"] == "guarded"
    assert "ILAC-G8" in cert["conformance"]["rule"]
    assert {v["quantity"] for v in cert["conformance"]["verdicts"]} >= {"DI", "DO", "DS"}
    assert cert["report"]["id"] in (folder / "index.html").read_text()


def test_a_fit_certificate_states_laboratory_statement_and_what_is_not_stated(certified):
    """The lab file's [laboratory] and the fixed statement (ISO/IEC 17025:2017 7.8.2.1 b, k);
    the plan's [test] gives no customer, receipt, condition or deviations: null in the JSON,
    "not stated" in the report."""
    folder, _ = certified
    cert = json.loads((folder / "certificate.json").read_text())
    assert cert["laboratory"]["name"].startswith("Example Inertial Test Laboratory")
    assert cert["laboratory"]["accreditation"].startswith("EXAMPLE-ACC-0000")
    assert cert["statement"] == RESULTS_STATEMENT
    assert {k: cert["test"][k] for k in ("customer", "customer_contact", "receipt_date",
                                         "condition_on_receipt", "deviations",
                                         "data_origin")} == dict.fromkeys(
        ("customer", "customer_contact", "receipt_date", "condition_on_receipt", "deviations",
         "data_origin"))
    assert all(v["limit_unit"] == "deg/h/g" for v in cert["conformance"]["verdicts"])
    page = html.unescape((folder / "index.html").read_text())
    assert "Example Inertial Test Laboratory" in page
    assert "not stated (give customer in the plan's [test])" in page
    assert "not stated (give deviations in the plan's [test])" in page
    assert page.count(RESULTS_STATEMENT) == 1


def test_the_schema_rejects_what_is_not_a_certificate(certified):
    folder, _ = certified
    cert = json.loads((folder / "certificate.json").read_text())
    v = _validator()
    for change in (
        lambda c: c.pop("results"),
        lambda c: c["results"][0].__setitem__("value", "0.86"),
        lambda c: c["test"].__setitem__("date", "16.11.2026"),
        lambda c: c["report"]["files"][0].__setitem__("sha256", "abc"),
        lambda c: c.__setitem__("certificate_version", 2),
        lambda c: c["equipment"][0].__setitem__("status_on_test_date", "fine"),
        lambda c: c.__setitem__("extra", 1),
        lambda c: c.__setitem__("statement", "Results apply to the lot."),
        lambda c: c["laboratory"].__setitem__("phone", "0"),
        lambda c: c["test"].__setitem__("data_origin", "guessed"),
        lambda c: c["test"].__setitem__("deviations", "none"),
        lambda c: c["test"].__setitem__("receipt_date", "16.11.2026"),
    ):
        bad = copy.deepcopy(cert)
        change(bad)
        assert not v.is_valid(bad)


def test_a_run_without_budget_says_u_and_k_are_not_given(examples_dir, tmp_path):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    data = tmp_path / "d.csv"
    assert main(["simulate", str(plan), "--truth", str(plan.parent / "truth.toml"), "-o",
                 str(data), "--noise", "0.002", "--seed", "6"]) == 0
    assert main(["fit", str(plan), str(data), "--no-store", "--report", str(tmp_path / "r")]) == 0
    cert = json.loads((tmp_path / "r" / "certificate.json").read_text())
    assert _validator().is_valid(cert)
    assert all(r["expanded_uncertainty"] is None and r["coverage_factor"] is None
               for r in cert["results"])
    assert cert["uncertainty"]["basis"].startswith("Type A only")
    assert cert["test"]["filed_at"] is None and cert["conformance"] is None
    assert cert["report"]["id"].startswith("R-")
    # no lab file: the laboratory is not stated, and the report says so
    assert cert["laboratory"] == {"name": None, "address": None, "accreditation": None}
    page = html.unescape((tmp_path / "r" / "index.html").read_text())
    assert "not stated (give name in the lab file's [laboratory])" in page
    assert RESULTS_STATEMENT in page
