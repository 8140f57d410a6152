"""Figures and report sections of temperature compensation and of a triad against temperature.

Seed 003: the scalar polynomial / BP-network compensation, and the triad K, M, B laws in
temperature with the heating/cooling hysteresis table.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.models.thermal import PolynomialThermalModel
from inertest.procedures.thermal_compensation import ThermalResult
from inertest.procedures.thermal_triad import ThermalTriadResult
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.rounding import format_number, format_with_std, round_to_uncertainty

_LABEL = {"scale_factor": "scale factor error", "bias": "bias"}


def thermal_figure(result: ThermalResult) -> Figure:
    """Data and both models against temperature, residuals over the validation cycles, CV."""
    u = result.unit
    val = ~result.train
    fig = plt.figure(figsize=(10, 7.2))
    grid = fig.add_gridspec(2, 3)
    ax = fig.add_subplot(grid[0, :2])
    ax.plot(result.temperature_c[result.train], result.value[result.train], ".", ms=2,
            color="0.65", label="training cycles")
    ax.plot(result.temperature_c[val], result.value[val], ".", ms=3, color="C0",
            label="validation cycle(s)")
    for fit, colour in ((result.polynomial, "C1"), (result.network, "C3")):
        ax.plot(result.temperature_c[val], fit.prediction[val], "-", lw=1.2, color=colour,
                label=f"{fit.name} ({fit.description})")
    ax.set_xlabel("temperature [degC]")
    ax.set_ylabel(f"{_LABEL[result.quantity]} [{u}]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("heating and cooling branches differ: hysteresis", fontsize=9)
    axc = fig.add_subplot(grid[0, 2])
    deg = np.array(sorted(result.cv_rms))
    axc.semilogy(deg, [result.cv_rms[d] for d in deg], "o-")
    axc.set_xlabel("polynomial degree")
    axc.set_ylabel(f"leave-one-cycle-out RMS [{u}]")
    axc.grid(alpha=0.3, which="both")
    axr = fig.add_subplot(grid[1, :])
    k = (result.time_s[val] - result.time_s[val][0]) / 3600.0
    ref = np.mean(result.value[result.train])
    axr.plot(k, result.value[val] - ref, "-", lw=0.8, color="0.5",
             label=f"uncompensated (RMS {result.before_validation_rms:.3g} {u})")
    for fit, colour in ((result.polynomial, "C1"), (result.network, "C3")):
        axr.plot(k, result.value[val] - fit.prediction[val], "-", lw=0.8, color=colour,
                 label=f"{fit.name} (RMS {fit.validation_rms:.3g} {u})")
    axr.set_xlabel("time in the validation cycle(s) [h]")
    axr.set_ylabel(f"residual [{u}]")
    axr.grid(alpha=0.3)
    axr.legend(fontsize=7)
    finish_figure(fig)
    return fig


def summary_rows(result: ThermalResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows: RMS residual before and after each model, training and validation."""
    u = result.unit
    header = ["model", f"training RMS [{u}]", f"validation RMS [{u}]", "details"]
    rows = [["uncompensated", format_number(result.before_train_rms),
             format_number(result.before_validation_rms), "deviation from the training mean"]]
    for fit in (result.polynomial, result.network):
        note = fit.description + ("" if fit.converged else " (did NOT converge)")
        rows.append([fit.name, format_number(fit.train_rms), format_number(fit.validation_rms),
                     note])
    return header, rows


