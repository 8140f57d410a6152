"""Figures and report sections of the 1 g tumble tests (polar-axis and local-level)."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np

from inertest.procedures.local_level_tumble import LocalLevelTumbleResult
from inertest.procedures.polar_tumble import PolarTumbleResult
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import fmt, identification_section


def polar_tumble_figure(result: PolarTumbleResult):
    """Per mounting: drift vs table angle with the fitted harmonic curve, and the residuals."""
    ms = list(result.harmonics)
    fig, axes = plt.subplots(2, len(ms), figsize=(3.6 * len(ms), 5.4), squeeze=False,
                             sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    grid = np.linspace(0, 2 * np.pi, 361)
    for j, m in enumerate(ms):
        h = result.harmonics[m]
        ax, axr = axes[0, j], axes[1, j]
        ax.plot(h.angles_deg, h.drift_deg_h, ".", ms=3, label="measured")
        ax.plot(np.degrees(grid), h.fit.evaluate(grid), "-", label="B0..C2 fit")
        ax.set_title(m)
        ax.grid(alpha=0.3)
        resid = h.drift_deg_h - h.fit.evaluate(np.radians(h.angles_deg))
        axr.plot(h.angles_deg, resid, ".", ms=3)
        axr.axhline(0, color="k", lw=0.6)
        axr.set_xlabel("table angle θ [deg]")
        axr.grid(alpha=0.3)
        if j == 0:
            ax.set_ylabel("drift S_T·i − ω_I [deg/h]")
            axr.set_ylabel("residual [deg/h]")
            ax.legend(fontsize=8)
    finish_figure(fig)
    return fig


def local_level_figure(result: LocalLevelTumbleResult):
    """Drift per position (Earth rate removed) with the fitted model, and the residuals."""
    labels, inverse = np.unique(result.position, return_inverse=True)
    x = np.arange(labels.size)
    mean = np.bincount(inverse, result.drift_deg_h) / np.bincount(inverse)
    fitted = np.bincount(inverse, result.fitted_deg_h) / np.bincount(inverse)
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(max(6, 0.35 * labels.size), 5.4), sharex=True,
                                  gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(inverse, result.drift_deg_h, ".", ms=3, alpha=0.5, label="readings")
    ax.plot(x, mean, "o", mfc="none", label="position mean")
    ax.plot(x, fitted, "_", ms=14, mew=2, label="model")
    ax.set_ylabel("drift S_T·i − ω_I [deg/h]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    axr.plot(inverse, result.drift_deg_h - result.fitted_deg_h, ".", ms=3)
    axr.axhline(0, color="k", lw=0.6)
    axr.set_ylabel("residual [deg/h]")
    axr.set_xticks(x, labels, rotation=90, fontsize=7)
    axr.set_xlabel("position (I O S directions; S = south)")
    axr.grid(alpha=0.3)
    finish_figure(fig)
    return fig


def polar_tumble_sections(
    result: PolarTumbleResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Report sections of a polar-axis tumble: estimates, harmonics, closed form, figures."""
    secs = [identification_section(f"{title}: general least squares", result.identification,
                                    truth)]
    h_rows = [
        [m] + [fmt(t.value, t.std) for t in h.terms] for m, h in result.harmonics.items()
    ]
    harm = Section(f"{title}: Fourier terms per mounting [deg/h]", [])
    if result.harmonics:
        names = [t.name for t in next(iter(result.harmonics.values())).terms]
        harm.parts.append(table_html(["mounting", *names], h_rows))
    for mount, combos in result.closed_form.items():
        rows = [[c.name, fmt(c.value, c.std), c.unit] for c in combos]
        harm.parts.append(paragraph(
            f"Closed-form separation from the {mount}-Np/{mount}-Sp pair "
            "(Source: Inertial instrument testing and data analysis, ch. 3, sec. 2(4)):"))
        harm.parts.append(table_html(["quantity", "estimate ± std", "unit"], rows))
    if result.harmonics:
        harm.parts.append(figure_html(polar_tumble_figure(result),
                                      "Drift against table angle per mounting, with residuals"))
    for msg in result.messages:
        harm.parts.append(paragraph("Warning: " + msg, note=True))
    return [*secs, harm]


def local_level_sections(
    result: LocalLevelTumbleResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Report sections of a local-level tumble."""
    sec = identification_section(f"{title}: least squares", result.identification, truth)
    sec.parts.append(paragraph(
        "At each position only one gyro axis is vertical, so no reading contains a product of "
        "two specific-force components: the cross terms DIO, DOS, DSI cannot be found by this "
        "test (use the polar-axis tumble)."))
    sec.parts.append(figure_html(local_level_figure(result),
                                 "Drift per position (Earth rate on I removed), with residuals"))
    for msg in result.messages:
        sec.parts.append(paragraph("Warning: " + msg, note=True))
    return [sec]
