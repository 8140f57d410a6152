"""Figures and tables of an instrument's coefficient history (a drift review).

Each quantity's panel shows the runs (± 1 std), the weighted mean with its ±k repeatability
band, the trend line with its ±2 std band (:meth:`inertest.estimation.trend.QuantityHistory.
trend_line`) and the specification's limits when a specification is given; the figure's title
names the serial and the date range. The table says the same in numbers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from datetime import datetime, timedelta

import matplotlib.dates as mdates
import matplotlib.pyplot as plt
import numpy as np

from inertest.estimation.trend import QuantityHistory
from inertest.quality.conformance import Limit, Spec
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import fmt
from inertest.report.rounding import format_number
from inertest.units import convert

#: Half-width of the trend line's band, in its standard uncertainties.
TREND_BAND_STDS = 2.0


def date_range_text(times: Sequence[datetime]) -> str:
    """``2026-01-01 to 2026-03-01`` (the test dates of the first and last run)."""
    if not times:
        return "no runs"
    first, last = min(times), max(times)
    return (f"{first:%Y-%m-%d}" if first.date() == last.date()
            else f"{first:%Y-%m-%d} to {last:%Y-%m-%d}")


def limit_lines(limit: Limit | None, unit: str) -> list[float]:
    """The values of a specification limit, converted to the quantity's ``unit``."""
    if limit is None:
        return []
    out = []
    if limit.max_abs is not None:
        v = convert(limit.max_abs, limit.unit, unit)
        out += [v, -v]
    out += [convert(x, limit.unit, unit) for x in (limit.minimum, limit.maximum)
            if x is not None]
    return out


def history_rows(
    histories: Sequence[QuantityHistory], *, limits: Mapping[str, Limit] | None = None,
) -> tuple[list[str], list[list[object]]]:
    """Header and rows of the history table.

    Per quantity: the mean weighted by the run stds (± its std), the weighted repeatability,
    the chi-square test of the run-to-run scatter against the run stds (chi2/dof, p and
    verdict), the GLS trend per 30 days (± its std, with the Birge-ratio inflation named when
    the scatter about the trend exceeds the run stds), the trend line at the last run (± its
    std), the flagged runs and, with a specification, its limit.
    """
    k = histories[0].k if histories else 3.0
    header = ["quantity", "unit", "runs", "mean (weighted by run std)", "repeatability (1σ)",
              "scatter vs run stds: χ²/dof (p)", "trend per 30 days", "trend at the last run",
              f"runs beyond {k:g}σ"] + (["spec limit"] if limits else [])
    rows: list[list[object]] = []
    for h in histories:
        rep = "-" if h.repeatability is None else format_number(h.repeatability, digits=2)
        mean = fmt(h.mean, h.mean_std)
        if not h.weighted:
            mean += " (unweighted: a run has no std)"
        if h.scatter is None:
            scatter = "-"
        else:
            sc = h.scatter
            scatter = (f"{format_number(sc.chi2)}/{sc.dof} (p = {format_number(sc.p, digits=2)}): "
                       + ("consistent" if sc.consistent else "exceeds run stds"))
        if h.trend_per_day is None:
            trend = at_last = "-"
        else:
            trend = fmt(h.trend_per_day * 30.0, (h.trend_std_per_day or 0.0) * 30.0)
            if h.trend_inflation != 1.0:
                trend += f" (std ×{format_number(h.trend_inflation)}, Birge ratio)"
            line, std = h.trend_line([float(h.t_days[-1])])
            at_last = fmt(float(line[0]), float(std[0]))
        flags = ", ".join(str(i + 1) for i in range(h.values.size) if h.flagged[i]) or "-"
        row: list[object] = [h.name, h.unit, h.values.size, mean, rep, scatter, trend, at_last,
                             flags]
        if limits:
            lim = limits.get(h.name)
            row.append("-" if lim is None else lim.text())
        rows.append(row)
    return header, rows