def model_rows(result: ThermalResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows: the polynomial model's coefficients with std and unit."""
    doc = result.model("polynomial").to_dict()
    header = ["term", "power of (T - T_ref)", "power of dT/dt", "value", "std", "unit"]
    rows = [[t["name"], str(t["power_of_t_minus_t_ref"]), str(t["power_of_rate"]),
             *round_to_uncertainty(float(t["value"]), float(t["std"])), t["unit"]]
            for t in doc["terms"]]  # type: ignore[attr-defined]
    return header, rows


def thermal_sections(result: ThermalResult, *, title: str) -> list[Section]:
    """Report section: summary table, the polynomial model, figure, notes."""
    header, rows = summary_rows(result)
    sec = Section(title, [table_html(header, rows)])
    poly = result.model("polynomial")
    assert isinstance(poly, PolynomialThermalModel)
    sec.parts.append(paragraph(
        f"Polynomial model (write it with thermal fit --model-out, apply it with inertest "
        f"apply): {poly.equation()}; valid for "
        f"{format_number(poly.temperature_range_c[0])} to "
        f"{format_number(poly.temperature_range_c[1])} degC"
        + ("" if poly.rate_range_c_per_min is None else
           f" and {format_number(poly.rate_range_c_per_min[0])} to "
           f"{format_number(poly.rate_range_c_per_min[1])} "
           "degC/min") + "."))
    sec.parts.append(table_html(*model_rows(result)))
    sec.parts.append(paragraph(
        f"Inputs: {', '.join(result.inputs)}. Train/validation split by temperature cycle; the "
        "polynomial degree was chosen by leave-one-cycle-out cross-validation on the training "
        "cycles; the BP network (the seed's model) has standardised inputs and target and a "
        "fixed random state. The validation RMS is the uncertainty of the compensation on a "
        "cycle the models have not seen."))
    for m in result.messages:
        sec.parts.append(paragraph(m, note=True))
    sec.parts.append(figure_html(thermal_figure(result),
                                 f"{_LABEL[result.quantity]} against temperature, and residuals"))
    return [sec]


def triad_thermal_figure(result: ThermalTriadResult) -> Figure:
    """Each coefficient's per-step estimates ± std (heating, cooling) and its fitted law."""
    names = list(result.laws)
    ncol = 3
    nrow = -(-len(names) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(11, 2.3 * nrow + 0.6), squeeze=False)
    t = result.step_temperature_c
    lo, hi = float(t.min()), float(t.max())
    grid = np.linspace(lo, hi, 121)
    rate = float(np.mean(result.step_rate_c_per_min))
    for ax, n in zip(axes.ravel(), names, strict=False):
        law = result.laws[n]
        for branch, colour, marker in (("heating", "C3", "^"), ("cooling", "C0", "v")):
            sel = result.step_branch == branch
            if np.any(sel):
                ax.errorbar(t[sel], result.step_values[n][sel], yerr=result.step_stds[n][sel],
                            fmt=marker, ms=4, color=colour, lw=0.8, capsize=2, label=branch)
        v, sd = law.predict(grid, np.full(grid.size, rate))
        ax.plot(grid, v, "-", color="k", lw=1.0, label="law")
        ax.fill_between(grid, v - sd, v + sd, color="0.6", alpha=0.35, lw=0)
        ax.set_title(f"{n} [{law.unit}]", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("temperature [degC]", fontsize=8)
    axes[0, 0].legend(fontsize=7)
    finish_figure(fig)
    return fig


def triad_law_rows(result: ThermalTriadResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows: each coefficient's law terms (value ± std unit) and its chi-square."""
    first = next(iter(result.laws.values()))
    terms = [f"a{k}" for k in range(first.degree + 1)] + (["r"] if first.uses_rate else [])
    dt = f"(T - {first.t_ref_c:g} degC)"
    header = ["coefficient", *("a0 (at T_ref)" if k == "a0" else f"a1 per {dt}" if k == "a1"
                                else f"{k} per {dt}^{k[1:]}" if k != "r"
                                else "r per dT/dt [degC/min]" for k in terms),
              "chi2 / dof", "p"]
    rows = []
    for n, law in result.laws.items():
        doc: Mapping[str, Any] = law.to_dict()["terms"]  # type: ignore[assignment]
        cells = [format_with_std(d["value"], d["std"], d["unit"]) for d in doc.values()]
        rows.append([n, *cells, f"{format_number(law.chi2)} / {law.dof}",
                     "-" if law.dof <= 0 else format_number(law.p_value, digits=2)])
    return header, rows


def triad_hysteresis_rows(result: ThermalTriadResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows: heating minus cooling at its largest, Wald test and verdict."""
    header = ["coefficient", "heating - cooling", "at [degC]", "Wald chi2", "dof", "p",
              "verdict"]
    rows = [[n, format_with_std(h.max_difference, h.std, h.unit),
             format_number(h.at_temperature_c), format_number(h.statistic), str(h.dof),
             format_number(h.p_value, digits=2),
             "SIGNIFICANT" if h.significant else "not significant"]
            for n, h in result.hysteresis.items()]
    return header, rows


def triad_thermal_sections(result: ThermalTriadResult, *, title: str) -> list[Section]:
    """Report section: laws per coefficient, figure, hysteresis table with verdicts."""
    first = next(iter(result.laws.values()))
    heat = int(np.sum(result.step_branch == "heating"))
    cool = int(np.sum(result.step_branch == "cooling"))
    t = result.step_temperature_c
    sec = Section(title, [paragraph(
        f"Multi-position calibration at each of {t.size} temperature steps ({heat} heating, "
        f"{cool} cooling, "
        f"{format_number(float(t.min()))} to {format_number(float(t.max()))} degC), then each "
        f"coefficient fitted as a polynomial of degree {first.degree} in "
        f"(T - {first.t_ref_c:g} degC)"
        + (" plus a term in dT/dt" if first.uses_rate else "")
        + " by weighted least squares with the per-step uncertainties. Triad model raw = "
        "K (I + M) (u + B); K in the scale unit, M in urad, B in mg (input-referred). "
        "The model (thermal triad --model-out) is valid over the step temperatures and is "
        "applied with inertest apply MODEL.json DATA --temperature-column temperature_c.")])
    sec.parts.append(table_html(*triad_law_rows(result),
                                caption="Law of each coefficient (value ± std unit)"))
    sec.parts.append(figure_html(triad_thermal_figure(result),
                                 "Per-step estimates ± std (heating up, cooling down triangles) "
                                 "and the fitted law ± std"))
    if result.hysteresis:
        sec.parts.append(table_html(
            *triad_hysteresis_rows(result),
            caption=(f"Hysteresis: heating minus cooling curve at its largest; Wald test of the "
                     f"two branches' polynomials, family level {result.alpha:g} (Bonferroni over "
                     f"{len(result.hysteresis)} coefficients)")))
    for m in result.messages:
        sec.parts.append(paragraph(m, note=True))
    return [sec]
