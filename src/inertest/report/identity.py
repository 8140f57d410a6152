"""Who, what, when, where and with what: the identity rows of every report and terminal table.

Built from a result envelope (:func:`inertest.results.envelope`) and its optional ``test`` block
(:func:`inertest.quality.lab.identity_block`), so the terminal, the JSON and the HTML report
state the same identity: instrument and serial, site, operator, date, software version, data
SHA-256, the equipment used with its calibration status, and the environment; the laboratory
(the lab file's ``[laboratory]``), the customer, the item's receipt and condition, the
deviations from the method and where the data come from (the plan's ``[test]``, a campaign's
``[campaign]``: :class:`inertest.plan.TestItem`), each "not stated" where no file gives it, so
that a reviewer sees what is missing. ISO/IEC 17025 7.8.2 lists what a test report identifies;
this is that list for an inertial instrument test.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from inertest.report.html import Approval, Section, paragraph, table_html, warning

_ENV_LABELS = {"temperature": "temperature", "humidity": "relative humidity",
               "warm_up": "warm-up before the first reading"}


#: The lab file's ``[laboratory]`` keys as a report names them.
_LABORATORY_LABELS = (("name", "laboratory"), ("address", "laboratory address"),
                      ("accreditation", "accreditation"))
#: The sentence a report prints when its data are simulated (``data_origin = "simulated"``).
SIMULATED_NOTE = ("The data of this report are simulated (data_origin = \"simulated\"): it shows "
                  "the procedure and its computation, not a test of a real unit.")


def _not_stated(key: str, where: str) -> str:
    return f"not stated (give {key} in {where})"


def laboratory_rows(laboratory: Mapping[str, Any] | None) -> list[list[str]]:
    """``[item, value]`` rows of the laboratory: name, address, accreditation, or not stated.

    Parameters
    ----------
    laboratory : mapping or None
        ``{"name", "address", "accreditation"}`` (the envelope's ``test.laboratory``).
    """
    lab = laboratory or {}
    return [[label, str(lab.get(key) or _not_stated(key, "the lab file's [laboratory]"))]
            for key, label in _LABORATORY_LABELS]


def item_rows(item: Mapping[str, Any], *, where: str = "the plan's [test]") -> list[list[str]]:
    """``[item, value]`` rows of the job and the item tested, "not stated" where not given.

    Customer and contact, date of receipt, condition on receipt, deviations from the method
    (``none`` when stated as ``[]``) and, when stated, where the data come from.

    Parameters
    ----------
    item : mapping
        The keys of :meth:`inertest.plan.TestItem.to_dict` (an envelope's ``test`` block, a
        campaign's ``campaign`` block).
    where : str
        The table that gives them, for the "not stated" hint.
    """
    rows = [[label, str(item.get(key) or _not_stated(key, where))] for key, label in (
        ("customer", "customer"), ("customer_contact", "customer contact"),
        ("receipt_date", "item received"), ("condition_on_receipt", "condition on receipt"))]
    dev = item.get("deviations")
    rows.append(["deviations from the method",
                 _not_stated("deviations", where) if dev is None
                 else "; ".join(str(d) for d in dev) if dev else "none"])
    origin = item.get("data_origin")
    if origin:
        rows.append(["data origin", "simulated, not measured on a real unit"
                     if origin == "simulated" else str(origin)])
    return rows


def simulated(item: Mapping[str, Any] | None) -> bool:
    """Whether the job states that its data are simulated."""
    return bool(item) and (item or {}).get("data_origin") == "simulated"


def identity_rows(doc: Mapping[str, Any], *, with_item: bool = True) -> list[list[str]]:
    """``[item, value]`` rows: instrument, site, procedure, operator, dates, version, data hash.

    Parameters
    ----------
    doc : mapping
        A result envelope, with or without its ``test`` block.
    with_item : bool
        Also the laboratory, the customer and the item (:func:`laboratory_rows`,
        :func:`item_rows`); False where the page states them once for a series.
    """
    rows: list[list[str]] = []
    inst = doc.get("instrument") or {}
    if inst:
        rows.append(["instrument", str(inst.get("kind") or "-")])
        rows.append(["serial", str(inst.get("serial") or "-")])
    site = doc.get("site") or {}
    if site.get("latitude_deg") is not None:
        rows.append(["site latitude", f"{float(site['latitude_deg']):.6f} deg"])
    if site.get("gravity_m_s2") is not None:
        rows.append(["site gravity", f"{float(site['gravity_m_s2']):.7f} m/s^2"])
    rows.append(["test", str(doc.get("kind") or "-")])
    test = doc.get("test") or {}
    if test:
        if test.get("certificate"):
            rows.append(["certificate", str(test["certificate"])])
        if with_item:
            rows += laboratory_rows(test.get("laboratory"))
            rows += item_rows(test)
        rows.append(["operator", str(test.get("operator") or "not stated")])
        rows.append(["test date", test_date_text(test)])
        if test.get("filed_at"):
            rows.append(["filed at (UTC)", _utc_text(str(test["filed_at"]))])
        for name, e in (test.get("environment") or {}).items():
            rows.append([_ENV_LABELS.get(name, name),
                         f"{float(e['value']):g} {e['unit']}"])
        if not test.get("environment"):
            rows.append(["environment", "not stated"])
        rows.append(["software", f"inertest {test.get('software_version') or '-'}"])
        if test.get("data_sha256"):
            rows.append(["data SHA-256", str(test["data_sha256"])])
        if test.get("notes"):
            rows.append(["notes", str(test["notes"])])
    return rows


#: Where the test date comes from (the envelope's ``test.date_source``), as printed.
_DATE_SOURCES = {
    "plan": "from the plan's [test] date",
    "--tested-at": "from --tested-at",
    "analysis": "the time of the analysis: the plan gives no [test] date",
}


def _utc_text(iso: str) -> str:
    """``2026-11-20T09:30:00+00:00`` as ``2026-11-20 09:30:00``."""
    return iso.replace("T", " ")[:19]


def test_date_text(test: Mapping[str, Any]) -> str:
    """The one test date as printed, with where it comes from.

    ``2026-11-20 (from the plan's [test] date)``, ``2026-01-05 14:00 UTC (from
    --tested-at)``.
    """
    when = test.get("tested_at")
    text = (f"{_utc_text(str(when))[:16]} UTC" if when and not str(when)[11:19] == "00:00:00"
            else str(test.get("date") or "-"))
    source = _DATE_SOURCES.get(str(test.get("date_source")), "")
    return f"{text} ({source})" if source else text


def approval_of(doc: Mapping[str, Any]) -> Approval:
    """The signature block of an envelope: its ``test.approval`` (blank where not given)."""
    a = (doc.get("test") or {}).get("approval") or {}
    return Approval(**{k: str(a.get(k) or "") for k in (
        "performed_by", "performed_on", "reviewed_by", "reviewed_on", "approved_by",
        "approved_on")})


EQUIPMENT_HEADER = ["id", "equipment", "model", "serial", "certificate", "calibrated",
                    "calibration due", "status on the test date"]


def equipment_rows(doc: Mapping[str, Any]) -> list[list[str]]:
    """One row per item of equipment in the envelope's ``test`` block (:data:`EQUIPMENT_HEADER`)."""
    test = doc.get("test") or {}
    rows = []
    for e in test.get("equipment") or []:
        overdue = e.get("calibration_overdue")
        status = ("OVERDUE" if overdue else "valid" if overdue is False
                  else "unknown (no lab file given)")
        rows.append([str(e.get("id", "")), str(e.get("name") or "-"), str(e.get("model") or "-"),
                     str(e.get("serial") or "-"), str(e.get("certificate") or "-"),
                     str(e.get("calibrated") or "-"), str(e.get("calibration_due") or "-"),
                     status])
    return rows


def equipment_warnings(doc: Mapping[str, Any]) -> list[str]:
    """One sentence per item whose calibration was overdue on the test date."""
    test = doc.get("test") or {}
    return [f"Calibration of {e.get('id')} ({e.get('name') or 'equipment'}) was due "
            f"{e.get('calibration_due')}, before the test date {test.get('date')}: the "
            "results are not traceable to it until it is recalibrated."
            for e in test.get("equipment") or [] if e.get("calibration_overdue")]


def no_equipment_note(doc: Mapping[str, Any]) -> str | None:
    """A note when the test names no equipment (the plan has no ``[test] equipment``)."""
    test = doc.get("test")
    if test is None:
        return ("The plan has no [test] table: operator, equipment and environment are not "
                "stated.")
    if not test.get("equipment"):
        return "The plan's [test] table names no equipment."
    return None


def identity_section(title: str, doc: Mapping[str, Any], *,
                     extra_rows: Sequence[Sequence[object]] = (),
                     software_version: str | None = None, with_item: bool = True) -> Section:
    """The report section stating the identity: identity table, equipment table, warnings.

    With ``with_item`` (:func:`identity_rows`), a warning first when the data are simulated.
    """
    rows: list[list[object]] = [list(r) for r in identity_rows(doc, with_item=with_item)]
    have = {str(r[0]) for r in rows}
    rows += [list(r) for r in extra_rows if str(r[0]) not in have]
    if software_version is not None and "software" not in have:
        rows.append(["software", f"inertest {software_version}"])
    sec = Section(title, [table_html(["item", "value"], rows, left_columns=2,
                                     caption="Identity of the test")])
    if with_item and simulated(doc.get("test")):
        sec.parts.insert(0, warning(SIMULATED_NOTE))
    eq = equipment_rows(doc)
    if eq:
        sec.parts.append(table_html(EQUIPMENT_HEADER, eq, left_columns=len(EQUIPMENT_HEADER),
                                    caption="Test equipment and its calibration status"))
    for w in equipment_warnings(doc):
        sec.parts.append(paragraph("Warning: " + w, note=True))
    note = no_equipment_note(doc)
    if note:
        sec.parts.append(paragraph(note))
    return sec
