"""Figure and report section of the temperature compensation (seed 003, BP network)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.procedures.thermal_compensation import ThermalResult
from inertest.report.html import Section, figure_html, paragraph, table_html

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
    fig.tight_layout()
    return fig


def summary_rows(result: ThermalResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows: RMS residual before and after each model, training and validation."""
    u = result.unit
    header = ["model", f"training RMS [{u}]", f"validation RMS [{u}]", "details"]
    rows = [["uncompensated", f"{result.before_train_rms:.4g}",
             f"{result.before_validation_rms:.4g}", "deviation from the training mean"]]
    for fit in (result.polynomial, result.network):
        note = fit.description + ("" if fit.converged else " (did NOT converge)")
        rows.append([fit.name, f"{fit.train_rms:.4g}", f"{fit.validation_rms:.4g}", note])
    return header, rows


def model_rows(result: ThermalResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows: the polynomial model's coefficients with std and unit."""
    doc = result.model("polynomial").to_dict()
    header = ["term", "power of (T - T_ref)", "power of dT/dt", "value", "std", "unit"]
    rows = [[t["name"], str(t["power_of_t_minus_t_ref"]), str(t["power_of_rate"]),
             f"{t['value']:.6g}", f"{t['std']:.2g}", t["unit"]]
            for t in doc["terms"]]  # type: ignore[attr-defined]
    return header, rows


def thermal_sections(result: ThermalResult, *, title: str) -> list[Section]:
    """Report section: summary table, the polynomial model, figure, notes."""
    header, rows = summary_rows(result)
    sec = Section(title, [table_html(header, rows)])
    poly = result.model("polynomial")
    sec.parts.append(paragraph(
        f"Polynomial model (write it with thermal fit --model-out, apply it with inertest "
        f"apply): {poly.equation()}; valid for {poly.temperature_range_c[0]:.4g} to "
        f"{poly.temperature_range_c[1]:.4g} degC"
        + ("" if poly.rate_range_c_per_min is None else
           f" and {poly.rate_range_c_per_min[0]:.3g} to {poly.rate_range_c_per_min[1]:.3g} "
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
