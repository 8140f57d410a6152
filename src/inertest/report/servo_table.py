"""Figures and report sections of the servo-table (long-term) drift test."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np

from inertest.procedures.servo_table import ServoTableResult
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import fmt, identification_section
from inertest.report.rounding import format_number


def servo_table_figure(result: ServoTableResult):
    """Per mounting: drift against table angle with the fitted curve, and the stability series.

    Top row: block drift from the encoder angle and the fitted B0..C2 curve; bottom row: the
    drift-stability series with the harmonic model removed.
    """
    ms = list(result.curves)
    fig, axes = plt.subplots(2, len(ms), figsize=(3.8 * len(ms), 5.6), squeeze=False)
    grid = np.linspace(0.0, 360.0, 361)
    for j, m in enumerate(ms):
        c = result.curves[m]
        ax, axs = axes[0, j], axes[1, j]
        ax.plot(c.angle_deg, c.drift_deg_h, ".", ms=3, label="from encoder angle")
        terms = np.array([t.value for t in result.harmonics[m]])
        g = np.radians(grid)
        curve = (terms[0] + terms[1] * np.sin(g) + terms[2] * np.cos(g)
                 + terms[3] * np.sin(2 * g) + terms[4] * np.cos(2 * g))
        ax.plot(grid, curve, "-", label="fitted B0..C2")
        ax.set_title(m)
        ax.set_xlabel("table angle θ [deg]")
        ax.grid(alpha=0.3)
        if m in result.stability:
            s = result.stability[m]
            axs.plot(s.time_h, s.drift_deg_h, "o-", ms=3)
        axs.axhline(0, color="k", lw=0.6)
        axs.set_xlabel("time since mounting start [h]")
        axs.grid(alpha=0.3)
        if j == 0:
            ax.set_ylabel("drift [deg/h]")
            axs.set_ylabel("drift − model [deg/h]")
            ax.legend(fontsize=8)
    finish_figure(fig)
    return fig


def servo_table_sections(
    result: ServoTableResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Report sections of a servo-table test: estimates, harmonics, drift stability, figure."""
    sec = identification_section(f"{title}: angle-series least squares", result.identification,
                                 truth)
    sec.parts.append(paragraph(
        f"Table axis: {result.table_axis}; Earth rate along it "
        f"{format_number(result.earth_rate_along_axis_deg_h)} deg/h. The encoder angle series "
        "is fitted with integrated regressors, so the stds are honest for white encoder noise."))
    harm = Section(f"{title}: drift against table angle and long-term stability", [])
    rows = [[m] + [fmt(t.value, t.std) for t in terms] for m, terms in result.harmonics.items()]
    if rows:
        names = [t.name for t in next(iter(result.harmonics.values()))]
        harm.parts.append(paragraph("Harmonic terms of the fitted drift [deg/h]:"))
        harm.parts.append(table_html(["mounting", *names], rows))
    srows = []
    for m, s in result.stability.items():
        allan = ", ".join(f"{format_number(float(d))} @ {format_number(float(t))} h"
                          for t, d in zip(s.allan_tau_h, s.allan_dev_deg_h, strict=True))
        trend = "—" if s.trend is None else f"{fmt(s.trend.value, s.trend.std)} deg/h/h"
        srows.append([m, f"{format_number(s.interval_h)} h", str(s.drift_deg_h.size),
                      f"{format_number(s.std_deg_h)} deg/h", trend, allan or "—"])
    if srows:
        harm.parts.append(paragraph(
            "Long-term drift stability (IEEE Std 517): drift per interval after the harmonic "
            "model is removed, its standard deviation, trend and overlapping Allan deviation:"))
        harm.parts.append(table_html(
            ["mounting", "interval", "n", "std", "trend", "Allan deviation [deg/h]"], srows))
    if result.curves:
        harm.parts.append(figure_html(servo_table_figure(result),
                                      "Drift against table angle and drift-stability series"))
    for msg in result.messages:
        harm.parts.append(paragraph("Warning: " + msg, note=True))
    return [sec, harm]
