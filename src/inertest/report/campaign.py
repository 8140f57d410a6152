"""The campaign report a lab files: one self-contained HTML page per fit.

Instrument, site, plan, data summary, what the test determined with uncertainties and units,
what it could not determine and why, residual plots, and the instrument's coefficient history
when the database holds earlier runs. Figures are embedded; the page works offline and prints.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from typing import Any

from inertest.estimation.trend import QuantityHistory
from inertest.quality.conformance import Spec
from inertest.quality.lab import TestTime
from inertest.report.certificate import RESULTS_STATEMENT
from inertest.report.conformance import conformance_sections
from inertest.report.history import history_sections, spec_limits
from inertest.report.html import (
    Section,
    page,
    paragraph,
    preformatted,
    table_html,
    warning,
)
from inertest.report.identification import misfit_notes, noise_model_text
from inertest.report.identity import approval_of, identity_section
from inertest.report.sections import result_sections
from inertest.results import Identification


def campaign_page(
    result: Any,
    *,
    instrument: Mapping[str, object],
    site: Mapping[str, object],
    plan_text: str,
    data: Mapping[str, object],
    tested: TestTime,
    software_version: str,
    history: Sequence[tuple[QuantityHistory, Sequence[datetime]]] = (),
    truth: Mapping[str, float] | None = None,
    test: Mapping[str, Any] | None = None,
    uncertainty_budget: Mapping[str, Any] | None = None,
    conformance: Mapping[str, Any] | None = None,
    report_id: str = "",
    spec: Spec | None = None,
    sources: Sequence[Sequence[str]] = (),
) -> str:
    """The complete HTML report of one fit.

    Parameters
    ----------
    result : procedure result
        From ``inertest.fit``.
    instrument, site : mapping
        Display fields (serial, kind, output unit, ...; latitude, gravity).
    plan_text : str
        The plan file as written.
    data : mapping
        Data summary: ``file``, ``rows``, ``columns``, ``sha256``.
    tested : TestTime
        The one test date (:func:`inertest.quality.lab.test_time`).
    history : sequence of (QuantityHistory, times)
        The instrument's stored history including this run (figures shown from two runs on).
    test : mapping, optional
        The envelope's ``test`` block (:func:`inertest.quality.lab.identity_block`): operator, date,
        equipment and its calibration status, environment.
    uncertainty_budget, conformance : mapping, optional
        The envelope's blocks of the same names: a verdict table and a budget table
        (:func:`inertest.report.conformance.conformance_sections`) after the result.
    report_id : str
        Certificate number or run id, printed on every page.
    spec : Spec, optional
        The specification: its limits are drawn in the history.
    sources : sequence of [item, value]
        Identity rows that reproduce the report: input paths and SHA-256, the command.
    """
    serial = str(instrument.get("serial") or "unnamed instrument")
    doc = result.to_dict()
    if test is not None:
        doc = {**doc, "test": dict(test)}
    rows = [[k, v] for k, v in instrument.items() if k not in ("serial", "kind")]
    head = identity_section("Instrument, site and test", doc, extra_rows=[
        ["report id", report_id], *rows, ["procedure", result.procedure], *sources],
        software_version=software_version)
    plan = Section("Plan", [preformatted(plan_text)])
    data_sec = Section("Data", [table_html(["item", "value"], [[k, v] for k, v in data.items()])])
    found = result_sections(result, truth, title="Result")
    if found:
        found[0].parts[:0] = _result_notes(result, doc, found[0])
    sections = [head, plan, data_sec, *found,
                *conformance_sections({"uncertainty_budget": uncertainty_budget,
                                       "conformance": conformance})]
    shown = [(h, t) for h, t in history if h.values.size >= 2]
    if shown:
        sections += history_sections([h for h, _ in shown], [t for _, t in shown],
                                     serial=serial, limits=spec_limits(spec))
    elif history:
        sections.append(Section(f"History of {serial}", [paragraph(
            "This is the first stored run of this instrument: repeatability and trends need at "
            "least two runs.")]))
    return page(f"inertest report: {result.procedure}, {serial}", sections, identity=None,
                subtitle=f"Tested {tested.text}; report {report_id}, generated "
                         f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC by inertest "
                         f"{software_version}.", report_id=report_id or None, serial=serial,
                approval=approval_of(doc), statement=RESULTS_STATEMENT)


def _result_notes(result: Any, doc: Mapping[str, Any], first: Section) -> list[str]:
    """Top of the result: a warning per model that does not fit, and the noise model used."""
    out = [warning("Warning: " + m) for m in misfit_notes(doc)]
    ident = getattr(result, "identification", None)
    if isinstance(ident, Identification):
        text = noise_model_text(ident)
        if not any(html.escape(text[1:]) in p for p in first.parts):  # not shown already
            out.append(paragraph(f"{text[0].upper()}{text[1:]}."))
    return out
