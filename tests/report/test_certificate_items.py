"""What a certificate states beyond the results (ISO/IEC 17025:2017 7.8.2.1, 7.8.3.1), unit by
unit: the laboratory, the customer, the item's receipt and condition, the deviations from the
method and where the data come from, each printed "not stated" where no file gives it; the
statement that the results relate only to the item tested; one decision-rule sentence for a
series whose clauses have their own k; a value shown in its limit's unit.
"""

from __future__ import annotations

import html
import re

from inertest.report.acceptance import acceptance_page, certificate_of, clause_rows, series_rule
from inertest.report.certificate import RESULTS_STATEMENT
from inertest.report.conformance import value_pm, verdict_rows
from inertest.report.identity import SIMULATED_NOTE, identity_rows, item_rows, laboratory_rows

ITEM = {"customer": "Example Avionics Ltd", "customer_contact": "J. Buyer",
        "receipt_date": "2026-11-16", "condition_on_receipt": "sealed, no damage",
        "deviations": [], "data_origin": "simulated"}
LAB = {"name": "Example Lab", "address": "1 Example Street", "accreditation": "EX-0000"}


def _text(page: str) -> str:
    """The page's text, one table cell or paragraph per line."""
    body = page[page.index("<body>"):]
    return html.unescape(re.sub(r"\n+", "\n", re.sub(r"<[^>]+>", "\n", body)))


def _clause(cid: str, value: float, big_u: float, k: float, unit: str, limit_unit: str,
            limit: str, test: str) -> dict:
    return {"clause": cid, "requirement": limit, "reference": "IEEE Std 952-1997",
            "quantity": cid, "test": test, "value": value, "expanded_uncertainty": big_u,
            "coverage_factor": k, "unit": unit, "limit_unit": limit_unit, "verdict": "pass",
            "note": ""}


def _series(item: dict | None = None, lab: dict | None = None) -> dict:
    """An acceptance envelope of three clauses judged by two tests with their own k."""
    campaign = {"title": "ATP of U-1", "manifest": "c.toml", "report_id": "ATP-1",
                "certificate": "ATP-1", "tested_from": "2026-11-16T00:00:00+00:00",
                "tested_to": "2026-11-20T00:00:00+00:00", **(item or {})}
    return {"kind": "acceptance", "instrument": {"serial": "U-1", "unit_type": "FOG-T"},
            "result": {
                "campaign": campaign,
                **({"laboratory": lab} if lab is not None else {}),
                "specification": {"name": "spec", "file": "s.toml", "decision_rule": "guarded"},
                "overall": "pass", "complete": True,
                "clauses": [
                    _clause("bias", 0.343, 0.098, 2.65, "deg/h", "deg/h", "B <= 1 deg/h",
                            "turn-on"),
                    _clause("warm-up-time", 1029.8684048667717, 54.396268866748244,
                            2.010605739230035, "s", "min", "warm_up_time <= 20 min", "warm-up"),
                    _clause("arw", 0.004961, 0.000091, 2.08, "deg/sqrt(h)", "deg/sqrt(h)",
                            "ARW <= 0.01 deg/sqrt(h)", "in-run")],
                "tests": [{"name": "thermal", "title": "Thermal", "plan": "p.toml",
                           "performed": False, "verifies": [], "stored_run": None,
                           "files": [{"path": "p.toml", "sha256": "0" * 64}],
                           "result": None}]},
            "messages": []}


def test_the_laboratory_customer_and_item_are_printed_when_given():
    rows = dict(map(tuple, laboratory_rows(LAB) + item_rows(ITEM)))
    assert rows == {"laboratory": "Example Lab", "laboratory address": "1 Example Street",
                    "accreditation": "EX-0000", "customer": "Example Avionics Ltd",
                    "customer contact": "J. Buyer", "item received": "2026-11-16",
                    "condition on receipt": "sealed, no damage",
                    "deviations from the method": "none",
                    "data origin": "simulated, not measured on a real unit"}
    assert item_rows({"deviations": ["thermal: 5 steps, not 7", "no humidity record"]})[4] == [
        "deviations from the method", "thermal: 5 steps, not 7; no humidity record"]


def test_what_is_not_given_is_printed_not_stated_with_where_to_give_it():
    rows = dict(map(tuple, laboratory_rows(None) + item_rows({}, where="the manifest's "
                                                                       "[campaign]")))
    assert rows["laboratory"] == "not stated (give name in the lab file's [laboratory])"
    assert rows["accreditation"].startswith("not stated")
    assert rows["customer"] == "not stated (give customer in the manifest's [campaign])"
    assert rows["item received"].startswith("not stated (give receipt_date")
    assert rows["condition on receipt"].startswith("not stated (give condition_on_receipt")
    assert rows["deviations from the method"].startswith("not stated (give deviations")
    assert "data origin" not in rows          # stated only when given
    # a fit's identity: every one of them, from an envelope whose test block has none
    fit = dict(map(tuple, identity_rows({"kind": "polar-tumble", "test": {"operator": "A"}})))
    assert fit["customer"] == "not stated (give customer in the plan's [test])"
    assert fit["laboratory"].startswith("not stated")


