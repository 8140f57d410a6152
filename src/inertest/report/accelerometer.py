"""Figures and report sections of the accelerometer tests.

Dividing-head multipoint test of a single pendulous accelerometer, and static multi-position
calibration of an accelerometer triad.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from inertest.models.triad import AXES
from inertest.procedures.accelerometer_multipoint import AccelerometerMultipointResult
from inertest.procedures.triad_multiposition import TriadMultipositionResult
from inertest.report.calibration import calibration_rows
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import fmt, identification_section


def multipoint_figure(result: AccelerometerMultipointResult):
    """Per mounting: model error ``E/K1 - aI`` [ug] vs head angle with the fit, and residuals.

    Removing the ideal response ``K1 aI`` shows the bias, nonlinearity, cross-coupling and
    misalignment harmonics that the test separates.
    """
    ms = list(np.unique(result.mounting))
    k1 = result.coefficients["K1"].value
    ideal = k1 * result.specific_force_g[:, 0]
    fig, axes = plt.subplots(2, len(ms), figsize=(3.8 * len(ms), 5.4), squeeze=False,
                             sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    for j, m in enumerate(ms):
        sel = result.mounting == m
        t = result.angle_deg[sel]
        order = np.argsort(t, kind="stable")
        err = (result.output[sel] - ideal[sel]) / k1 * 1e6
        model = (result.fitted[sel] - ideal[sel]) / k1 * 1e6
        ax, axr = axes[0, j], axes[1, j]
        ax.plot(t, err, ".", ms=3, label="measured")
        ax.plot(t[order], model[order], "-", lw=1, label="model")
        ax.set_title(f"mounting {m}")
        ax.grid(alpha=0.3)
        axr.plot(t, result.residual_output[sel], ".", ms=3)
        axr.axhline(0, color="k", lw=0.6)
        axr.set_xlabel("head angle θ [deg]")
        axr.grid(alpha=0.3)
        if j == 0:
            ax.set_ylabel("E/K1 − aI [µg]")
            axr.set_ylabel(f"residual [{result.output_unit}]")
            ax.legend(fontsize=8)
    finish_figure(fig)
    return fig


def multipoint_sections(
    result: AccelerometerMultipointResult, truth: Mapping[str, float] | None = None, *,
    title: str,
) -> list[Section]:
    """Estimates (general least squares), Fourier terms and closed forms per mounting, figure."""
    sec = identification_section(f"{title}: general least squares over all mountings",
                                 result.identification, truth)
    four = Section(f"{title}: Fourier analysis per mounting", [])
    if result.fourier:
        names = ["B0", "S1", "C1", "S2", "C2", "S3", "C3"]
        sig = fourier_stds(result)
        rows = [[m, *(fmt(v["harmonics"][n], sig[m][n]) for n in names)]  # type: ignore[index]
                for m, v in result.fourier.items()]
        four.parts.append(table_html(
            ["mounting", *(f"{n} ± std [{result.output_unit}]" for n in names)], rows,
            caption="Fourier terms of the position means per mounting; std from the fit's "
                    "residual scatter of the position means"))
        for m, v in result.fourier.items():
            found: Mapping[str, Any] = v
            cf: dict[str, Any] = {**found.get("coefficients", {}), **found.get("combinations", {})}
            if cf:
                stds = closed_form_stds(v, sig[m])  # type: ignore[arg-type]
                four.parts.append(table_html(
                    ["quantity", "value ± std", "unit"],
                    [[k, fmt(x["value"], stds.get(k)), x["unit"]] for k, x in cf.items()],
                    caption=f"Closed forms of mounting {m} (IEEE Std 1293 multipoint): "
                            "K1 = (C1 − 3 C3)/γ, K3 = 4 C3/(K1 γ³), misalignment from S1, "
                            "cross-coupling from S2"))
    else:
        four.parts.append(paragraph("No mounting has 8+ equally spaced positions over 360 deg; "
                                    "the Fourier closed forms do not apply.", note=True))
    four.parts.append(figure_html(multipoint_figure(result),
                                  "Output less the ideal K1·aI against head angle per "
                                  "mounting, with residuals"))
    for msg in result.messages:
        four.parts.append(paragraph("Warning: " + msg, note=True))
    return [sec, four]


def fourier_stds(result: AccelerometerMultipointResult) -> dict[str, dict[str, float]]:
    """Standard uncertainty of each Fourier term per mounting [output unit].

    From the result's own residuals: ``s_e`` is the scatter of the position means about the
    fitted model (degrees of freedom: positions less the fitted quantities); for ``N`` equally
    spaced positions ``u(B0) = s_e / sqrt(N)`` and ``u(Sk) = u(Ck) = s_e sqrt(2/N)`` (the
    discrete Fourier sums of independent position means).
    """
    resid = np.asarray(result.output, dtype=float) - np.asarray(result.fitted, dtype=float)
    keys = np.char.add(np.asarray(result.mounting).astype(str),
                       np.char.mod("|%.9f", np.asarray(result.angle_deg, dtype=float) % 360.0))
    labels, inv = np.unique(keys, return_inverse=True)
    means = np.bincount(inv, weights=resid) / np.bincount(inv)
    ident = result.identification
    p = len(ident.coefficients) + len(ident.combinations)
    dof = max(labels.size - p, 1)
    s_e = float(np.sqrt(np.sum(means**2) / dof))
    out = {}
    for m in result.fourier:
        n = int(np.unique(np.asarray(result.angle_deg)[np.asarray(result.mounting) == m]
                          % 360.0).size)
        out[m] = {"B0": s_e / np.sqrt(n),
                  **{f"{t}{k}": s_e * np.sqrt(2.0 / n) for t in "SC" for k in (1, 2, 3)}}
    return out


def closed_form_stds(v: Mapping[str, Mapping], s: Mapping[str, float]) -> dict[str, float]:
    """Standard uncertainties of the closed forms of one mounting by first-order propagation.

    The Fourier terms are independent (orthogonal sums), and the relative uncertainty of K1 is
    neglected in the ratios (it is far below that of the small terms divided by it).
    """
    h = v["harmonics"]
    coeff = v.get("coefficients", {})
    if "K1" not in coeff:
        return {}
    k1 = float(coeff["K1"]["value"])
    g = (h["C1"] - 3 * h["C3"]) / k1               # gamma, as the closed form used it
    u = 1e-6
    out = {"K1": float(np.hypot(s["C1"], 3 * s["C3"]) / g),
           "K3": 4 * s["C3"] / (abs(k1) * g**3) / u}
    for name in coeff:
        if name in ("dO", "dP"):
            out[name] = s["S1"] / (abs(k1) * g) / u
        elif name in ("KIP", "KIO"):
            out[name] = 2 * s["S2"] / (abs(k1) * g**2) / u
    for name in v.get("combinations", {}):
        out[name] = (s["B0"] / abs(k1) / u if name.startswith("K0")
                     else 2 * s["C2"] / (abs(k1) * g**2) / u)
    return out


def triad_residual_figure(result: TriadMultipositionResult):
    """Residual of each output per position."""
    labels, inverse = np.unique(result.position, return_inverse=True)
    fig, ax = plt.subplots(figsize=(max(6, 0.4 * labels.size), 3.6))
    resid = result.output - result.fitted
    for i, a in enumerate(AXES):
        ax.plot(inverse + (i - 1) * 0.15, resid[:, i], ".", ms=4, label=f"output_{a}")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xticks(np.arange(labels.size), labels, rotation=90, fontsize=7)
    ax.set_xlabel("position (directions of x, y, z; /axis±deg = tilt)")
    ax.set_ylabel(f"residual [{result.output_unit}]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    finish_figure(fig)
    return fig


def triad_sections(
    result: TriadMultipositionResult, truth: Mapping[str, float] | None = None, *, title: str,
) -> list[Section]:
    """Estimates with uncertainty, the calibration matrix/offset and residuals per position."""
    sec = identification_section(f"{title}: scale factor, misalignment, bias",
                                 result.identification, truth)
    sec.parts.append(paragraph(
        "Model raw = K (I + M) f + K (I + M) B: K_i scale factor, M_ij sensitivity of sensor i to "
        "specific force along the fixture's reference axis j (all six angles, since the fixture "
        "fixes the reference frame), B input-referred bias."))
    est = result.triads[0]
    if est.scale_ppm:
        sec.parts.append(table_html(
            ["scale factor", "deviation from nominal ± std [ppm]"],
            [[k, fmt(e.value, e.std)] for k, e in est.scale_ppm.items()]))
    cal = result.calibration.accelerometer
    if cal is not None:
        sec.parts.append(paragraph(f"Calibration: calibrated [m/s²] = matrix @ (raw − offset), "
                                   f"raw in {cal.raw_unit}."))
        sec.parts.append(table_html(
            ["row", "matrix x ± std", "matrix y ± std", "matrix z ± std", "offset ± std"],
            calibration_rows(cal, est.all_estimates()),
            caption="Entries ± their standard uncertainties (first order from those of K, M "
                    "and B)"))
    sec.parts.append(table_html(
        ["output", f"noise per reading [{result.output_unit}]"],
        [[k, float(v)] for k, v in result.noise_per_axis.items()]))
    sec.parts.append(figure_html(triad_residual_figure(result), "Residuals per position"))
    for msg in result.messages:
        sec.parts.append(paragraph("Warning: " + msg, note=True))
    return [sec]
