"""The lot report: many units of one type, quantity by quantity, against the specification.

From :class:`inertest.quality.lot.LotStatistics`: a summary table (units, mean, observed spread,
the measurement's share, the unit-to-unit spread with the measurement removed, the units that
stand out), a capability table per limit (Cp and Cpk with their 95 % intervals, units outside),
and a figure per quantity: each unit's value with its expanded uncertainty (2 std) against the
limits. One self-contained page in the layout of every inertest report.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from inertest.report.html import Section, figure_html, page, paragraph, table_html
from inertest.report.rounding import format_number

#: Most quantities drawn as figures (the tables hold them all).
MAX_FIGURES = 16


def _num(x: float | None, digits: int = 3) -> str:
    return "-" if x is None else format_number(float(x), digits=digits)


def _pair(p: Sequence[float] | None, digits: int = 3) -> str:
    return "-" if p is None else f"{_num(p[0], digits)} to {_num(p[1], digits)}"


def summary_rows(stats: Any) -> list[list[str]]:
    """One row per quantity: procedure, quantity, unit, n, mean, spreads, units that stand out."""
    rows = []
    for q in stats.quantities:
        rows.append([q.procedure, q.quantity, q.unit, str(q.n), _num(q.mean, 4),
                     _num(q.observed_std), _num(q.measurement_rms),
                     f"{_num(q.unit_to_unit)} ({_pair(q.unit_to_unit_interval)})",
                     ", ".join(f"{s.serial} (t = {s.t:.1f})" for s in q.stand_out) or "none"])
    return rows


SUMMARY_HEADER = ["procedure", "quantity", "unit", "units", "mean", "observed std",
                  "measurement std (RMS)", "unit-to-unit std (95 %)", "stand out"]
CAPABILITY_HEADER = ["quantity", "clause", "limit", "Cp (95 %)", "Cpk (95 %)",
                     "Cpk, measurement removed (lower 95 % bound)", "units outside"]


def capability_rows(stats: Any) -> list[list[str]]:
    """One row per (quantity, limit)."""
    rows = []
    for q in stats.quantities:
        for c in q.capability:
            rows.append([f"{q.procedure}: {q.quantity}", c.clause_id, c.limit,
                         f"{_num(c.cp)} ({_pair(c.cp_interval)})",
                         f"{_num(c.cpk)} ({_pair(c.cpk_interval)})",
                         f"{_num(c.cpk_process)} (>= {_num(c.cpk_process_lower)})"
                         if c.cpk_process is not None else _num(None),
                         f"{c.outside} of {q.n}"])
    return rows


def lot_page(stats: Any, *, title: str, identity: Sequence[Sequence[object]] = ()) -> str:
    """The lot report as one HTML page."""
    sections = [Section("Lot summary", [
        table_html(SUMMARY_HEADER, summary_rows(stats), left_columns=3,
                   caption=f"{len(stats.serials)} units; values in each quantity's unit"),
        paragraph(
            "The observed std is the scatter of the units' values and includes each unit's "
            "measurement noise (its RMS is the next column); the unit-to-unit std has that "
            "measurement part removed (random effects, REML; 95 % interval). A unit stands "
            f"out when its leave-one-out t exceeds the Bonferroni bound at "
            f"{100 * stats.level:g} % for the lot.", note=True),
        *(paragraph(n) for n in stats.notes)])]
    caps = capability_rows(stats)
    if caps:
        sections.append(Section("Process capability against the specification", [
            table_html(CAPABILITY_HEADER, caps, left_columns=3,
                       caption=f"Against {stats.spec_name}"),
            paragraph("Cp = (USL - LSL) / 6s and Cpk = min(USL - mean, mean - LSL) / 3s with the "
                      "observed s (ISO 22514-2); intervals: chi-squared for Cp, Bissell (1990) "
                      "for Cpk; the last Cpk uses the unit-to-unit std instead (the process "
                      "without the measurement).", note=True)]))
    figs = [q for q in stats.quantities if q.n >= 2][:MAX_FIGURES]
    if figs:
        sections.append(Section("Units against the limits", [
            figure_html(_figure(q), f"{q.procedure}: {q.quantity} [{q.unit}] per unit, "
                                    "± 2 std; dashed: the limits") for q in figs]))
    return page(title, sections, identity=[["units", str(len(stats.serials))],
                                           *identity])


def _figure(q: Any) -> Any:
    import matplotlib.pyplot as plt

    from inertest.report.figure_text import finish_figure

    fig, ax = plt.subplots(figsize=(7.0, 2.6))
    xs = range(q.n)
    ax.errorbar(list(xs), [v.value for v in q.values], yerr=[2 * v.std for v in q.values],
                fmt="o", ms=3, capsize=2)
    out = {s.serial for s in q.stand_out}
    for i, v in enumerate(q.values):
        if v.serial in out:
            ax.plot([i], [v.value], "rs", ms=7, mfc="none")
    for c in q.capability:
        for b in (c.lower, c.upper):
            if b is not None:
                ax.axhline(b, ls="--", color="0.4", lw=1)
    ax.axhline(q.mean, color="C2", lw=1)
    ax.set_xticks(list(xs), [v.serial for v in q.values], rotation=60, fontsize=6)
    ax.set_ylabel(f"{q.quantity} [{q.unit}]")
    finish_figure(fig)
    return fig