def history_figure(histories: Sequence[QuantityHistory], times: Sequence[Sequence[datetime]], *,
                   serial: str = "", limits: Mapping[str, Limit] | None = None):
    """One panel per quantity: runs ± 1 std, mean and repeatability band, trend, spec limits.

    Parameters
    ----------
    histories, times
        Per quantity its summary and the test dates of its runs.
    serial : str
        The instrument, named in the title with the runs' date range.
    limits : mapping, optional
        ``{quantity: Limit}`` of a specification: its limits are drawn in the quantity's unit.
    """
    n = len(histories)
    cols = 2 if n > 1 else 1
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(6.2 * cols, 2.8 * rows + 0.5), squeeze=False)
    all_times = [t for ts in times for t in ts]
    for ax, h, ts in zip(axes.flat, histories, times, strict=False):
        ax.errorbar(ts, h.values, yerr=h.stds, fmt="o", ms=4, capsize=3, label="run ± 1σ")
        ax.axhline(h.mean, color="k", lw=0.8, label="weighted mean")
        if h.repeatability is not None:
            ax.axhspan(h.mean - h.k * h.repeatability, h.mean + h.k * h.repeatability,
                       color="0.88", zorder=0, label=f"±{h.k:g}× repeatability")
        if h.trend_per_day is not None and ts:
            span = max((ts[-1] - ts[0]).total_seconds() / 86400.0, 1.0)
            t_days = np.linspace(float(h.t_days[0]), float(h.t_days[-1]) + 0.15 * span, 50)
            line, std = h.trend_line(t_days)
            when = [ts[0] + timedelta(days=float(d - h.t_days[0])) for d in t_days]
            ax.plot(when, line, color="C3", lw=1.2, label="trend")
            ax.fill_between(when, line - TREND_BAND_STDS * std, line + TREND_BAND_STDS * std,
                            color="C3", alpha=0.15, lw=0,
                            label=f"trend ± {TREND_BAND_STDS:g} std")
        for value in limit_lines((limits or {}).get(h.name), h.unit):
            ax.axhline(value, color="C1", lw=1.3, ls="--", label="spec limit")
        bad = np.flatnonzero(h.flagged)
        if bad.size:
            ax.plot([ts[int(i)] for i in bad], h.values[bad], "rx", ms=10, mew=2, label="flagged")
        ax.set_title(f"{h.name} [{h.unit}]", fontsize=9)
        ax.set_ylabel(f"{h.name} [{h.unit}]", fontsize=8)
        ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
        ax.tick_params(axis="x", labelsize=7, rotation=30)
        ax.grid(alpha=0.3)
        handles, labels = ax.get_legend_handles_labels()
        seen = dict(zip(labels, handles, strict=False))  # one entry per label
        ax.legend(seen.values(), seen.keys(), fontsize=6)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.suptitle(f"History of {serial or 'the instrument'}: {len(set(all_times))} runs, "
                 f"{date_range_text(all_times)} (test dates)", fontsize=10)
    finish_figure(fig)
    return fig


def spec_limits(spec: Spec | None) -> dict[str, Limit]:
    """``{quantity: Limit}`` of a specification (empty without one)."""
    return {} if spec is None else {lim.quantity: lim for lim in spec.limits}


def history_sections(
    histories: Sequence[QuantityHistory], times: Sequence[Sequence[datetime]], *, serial: str,
    limits: Mapping[str, Limit] | None = None, title: str | None = None,
) -> list[Section]:
    """The drift review of ``serial``: table and figure, both with serial and date range."""
    all_times = [t for ts in times for t in ts]
    span = date_range_text(all_times)
    head, rows = history_rows(histories, limits=limits)
    sec = Section(title or f"History of {serial}", [
        table_html(head, rows, caption=f"{serial}: {len(set(all_times))} runs, {span} "
                                       "(test dates)"),
        figure_html(history_figure(histories, times, serial=serial, limits=limits),
                    f"Each quantity of {serial} over its runs ({span}): runs ± 1σ, weighted "
                    f"mean, repeatability band, trend ± {TREND_BAND_STDS:g} std"
                    + (", specification limits" if limits else ""))])
    notes = [m for h in histories for m in h.messages]
    for m in dict.fromkeys(notes):
        sec.parts.append(paragraph(m, note=True))
    return [sec]
