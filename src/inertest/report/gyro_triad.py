"""Figures and report sections of the gyro calibrations of seed 003.

The rate-table test, the 360-degree rotation test and the navigation-mode iteration.
"""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from inertest.procedures.gyro_rate_table import GyroRateTableResult
from inertest.procedures.gyro_triad_rotation import GyroTriadRotationResult
from inertest.procedures.navigation_calibration import (
    AXES,
    NavigationCalibration,
    NavigationCalibrationResult,
)
from inertest.report.calibration import calibration_rows
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, page, paragraph, table_html
from inertest.report.identification import fmt, identification_section
from inertest.report.rounding import format_number, format_with_std
from inertest.results import Estimate


def rate_table_figure(result: GyroRateTableResult):
    """Output against table rate with the fit, and the deviation from the straight line."""
    rates, inverse = np.unique(result.rate_deg_s, return_inverse=True)
    counts = np.bincount(inverse)
    dev = np.bincount(inverse, result.line_deviation) / counts
    k = result.coefficients["K"].value
    fs = abs(k) * np.max(np.abs(rates)) if result.scale_unit != "1" else np.max(np.abs(
        result.output))
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(7, 5.6), sharex=True,
                                  gridspec_kw={"height_ratios": [1.4, 1]})
    ax.plot(result.rate_deg_s, result.output, ".", ms=4, label="readings")
    order = np.argsort(result.rate_deg_s)
    ax.plot(result.rate_deg_s[order], result.fitted[order], "-", lw=1, label="model")
    ax.set_ylabel(f"output [{result.output_unit}]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    axr.plot(result.rate_deg_s, result.line_deviation / fs * 1e6, ".", ms=3, alpha=0.5,
             label="readings")
    axr.plot(rates, dev / fs * 1e6, "o-", mfc="none", label="mean per rate")
    axr.axhline(0, color="k", lw=0.6)
    axr.set_xlabel("commanded table rate [deg/s]")
    axr.set_ylabel("deviation from line [ppm FS]")
    axr.grid(alpha=0.3)
    axr.legend(fontsize=8)
    finish_figure(fig)
    return fig