def test_the_series_certificate_states_them_and_the_statement():
    text = _text(acceptance_page(_series(ITEM, LAB), {}))
    for line in ("Example Lab", "1 Example Street", "EX-0000", "Example Avionics Ltd",
                 "J. Buyer", "2026-11-16", "sealed, no damage", SIMULATED_NOTE,
                 RESULTS_STATEMENT):
        assert f"\n{line}\n" in text, line
    assert "Simulated data, not a test of a real unit." in text
    # the statement comes once, before the end of the report
    assert text.count(RESULTS_STATEMENT) == 1
    assert text.index(RESULTS_STATEMENT) < text.index("End of report ATP-1")
    cert = certificate_of(_series(ITEM, LAB), report_id="ATP-1")
    assert cert["laboratory"] == LAB and cert["statement"] == RESULTS_STATEMENT
    assert {k: cert["campaign"][k] for k in ITEM} == ITEM


def test_the_series_certificate_says_not_stated_and_nulls_when_absent():
    text = _text(acceptance_page(_series(), {}))
    for key in ("name", "address", "accreditation"):
        assert f"not stated (give {key} in the lab file's [laboratory])" in text
    for key in ("customer", "customer_contact", "receipt_date", "condition_on_receipt",
                "deviations"):
        assert f"not stated (give {key} in the manifest's [campaign])" in text
    assert SIMULATED_NOTE not in text and "Simulated data" not in text
    assert RESULTS_STATEMENT in text
    cert = certificate_of(_series(), report_id="ATP-1")
    assert cert["laboratory"] == {"name": None, "address": None, "accreditation": None}
    assert all(cert["campaign"][k] is None for k in ITEM)


def test_the_series_decision_rule_gives_each_clause_its_own_k():
    """Three clauses of k = 2.65, 2.01 and 2.08: the sentence under the table lists them as
    the rows' own (was the first test's k = 2.65 for the whole table)."""
    doc = _series()
    rule = series_rule(doc)
    assert "k per clause as in its row: 2.01, 2.08 and 2.65" in rule
    assert "k = 2.65" not in rule
    text = _text(acceptance_page(doc, {}))
    (sentence,) = [x for x in text.splitlines() if x.startswith("Decision rule")]
    assert "k per clause" in sentence and "k = " not in sentence
    # every row prints its own k
    assert [r[4].rsplit("(k = ", 1)[1] for r in clause_rows(doc)] == ["2.65)", "2.01)", "2.08)"]
    assert certificate_of(doc, report_id="ATP-1")["specification"]["rule"] == rule
    # one k for every clause: said once
    one = _series()
    for c in one["result"]["clauses"]:
        c["coverage_factor"] = 2.0
    assert "k = 2.00)" in series_rule(one)


def test_a_value_is_shown_in_its_limits_unit_beside_its_own():
    """1029.87 s ± 54.40 s against <= 20 min: 17.16 ± 0.91 min (1029.87 / 60 = 17.164,
    54.396 / 60 = 0.9066), then the value as measured; the JSON keeps seconds."""
    doc = _series()
    row = clause_rows(doc)[1]
    assert row[4] == "17.16 ± 0.91 min = 1030 ± 54 s (k = 2.01)"
    assert clause_rows(doc)[0][4] == "0.343 ± 0.098 deg/h (k = 2.65)"   # same unit: as before
    cert = certificate_of(doc, report_id="ATP-1")
    warm = cert["clauses"][1]
    assert (warm["value"], warm["unit"], warm["limit_unit"]) == (1029.8684048667717, "s", "min")
    # a single run's verdict table does the same
    (r,) = verdict_rows({"verdicts": [{
        "quantity": "warm_up_time", "value": 1029.8684048667717,
        "expanded_uncertainty": 54.396268866748244, "coverage_factor": 2.010605739230035,
        "unit": "s", "limit_unit": "min", "limit": "warm_up_time <= 20 min",
        "clause": "IEEE Std 952-1997", "verdict": "pass"}]})
    assert r[1] == "17.16 ± 0.91 min = 1030 ± 54 s (k = 2.01)"
    # an envelope stored before limit_unit existed prints as it did
    assert value_pm(1029.8684, 54.396, "s", 2.01) == "1030 ± 54 s (k = 2.01)"
    assert value_pm(None, None, "s", None, limit_unit="min") == "-"
