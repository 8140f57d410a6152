"""Figures of an instrument's coefficient history."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime

import matplotlib.dates as mdates
import matplotlib.pyplot as plt
import numpy as np

from inertest.estimation.trend import QuantityHistory
from inertest.report.figure_text import finish_figure
from inertest.report.identification import fmt
from inertest.report.rounding import format_number


def history_rows(
    histories: Sequence[QuantityHistory],
) -> tuple[list[str], list[list[object]]]:
    """Header and rows of the history table.

    Per quantity: the mean weighted by the run stds (± its std), the weighted repeatability,
    the chi-square test of the run-to-run scatter against the run stds (chi2/dof, p and
    verdict), the GLS trend per 30 days (± its std, with the Birge-ratio inflation named when
    the scatter about the trend exceeds the run stds) and the flagged runs.
    """
    k = histories[0].k if histories else 3.0
    header = ["quantity", "unit", "runs", "mean (weighted by run std)", "repeatability (1σ)",
              "scatter vs run stds: χ²/dof (p)", "trend per 30 days", f"runs beyond {k:g}σ"]
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
            trend = "-"
        else:
            trend = fmt(h.trend_per_day * 30.0, (h.trend_std_per_day or 0.0) * 30.0)
            if h.trend_inflation != 1.0:
                trend += f" (std ×{format_number(h.trend_inflation)}, Birge ratio)"
        flags = ", ".join(str(i + 1) for i in range(h.values.size) if h.flagged[i]) or "-"
        rows.append([h.name, h.unit, h.values.size, mean, rep, scatter, trend, flags])
    return header, rows


def history_figure(histories: Sequence[QuantityHistory], times: Sequence[Sequence[datetime]]):
    """One panel per quantity: value ± 1 sigma per run, weighted mean, ± k * repeatability band."""
    n = len(histories)
    cols = 2 if n > 1 else 1
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(6.2 * cols, 2.6 * rows), squeeze=False)
    for ax, h, ts in zip(axes.flat, histories, times, strict=False):
        ax.errorbar(ts, h.values, yerr=h.stds, fmt="o", ms=4, capsize=3, label="run ± 1σ")
        ax.axhline(h.mean, color="k", lw=0.8, label="weighted mean")
        if h.repeatability is not None:
            ax.axhspan(h.mean - h.k * h.repeatability, h.mean + h.k * h.repeatability,
                       color="0.85", zorder=0, label=f"±{h.k:g}× repeatability")
        bad = np.flatnonzero(h.flagged)
        if bad.size:
            ax.plot([ts[i] for i in bad], h.values[bad], "rx", ms=10, mew=2, label="flagged")
        ax.set_title(f"{h.name} [{h.unit}]", fontsize=9)
        ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
        ax.tick_params(axis="x", labelsize=7, rotation=30)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=7)
    finish_figure(fig)
    return fig