def rate_table_sections(
    result: GyroRateTableResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Report section of a rate-table test: estimates, nonlinearity, closed-form pairs, figure."""
    sec = identification_section(f"{title}: scale factor, asymmetry, bias", result.identification,
                                 truth)
    sec.parts.append(paragraph(
        "Earth rate along the table axis removed from the bias: "
        f"{format_number(result.earth_rate_deg_h)} "
        "deg/h. K is the mean of the two directions' scale factors when both are determined; "
        "asymmetry = (K_pos - K_neg)/K (IEEE Std 528 / 952 terms)."))
    if result.nonlinearity_ppm is not None:
        sec.parts.append(paragraph(
            "Nonlinearity (largest deviation of a per-rate mean from the straight line, IEEE "
            "Std 528/952): "
            + format_with_std(result.nonlinearity_ppm, result.nonlinearity_noise_ppm)
            + " ppm of full scale (± the noise of a per-rate mean at that rate)."))
    if result.pairs:
        sec.parts.append(paragraph("Closed form from each pair of opposite rates: K = (E+ − E−)"
                                   "/(2ω), B = (E+ + E−)/(2K) − Earth rate:"))
        sec.parts.append(table_html(
            ["rate [deg/s]", f"K ± std [{result.scale_unit}]", "B ± std [deg/h]"],
            pair_rows(result),
            caption="Std of each pair scaled from the least-squares estimates' (equal readings "
                    "per rate): u(K) × √(Σω²/ω²), u(B) × √(number of pairs)"))
        note = pair_bias_note(result)
        if note:
            sec.parts.append(paragraph(note, note=True))
    sec.parts.append(figure_html(rate_table_figure(result),
                                 "Output against table rate, and deviation from the straight "
                                 "line (ppm of full scale)"))
    for msg in result.messages:
        sec.parts.append(paragraph("Warning: " + msg, note=True))
    return [sec]


def pair_bias_note(result: GyroRateTableResult) -> str | None:
    """Why the closed-form bias of the pairs changes with the rate, when it does.

    ``B = (E+ + E-)/(2K)`` takes the whole even part of a pair's outputs as bias: a scale-factor
    asymmetry adds ``(K+ - K-) w / (2K)`` (growing with the rate), a second-order term
    ``K2 w^2`` (growing with its square). The least-squares bias is fitted with those terms.
    None when the pair biases agree within 3 of their standard uncertainties.
    """
    pairs = sorted(result.pairs, key=lambda q: q["rate_deg_s"])
    b = result.identification.coefficients.get("B")
    if len(pairs) < 2 or b is None:
        return None
    u = float(b.std) * np.sqrt(len(pairs))
    lo, hi = pairs[0], pairs[-1]
    if not abs(hi["B"] - lo["B"]) > 3.0 * np.sqrt(2.0) * u:
        return None
    fitted = [n for n in ("asymmetry", "K2") if n in result.identification.coefficients]
    return (f"The pair bias climbs from {format_with_std(lo['B'], u)} deg/h at "
            f"±{lo['rate_deg_s']:g} deg/s to {format_with_std(hi['B'], u)} deg/h "
            f"at ±{hi['rate_deg_s']:g} deg/s: the closed form counts the whole "
            "even part of a pair's outputs as bias, and a scale-factor asymmetry (K+ ≠ K−) "
            "adds (K+ − K−)ω/(2K), growing with the rate, a second-order term K2 adds K2 ω², "
            "growing with its square. It is not the gyro's bias: the least-squares B above is "
            "fitted together with " + (" and ".join(fitted) if fitted else "the scale factor")
            + " and holds at every rate.")


def rotation_residual_figure(result: GyroTriadRotationResult):
    """Residual counts of each gyro in each window."""
    n = result.counts.shape[0]
    fig, ax = plt.subplots(figsize=(max(6, 0.32 * n), 3.6))
    x = np.arange(n)
    for j, a in enumerate(AXES):
        ax.plot(x + (j - 1) * 0.2, result.residual_output[:, j], "o", ms=4, label=f"gyro {a}")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xticks(x, result.part, rotation=90, fontsize=7)
    ax.set_ylabel(f"residual [{result.output_unit}]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    finish_figure(fig)
    return fig


def rotation_sections(
    result: GyroTriadRotationResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Report section of the 360-degree rotation test: estimates, calibration, residuals."""
    sec = identification_section(f"{title}: scale factors, misalignment, bias",
                                 result.identification, truth)
    gyro = result.calibration.gyroscope
    assert gyro is not None
    sec.parts.append(paragraph(
        f"Calibration (calibrated [rad/s] = matrix @ (raw [{gyro.raw_unit}] − offset)):"))
    rows = calibration_rows(gyro, result.identification.coefficients)
    sec.parts.append(table_html(
        ["gyro", "matrix x ± std", "matrix y ± std", "matrix z ± std", "offset ± std"], rows,
        caption="Entries ± their standard uncertainties (first order from those of K, M and B)"))
    if result.closed_form_scale:
        sec.parts.append(paragraph(
            "Closed form K_j = (N_j(+) − N_j(−))/(4π) (equal windows, constant rate): "
            + ", ".join(f"{k} = {fmt(v, _std(result.identification.coefficients, k))} "
                        f"{result.scale_unit}" for k, v in result.closed_form_scale.items())
            + " (± the least-squares estimate's std)."))
    sec.parts.append(figure_html(rotation_residual_figure(result),
                                 "Residual counts per window and gyro"))
    return [sec]


def _std(estimates: Mapping[str, Estimate], name: str) -> float | None:
    e = estimates.get(name)
    return None if e is None else float(e.std)


def pair_rows(result: GyroRateTableResult) -> list[list[str]]:
    """Closed-form K and B of each pair of opposite rates, each ± its std.

    The least-squares estimates use every rate; one pair at rate ω uses the readings at ±ω
    only, so (equal readings per rate) ``u(K_ω) = u(K) sqrt(Σ ω_k² / ω²)`` and
    ``u(B_ω) = u(B) sqrt(number of pairs)``: the std only sets the printed decimal.
    """
    coeffs = result.identification.coefficients
    rates = np.array([float(p["rate_deg_s"]) for p in result.pairs])
    uk, ub = _std(coeffs, "K"), _std(coeffs, "B")
    rows = []
    for p in result.pairs:
        r = float(p["rate_deg_s"])
        sk = None if uk is None or r == 0 else uk * float(np.sqrt(np.sum(rates**2) / r**2))
        sb = None if ub is None else ub * float(np.sqrt(rates.size))
        rows.append([f"±{format_number(r)}", fmt(p["K"], sk), fmt(p["B"], sb)])
    return rows


def convergence_figure(result: NavigationCalibrationResult):
    """Attitude error and corrections against iteration (log scale)."""
    it = [h.iteration for h in result.history]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8))
    a1.semilogy(it, [max(h.attitude_error_rms_arcsec, 1e-12) for h in result.history], "o-",
                label="rms")
    a1.semilogy(it, [max(h.attitude_error_max_arcsec, 1e-12) for h in result.history], "s--",
                label="max")
    a1.set_xlabel("iteration")
    a1.set_ylabel("attitude error before correction [arcsec]")
    a1.grid(alpha=0.3, which="both")
    a1.legend(fontsize=8)
    for j, a in enumerate(AXES):
        a2.semilogy(it, [max(abs(h.scale_correction_ppm[j]), 1e-12) for h in result.history],
                    "o-", label=f"|δK_{a}| [ppm]")
    a2.semilogy(it, [max(np.max(np.abs(h.misalignment_correction_urad)), 1e-12)
                     for h in result.history], "k^--", label="max |δM| [µrad]")
    a2.set_xlabel("iteration")
    a2.set_ylabel("correction")
    a2.grid(alpha=0.3, which="both")
    a2.legend(fontsize=8)
    for ax in (a1, a2):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    finish_figure(fig)
    return fig


