"""Verdicts against a specification and the uncertainty budget, as tables (report and terminal).

Built from the envelope's ``conformance`` block
(:meth:`inertest.quality.conformance.Conformance.to_dict`) and ``uncertainty_budget`` block
(:meth:`inertest.quality.budget.UncertaintyBudget.to_dict`),
so the terminal, the JSON and the HTML report say the same. Values and uncertainties are rounded
by :func:`~inertest.report.rounding.round_to_uncertainty` (JCGM 100:2008, GUM 7.2.6); a Type-B
contribution is printed to two significant digits in the quantity's unit.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from inertest.errors import UnitError
from inertest.report.html import Section, paragraph, table_html
from inertest.report.rounding import format_number, round_to_uncertainty
from inertest.units import convert

#: A Type-B contribution below this fraction of the combined standard uncertainty is printed
#: as ``< (fraction x u_c)``: it changes u_c by less than fraction^2 / 2 (0.005 %), which the
#: two significant digits of u_c (GUM 7.2.6) cannot show. The JSON keeps its value.
NEGLIGIBLE_FRACTION = 0.01

#: Header of the verdict table.
VERDICT_HEADER = ["quantity", "value ± U (k)", "limit", "clause", "verdict"]


def _pm(value: float, expanded: float | None, unit: str) -> tuple[str, bool]:
    """``"v ± U unit"`` rounded (GUM 7.2.6), ``"v unit"`` without U; and whether U is shown."""
    v, u = round_to_uncertainty(value, expanded)
    return (f"{v} ± {u} {unit}", True) if u and u != "0" else (f"{v} {unit}", False)


def value_pm(value: float | None, expanded: float | None, unit: str, k: float | None, *,
             limit_unit: str = "", k_without_u: bool = True) -> str:
    """A measured value as printed: ``value ± U unit (k = ...)``, in the limit's unit too.

    When the limit is written in another unit than the result (a warm-up time in s against
    ``<= 20 min``), the value and U are shown in the limit's unit first, then as the result
    gives them: ``17.17 ± 0.90 min = 1030 ± 54 s (k = 2.01)``. The JSON keeps the result's
    value and unit.

    Parameters
    ----------
    value, expanded : float or None
        Value and expanded uncertainty U in ``unit``; ``value`` None: not determined (``-``).
    unit : str
        The result's unit.
    k : float or None
        The coverage factor of U.
    limit_unit : str
        The unit of the limit ("" or ``unit``: shown in ``unit`` alone).
    k_without_u : bool
        Whether k is printed when U rounds to nothing.
    """
    if value is None:   # not determined by the test
        return "-"
    big_u = None if expanded is None else float(expanded)
    text, with_u = _pm(float(value), big_u, unit)
    if limit_unit and limit_unit != unit:
        try:
            in_limit, _ = _pm(convert(float(value), unit, limit_unit),
                              None if big_u is None else convert(big_u, unit, limit_unit),
                              limit_unit)
        except UnitError:   # a limit that cannot express the result is refused earlier
            pass
        else:
            text = f"{in_limit} = {text}"
    kk = "" if k is None or not (with_u or k_without_u) else f" (k = {float(k):.2f})"
    return text + kk


def verdict_rows(conformance: Mapping[str, Any]) -> list[list[str]]:
    """``[quantity, value ± U (k), limit, clause, verdict]`` per limited quantity.

    The value is shown in the limit's unit too where the two differ (:func:`value_pm`).
    """
    rows = []
    for v in conformance.get("verdicts") or []:
        rows.append([str(v["quantity"]),
                     value_pm(v["value"], v["expanded_uncertainty"], str(v["unit"]),
                              v.get("coverage_factor"), limit_unit=str(v.get("limit_unit") or "")),
                     str(v["limit"]), str(v["clause"]), str(v["verdict"])])
    return rows


def verdict_notes(conformance: Mapping[str, Any]) -> list[str]:
    """The note of each verdict that has one (why a quantity is not determined)."""
    return [f"{v['verdict']}: {v['note']}" for v in conformance.get("verdicts") or []
            if v.get("note")]


def budget_table(budget: Mapping[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Header and rows of one result's budget: Type A, each Type B, combined, k, U per quantity.

    Each Type-B column holds the source's signed contribution ``c_i u_i`` (GUM 5.1.3) in the
    quantity's unit; the source's own standard uncertainty is in the column header.
    """
    quantities: Mapping[str, Any] = budget.get("quantities") or {}
    sources: list[tuple[str, str]] = []
    for q in quantities.values():
        for c in q.get("type_b") or []:
            label = f"{c['source']} (u = {float(c['u']):g} {c['u_unit']})"
            if (c["source"], label) not in sources:
                sources.append((c["source"], label))
    header = ["quantity", "unit", "value", "Type A std (dof)",
              *(f"Type B: {lab}" for _, lab in sources),
              "combined std", "k", "U (expanded)"]
    rows = []
    for name, q in quantities.items():
        unit = str(q["unit"])
        uc, big_u = float(q["combined_std"]), float(q["expanded"])
        value, _ = round_to_uncertainty(float(q["value"]), uc)
        ta = q.get("type_a") or {}
        contrib = {c["source"]: float(c["contribution"]) for c in q.get("type_b") or []}
        rows.append([
            name, unit, value,
            f"{format_number(float(ta.get('std', 0.0)), digits=2)} ({_dof(ta)})",
            *(contribution_text(contrib[s], uc) if s in contrib else "-" for s, _ in sources),
            round_to_uncertainty(uc, uc)[1],
            f"{float(q['coverage_factor']):.2f}",
            round_to_uncertainty(big_u, big_u)[1],
        ])
    return header, rows


