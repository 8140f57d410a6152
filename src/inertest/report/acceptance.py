"""The certificate of an acceptance campaign: one report for a series of tests on one unit.

Built from the campaign's envelope (:meth:`inertest.app.acceptance.AcceptanceOutcome.to_dict`,
kind ``acceptance``) in the layout of every inertest certificate (:func:`inertest.report.html.
page`: report id and serial on every page, page x of y, the approval block and the end line):

1. *Identity of the series*: the laboratory (the lab file's ``[laboratory]``), the customer,
   the unit and its type, its receipt and condition, the deviations from the method (each
   "not stated" where the files give none; a warning when the data are simulated), the
   specification, the campaign manifest, the test dates, the command, every input file with its
   SHA-256;
2. *Conformance of the series*: one row per clause of the specification: its id, the
   requirement and the clause of the standard it comes from, the test that verifies it, the
   measured value with its expanded uncertainty U and its own coverage factor k (in the
   limit's unit too where the result has another), and the verdict (ILAC-G8:09/2019 decision
   rule of the spec, k per clause; *not tested* and *not verified* for a clause whose test has
   no data or that no test verifies); the overall verdict;
3. per test: its identity (operator, dates, equipment and calibration status, environment),
   its result, its verdicts and uncertainty budget;
4. the statement that the results relate only to the item tested, the signatures, the end.

``certificate.json`` (:func:`certificate_of`, layout ``inertest-acceptance-certificate`` version
1) holds the same: the report's id and the SHA-256 of ``index.html``, the laboratory, the
statement, the unit, the campaign (with the customer, receipt, condition, deviations and data
origin, null where not stated), the specification and decision rule, the overall verdict, the
clause table at full precision (value and U in the result's ``unit``, the limit's
``limit_unit`` beside), and each test's own certificate
(:func:`inertest.report.certificate.certificate`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from inertest.quality.conformance import DECISION_RULES, rule_text
from inertest.report.certificate import (
    RESULTS_STATEMENT,
    _json_safe,
    certificate,
    file_sha256,
    item_of,
    laboratory_of,
)
from inertest.report.conformance import conformance_sections, value_pm
from inertest.report.html import (
    Approval,
    Section,
    page,
    paragraph,
    software_version,
    table_html,
    warning,
)
from inertest.report.identity import (
    SIMULATED_NOTE,
    approval_of,
    identity_section,
    item_rows,
    laboratory_rows,
    simulated,
)
from inertest.report.sections import envelope_sections, result_sections

#: Layout of the series certificate and its version.
ACCEPTANCE_SCHEMA = "inertest-acceptance-certificate"
ACCEPTANCE_VERSION = 1
#: Header of the clause table.
CLAUSE_HEADER = ["clause", "requirement", "reference", "test", "measured ± U (k)", "verdict"]


def clause_rows(doc: Mapping[str, Any]) -> list[list[str]]:
    """The clause table's rows (:data:`CLAUSE_HEADER`) of an acceptance envelope.

    Each measured value with its U and its own k, in the limit's unit too where the result
    gives another (:func:`inertest.report.conformance.value_pm`).
    """
    rows = []
    for c in (doc.get("result") or {}).get("clauses") or []:
        measured = value_pm(c.get("value"), c.get("expanded_uncertainty"), str(c["unit"]),
                            c.get("coverage_factor"), limit_unit=str(c.get("limit_unit") or ""),
                            k_without_u=False)
        rows.append([str(c["clause"]), str(c["requirement"]), str(c["reference"]),
                     str(c.get("test") or "-"), measured, str(c["verdict"])])
    return rows


def acceptance_page(doc: Mapping[str, Any], results: Mapping[str, Any], *,
                    command: str | None = None) -> str:
    """The series certificate as one self-contained HTML page.

    Parameters
    ----------
    doc : mapping
        The campaign's envelope (kind ``acceptance``).
    results : mapping of str to result
        Each performed test's result object by test name (for its own report sections).
    command : str, optional
        The command line that ran the campaign.
    """
    res = doc.get("result") or {}
    camp = res.get("campaign") or {}
    spec = res.get("specification") or {}
    inst = doc.get("instrument") or {}
    serial = str(inst.get("serial") or "")
    tests = res.get("tests") or []
    identity: list[Sequence[object]] = [
        *laboratory_rows(res.get("laboratory")),
        ["serial", serial], ["unit type", str(inst.get("unit_type") or "not stated")],
        *item_rows(camp, where="the manifest's [campaign]"),
        ["campaign", str(camp.get("title") or "-")],
        ["campaign manifest", str(camp.get("manifest") or "-")],
        ["specification", f"{spec.get('name')} ({spec.get('file')})"],
        ["tested", f"{str(camp.get('tested_from'))[:10]} to {str(camp.get('tested_to'))[:10]}"],
    ]
    if camp.get("campaign_id"):
        identity.append(["campaign id (history database)", str(camp["campaign_id"])])
    ops = sorted({str(((t.get("result") or {}).get("test") or {}).get("operator") or "")
                  for t in tests} - {""})
    identity.append(["operator", ", ".join(ops) if ops else "not stated"])
    site = next(((t.get("result") or {}).get("site") for t in tests if t.get("result")), None)
    if site and site.get("latitude_deg") is not None:
        identity.append(["site", f"latitude {float(site['latitude_deg']):.6f} deg"])
    if command:
        identity += [["command", command], ["working folder", str(Path.cwd())]]
    files = [[t["name"], f["path"], f["sha256"]] for t in tests for f in t.get("files") or []]
    sections = [_clause_section(doc)]
    for t in tests:
        sections += _test_sections(t, results.get(str(t["name"])))
    sections.append(Section("Input files", [table_html(
        ["test", "file", "SHA-256"], files, left_columns=3,
        caption="Every input of the series (the certificate reproduces from these and the "
                "command above)")]))
    first = next((t.get("result") for t in tests if t.get("result")), None) or {}
    approval = approval_of(first) if first else Approval()
    return page(f"Acceptance certificate: {serial}", sections, identity=identity,
                subtitle=f"{camp.get('title')}. Overall verdict against {spec.get('name')}: "
                         f"{res.get('overall')}"
                         + ("" if res.get("complete") else " (the series is incomplete)")
                         + "." + (" Simulated data, not a test of a real unit."
                                  if simulated(camp) else ""),
                report_id=str(camp.get("report_id") or ""), serial=serial, approval=approval,
                statement=RESULTS_STATEMENT)


def _clause_section(doc: Mapping[str, Any]) -> Section:
    res = doc.get("result") or {}
    spec = res.get("specification") or {}
    sec = Section("Conformance of the series, clause by clause", [table_html(
        CLAUSE_HEADER, clause_rows(doc), left_columns=4,
        caption=f"Every clause of {spec.get('name')} (overall: {res.get('overall')})")])
    if simulated(res.get("campaign")):
        sec.parts.insert(0, warning(SIMULATED_NOTE))
    for c in res.get("clauses") or []:
        if c.get("note"):
            sec.parts.append(paragraph(f"{c['clause']}: {c['verdict']}: {c['note']}", note=True))
    rule = series_rule(doc)
    if rule:
        sec.parts.append(paragraph(f"Decision rule: {rule}.", note=True))
    sec.parts.append(paragraph(
        "U is the expanded uncertainty of the test's uncertainty budget (Type A of the fit and "
        "Type B of the equipment and site), k its coverage factor for 95.45 % (JCGM 100:2008 "
        "G.4.1); each test's budget is in its own section below. A clause not tested or not "
        "verified ranks with 'not determined': the series passes only when every clause "
        "passes.", note=True))
    for m in doc.get("messages") or []:
        sec.parts.append(paragraph(str(m)))
    return sec


def series_rule(doc: Mapping[str, Any]) -> str | None:
    """The series' decision rule in words, each clause with its own k (None without a rule).

    The clauses' k differ with each test's effective degrees of freedom: the sentence lists
    them as the rows' own (:func:`inertest.quality.conformance.rule_text`, ``per="clause"``),
    never one test's k for all.
    """
    res = doc.get("result") or {}
    spec = res.get("specification") or {}
    if spec.get("rule"):
        return str(spec["rule"])
    if spec.get("decision_rule") not in DECISION_RULES:
        return None
    return rule_text(str(spec["decision_rule"]),
                     (c.get("coverage_factor") for c in res.get("clauses") or []),
                     per="clause")


def _test_sections(t: Mapping[str, Any], result: Any) -> list[Section]:
    title = f"Test '{t['name']}': {t.get('title') or t['name']}"
    doc = t.get("result")
    if doc is None:
        return [Section(title, [paragraph(
            f"Planned, not performed: the campaign lists no data for it (plan {t['plan']}); "
            f"its clauses ({', '.join(t.get('verifies') or []) or 'none'}) are not tested.",
            note=True)])]
    ident = identity_section(f"{title}: identity", doc, extra_rows=[
        ["plan", str(t["plan"])], ["stored run", str(t.get("stored_run") or "not stored")]],
        with_item=False)
    body = (result_sections(result, None, title=f"{title}: result") if result is not None
            else envelope_sections(doc, title=f"{title}: result"))
    return [ident, *body, *conformance_sections(
        doc, title=f"{title}: verdicts and uncertainty budget")]


def certificate_of(doc: Mapping[str, Any], *, report_id: str,
                   report_files: Mapping[str, str] | None = None,
                   issued_at: datetime | None = None) -> dict[str, Any]:
    """The series certificate's JSON (layout in the module docstring)."""
    res = doc.get("result") or {}
    camp = res.get("campaign") or {}
    when = issued_at or datetime.now(UTC)
    return {
        "certificate_schema": ACCEPTANCE_SCHEMA,
        "certificate_version": ACCEPTANCE_VERSION,
        "report": {"id": report_id, "files": [{"name": n, "sha256": h}
                                              for n, h in (report_files or {}).items()]},
        "issued": {"software": f"inertest {software_version()}",
                   "at": when.astimezone(UTC).isoformat(timespec="seconds")},
        "laboratory": laboratory_of(res.get("laboratory")),
        "statement": RESULTS_STATEMENT,
        "unit": dict(doc.get("instrument") or {}),
        "campaign": {**camp, **item_of(camp)},
        "specification": {**(res.get("specification") or {}), "rule": series_rule(doc)},
        "overall": res.get("overall"),
        "complete": res.get("complete"),
        "clauses": list(res.get("clauses") or []),
        "tests": [{"name": t["name"], "performed": t["performed"],
                   "verifies": t.get("verifies"), "files": t.get("files"),
                   "certificate": None if t.get("result") is None else certificate(
                       t["result"], report_id=f"{report_id}/{t['name']}", issued_at=when)}
                  for t in res.get("tests") or []],
        "messages": [str(m) for m in doc.get("messages") or []],
    }


def write_acceptance_report(folder: Path, doc: Mapping[str, Any], results: Mapping[str, Any],
                            *, command: str | None = None,
                            files: Sequence[str] = ("index.html",)) -> Path:
    """Write ``index.html`` and ``certificate.json`` of a campaign into ``folder``."""
    res = doc.get("result") or {}
    report_id = str((res.get("campaign") or {}).get("report_id") or "")
    (folder / "index.html").write_text(acceptance_page(doc, results, command=command),
                                       encoding="utf-8")
    found = {n: file_sha256(folder / n) for n in files if (folder / n).is_file()}
    cert = _json_safe(certificate_of(doc, report_id=report_id, report_files=found))
    path = folder / "certificate.json"
    path.write_text(json.dumps(cert, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return path