def navigation_sections(result: NavigationCalibration, *,
                        title: str = "Navigation-mode calibration") -> list[Section]:
    """Estimates after the iteration, the history of corrections and the convergence figure."""
    it = result.iteration
    rows = [[e.name, fmt(e.value, e.std), e.unit] for e in result.coefficients.values()]
    sec = Section(title, [table_html(["quantity", "estimate ± std", "unit"], rows)])
    for note in result.identification.not_separable:
        sec.parts.append(paragraph("Not determined: " + note, note=True))
    sec.parts.append(paragraph(
        f"{'Converged' if it.converged else 'Not converged'} after {len(it.history)} "
        "iteration(s); scatter of the attitude-error increments "
        f"{format_number(it.noise_arcsec)} arcsec ({it.dof} dof)."))
    hist = [[h.iteration, float(h.attitude_error_rms_arcsec),
             float(h.attitude_error_max_arcsec),
             ", ".join(format_number(float(v)) for v in h.scale_correction_ppm),
             float(np.max(np.abs(h.misalignment_correction_urad))),
             ", ".join(format_number(float(v)) for v in h.bias_correction_deg_h)]
            for h in it.history]
    sec.parts.append(table_html(
        ["iteration", "rms error [arcsec]", "max error [arcsec]", "δK x, y, z [ppm]",
         "max |δM| [urad]", "δB x, y, z [deg/h]"], hist))
    sec.parts.append(figure_html(convergence_figure(it),
                                 "Attitude error and corrections per iteration"))
    return [sec]


def navigation_page(result: NavigationCalibration) -> str:
    """Self-contained HTML page of a navigation-mode calibration."""
    serial = result.instrument.serial
    return page(f"inertest: navigation-mode calibration of {serial or 'gyro triad'}",
                navigation_sections(result),
                subtitle="Iterative refinement through 360-degree rotations (Source: Precise "
                         "calibration and compensation of FOG scale factor, sec. 1.3)")