def contribution_text(c: float, combined: float) -> str:
    """A signed contribution ``c_i u_i`` as printed: two significant digits, or ``< bound``.

    Below :data:`NEGLIGIBLE_FRACTION` of the combined standard uncertainty it is printed as
    ``< 2e-05`` (that fraction of u_c, one digit): a 1.6e-11 deg/h/g^2 contribution next to a
    0.0042 deg/h/g^2 u_c is round-off of the budget's simulation, not data.
    """
    bound = NEGLIGIBLE_FRACTION * combined
    if bound > 0 and abs(c) < bound:
        return f"< {format_number(bound, digits=1)}"
    return format_number(c, digits=2)


def _negligible(budget: Mapping[str, Any]) -> bool:
    """Whether any contribution is printed as ``< bound`` (:func:`contribution_text`)."""
    return any(contribution_text(float(c["contribution"]), float(q["combined_std"]))
               .startswith("<")
               for q in (budget.get("quantities") or {}).values() for c in q.get("type_b") or [])


def _dof(type_a: Mapping[str, Any]) -> str:
    """Type-A degrees of freedom as printed: ``None`` in the JSON is a known std, infinite."""
    if "dof" not in type_a:
        return "-"
    return "∞" if type_a["dof"] is None else str(type_a["dof"])


def budget_notes(budget: Mapping[str, Any]) -> list[str]:
    """The budget's assumptions and the lab-file entries that do not apply, as sentences."""
    notes = [f"Assumption: {a}." for a in budget.get("assumptions") or []]
    notes += [f"Not applied: {n}." for n in budget.get("not_applicable") or []]
    if _negligible(budget):
        notes.append(f"A Type-B contribution below {100 * NEGLIGIBLE_FRACTION:g} % of the "
                     "combined standard uncertainty is shown as < (that bound): it changes the "
                     f"combined standard uncertainty by less than "
                     f"{100 * NEGLIGIBLE_FRACTION**2 / 2:g} % (JCGM 100:2008, 7.2.6: u to two "
                     "significant digits); the JSON keeps its value.")
    p = budget.get("coverage_probability")
    if p is not None:
        notes.append(f"U = k × combined std, k = t-factor for a coverage probability of "
                     f"{100 * float(p):.2f} % with the Welch-Satterthwaite effective degrees of "
                     "freedom (JCGM 100:2008, GUM G.4.1, G.6.6).")
    return notes


def conformance_sections(
    doc: Mapping[str, Any], *, title: str = "Conformance and uncertainty budget"
) -> list[Section]:
    """The verdict table and the budget table of an envelope (none when it has neither block)."""
    budget = doc.get("uncertainty_budget")
    conf = doc.get("conformance")
    if not budget and not conf:
        return []
    sec = Section(title, [])
    if conf:
        sec.parts.append(table_html(
            VERDICT_HEADER, verdict_rows(conf), left_columns=1,
            caption=f"Verdicts against {conf.get('spec', 'the specification')} "
                    f"(overall: {conf.get('overall', '-')})"))
        for n in verdict_notes(conf):
            sec.parts.append(paragraph(n, note=True))
        sec.parts.append(paragraph(f"Decision rule: {conf.get('rule', '')}.", note=True))
    if budget:
        header, rows = budget_table(budget)
        sec.parts.append(table_html(header, rows, left_columns=2,
                                    caption="Uncertainty budget (Type A, Type B, combined, "
                                            "expanded U), each in the quantity's unit"))
        for n in budget_notes(budget):
            sec.parts.append(paragraph(n, note=True))
    return [sec]


__all__ = ["NEGLIGIBLE_FRACTION", "VERDICT_HEADER", "budget_notes", "budget_table",
           "conformance_sections", "contribution_text", "value_pm", "verdict_notes",
           "verdict_rows"]
