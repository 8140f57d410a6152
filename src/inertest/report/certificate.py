"""The machine-readable certificate: a run's envelope as a versioned JSON document.

A lab's systems (LIMS, asset management, a quality manager's review) read a calibration
certificate, not an analysis dump. :func:`certificate` turns a result envelope (with its
``test``, ``uncertainty_budget`` and ``conformance`` blocks) into the document
``certificate.json`` that ``inertest fit --report DIR`` writes beside ``index.html``:

- ``certificate_schema``, ``certificate_version``: which layout (this is version 1; a change of
  layout bumps it and is listed in the CHANGELOG);
- ``report``: the report id (certificate number or run id) and the SHA-256 of every report file
  (``index.html``, ``report.pdf``), so the certificate names the exact report it belongs to;
- ``issued``: software and time of issue;
- ``laboratory``: the lab file's ``[laboratory]`` (name, address, accreditation; null where not
  stated) and ``statement``, "The results relate only to the item tested." (ISO/IEC
  17025:2017 7.8.2.1 b, k);
- ``instrument``, ``site``, ``test`` (procedure, test date and where it comes from, filing time
  when stored, operator, environment, the data's SHA-256; customer and contact, receipt date,
  condition on receipt, deviations from the method, data origin: null where not stated, the
  deviations ``[]`` when stated as none), ``approval``;
- ``equipment``: each item with its calibration certificate, dates and status on the test date
  (the traceability, ISO/IEC 17025:2017 6.5, 7.8.2.1);
- ``results``: per quantity its value, standard uncertainty, and, with a budget, the expanded
  uncertainty U, the coverage factor k, the coverage probability and the effective degrees of
  freedom (JCGM 100:2008, GUM 6.2, G.4.1), all at full precision (rounding is for display
  only, :mod:`inertest.report.rounding`); what the test cannot determine;
- ``conformance``: the verdicts with the decision rule (ILAC-G8:09/2019), or null; each
  verdict's value in the result's ``unit`` and its ``limit_unit``, the unit of the limit.

The layout is fixed by the JSON Schema :data:`SCHEMA_PATH` (draft 2020-12), shipped with the
package; docs/certificate.md describes every field.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import fields
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from inertest.plan import TestItem
from inertest.quality.lab import LABORATORY_KEYS

#: Name of the layout and its version (bumped on any change of layout).
CERTIFICATE_SCHEMA = "inertest-certificate"
CERTIFICATE_VERSION = 1
#: The JSON Schema of this version, shipped as package data.
SCHEMA_PATH = Path(__file__).resolve().parent / "schemas" / "certificate-1.schema.json"
#: File name of the certificate in a report folder.
CERTIFICATE_FILE = "certificate.json"
#: Report files whose SHA-256 the certificate records, when present.
REPORT_FILES = ("index.html", "report.pdf")
#: The statement every certificate makes (ISO/IEC 17025:2017 7.8.2.1 k).
RESULTS_STATEMENT = "The results relate only to the item tested."
#: The keys of the job and the item in the ``test`` block (:class:`inertest.plan.TestItem`).
ITEM_KEYS = tuple(f.name for f in fields(TestItem))


def certificate(doc: Mapping[str, Any], *, report_id: str,
                report_files: Mapping[str, str] | None = None,
                issued_at: datetime | None = None) -> dict[str, Any]:
    """The certificate of one run (layout: module docstring and :data:`SCHEMA_PATH`).

    Parameters
    ----------
    doc : mapping
        The run's result envelope with its ``test`` block (and budget, conformance).
    report_id : str
        Certificate number or run id (printed on every page of the report).
    report_files : mapping, optional
        ``{file name: SHA-256}`` of the report's files.
    issued_at : datetime, optional
        Time of issue (default: now, UTC).
    """
    test: Mapping[str, Any] = doc.get("test") or {}
    inst: Mapping[str, Any] = doc.get("instrument") or {}
    budget: Mapping[str, Any] = doc.get("uncertainty_budget") or {}
    conf: Mapping[str, Any] | None = doc.get("conformance")
    when = issued_at or datetime.now(UTC)
    return {
        "certificate_schema": CERTIFICATE_SCHEMA,
        "certificate_version": CERTIFICATE_VERSION,
        "report": {"id": report_id, "files": [
            {"name": n, "sha256": h} for n, h in (report_files or {}).items()]},
        "issued": {"software": f"inertest {test.get('software_version') or 'unknown'}",
                   "at": when.astimezone(UTC).isoformat(timespec="seconds")},
        "laboratory": laboratory_of(test.get("laboratory")),
        "statement": RESULTS_STATEMENT,
        "instrument": {"kind": str(inst.get("kind") or ""),
                       "serial": str(inst.get("serial") or "")},
        "site": _site(doc.get("site") or {}),
        "test": {
            "procedure": str(doc.get("kind") or ""),
            "date": test.get("date"),
            "tested_at": test.get("tested_at"),
            "date_source": test.get("date_source"),
            "filed_at": test.get("filed_at"),
            "operator": test.get("operator") or None,
            "environment": dict(test.get("environment") or {}),
            "notes": test.get("notes") or None,
            "data_sha256": test.get("data_sha256"),
            "certificate": test.get("certificate"),
            **item_of(test),
        },
        "approval": _approval(test.get("approval") or {}),
        "equipment": [_equipment(e) for e in test.get("equipment") or []],
        "results": _results(doc.get("identification") or {}, budget),
        "not_determined": [str(s) for s in (doc.get("identification") or {}).get(
            "not_separable") or []],
        "uncertainty": ({"basis": "GUM budget: Type A of the fit and Type B of the equipment "
                                  "and site (JCGM 100:2008 5.1.2, G.4.1)",
                         "coverage_probability": budget.get("coverage_probability"),
                         "assumptions": list(budget.get("assumptions") or [])}
                        if budget else
                        {"basis": "Type A only (standard uncertainty of the fit); no budget: "
                                  "give --equipment or --spec for U and k",
                         "coverage_probability": None, "assumptions": []}),
        "conformance": None if not conf else {
            "specification": conf.get("spec"),
            "decision_rule": conf.get("decision_rule"),
            "rule": conf.get("rule"),
            "overall": conf.get("overall"),
            "verdicts": [_verdict(v) for v in conf.get("verdicts") or []],
        },
        "messages": [str(m) for m in doc.get("messages") or []],
    }


def laboratory_of(lab: Mapping[str, Any] | None) -> dict[str, Any]:
    """``{"name", "address", "accreditation"}``, null where not stated."""
    return {k: (lab or {}).get(k) or None for k in LABORATORY_KEYS}


def item_of(block: Mapping[str, Any]) -> dict[str, Any]:
    """The job and the item of a ``test`` or ``campaign`` block, null where not stated.

    ``deviations`` stays ``[]`` when stated as none (null: not stated).
    """
    out = {k: block.get(k) or None for k in ITEM_KEYS}
    dev = block.get("deviations")
    out["deviations"] = None if dev is None else [str(d) for d in dev]
    return out


def _site(site: Mapping[str, Any]) -> dict[str, Any]:
    return {"latitude_deg": site.get("latitude_deg"), "gravity_m_s2": site.get("gravity_m_s2")}


def _approval(a: Mapping[str, Any]) -> dict[str, Any]:
    return {k: a.get(k) for k in ("performed_by", "performed_on", "reviewed_by", "reviewed_on",
                                  "approved_by", "approved_on")}


def _equipment(e: Mapping[str, Any]) -> dict[str, Any]:
    overdue = e.get("calibration_overdue")
    return {
        "id": str(e.get("id", "")), "name": e.get("name") or None, "model": e.get("model") or None,
        "serial": e.get("serial") or None, "calibration_certificate": e.get("certificate") or None,
        "calibrated": e.get("calibrated"), "calibration_due": e.get("calibration_due"),
        "status_on_test_date": ("overdue" if overdue else "valid" if overdue is False
                                else "unknown"),
    }


def _results(ident: Mapping[str, Any], budget: Mapping[str, Any]) -> list[dict[str, Any]]:
    quantities: Mapping[str, Any] = budget.get("quantities") or {}
    out = []
    items: list[tuple[str, str, Mapping[str, Any], Mapping[str, float] | None]] = [
        (n, "coefficient", e, None) for n, e in (ident.get("coefficients") or {}).items()]
    items += [(c["name"], "combination", c, dict(c.get("terms") or {}))
              for c in ident.get("combinations") or []]
    for name, kind, e, terms in items:
        q = quantities.get(name) or {}
        out.append({
            "quantity": name, "kind": kind, "terms": terms,
            "value": float(e["value"]), "unit": str(e["unit"]),
            "standard_uncertainty": float(q.get("combined_std", e["std"])),
            "type_a_std": float(e["std"]),
            "expanded_uncertainty": q.get("expanded"),
            "coverage_factor": q.get("coverage_factor"),
            "effective_dof": q.get("effective_dof"),
        })
    return out


def _verdict(v: Mapping[str, Any]) -> dict[str, Any]:
    return {"quantity": v.get("quantity"), "value": v.get("value"), "unit": v.get("unit"),
            "expanded_uncertainty": v.get("expanded_uncertainty"),
            "coverage_factor": v.get("coverage_factor"), "limit": v.get("limit"),
            "limit_unit": v.get("limit_unit") or v.get("unit"),
            "clause": v.get("clause"), "verdict": v.get("verdict"), "note": v.get("note")}


def _json_safe(v: Any) -> Any:
    """``v`` with every NaN or infinity as null (JSON has neither)."""
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, Mapping):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_json_safe(x) for x in v]
    return v


def file_sha256(path: Path) -> str:
    """SHA-256 of a report file (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_certificate(folder: Path, doc: Mapping[str, Any], *, report_id: str,
                      files: Sequence[str] = REPORT_FILES) -> Path:
    """Write ``certificate.json`` into the report ``folder``, with the SHA-256 of its files."""
    found = {n: file_sha256(folder / n) for n in files if (folder / n).is_file()}
    path = folder / CERTIFICATE_FILE
    cert = _json_safe(certificate(doc, report_id=report_id, report_files=found))
    path.write_text(json.dumps(cert, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return path


def load_schema() -> dict[str, Any]:
    """The certificate's JSON Schema (:data:`SCHEMA_PATH`)."""
    schema: dict[str, Any] = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
    return schema
