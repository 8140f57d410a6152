"""HTML report of the centrifuge error study (issue 5, Sun, Ren & Wang): tables, figures."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np

from inertest.report.figure_text import plain_figure_text
from inertest.report.html import Section, figure_html, page, paragraph, table_html
from inertest.report.rounding import format_number, round_to_uncertainty
from inertest.studies.centrifuge_study import REFERENCE, StudyResult
from inertest.units import DEG_PER_H_TO_RAD_PER_S, DEG_TO_RAD

_K = DEG_PER_H_TO_RAD_PER_S


def uncertainty_rows(result: StudyResult) -> list[list[str]]:
    """Rows: coefficient, unit, truth, analytic std, Monte Carlo std, ratio."""
    rows = []
    for i, (n, u) in enumerate(zip(result.names, result.units, strict=True)):
        mc = result.monte_carlo_std
        rows.append([
            n, u, format_number(result.plan.truth[i] / _K), _u(result.std[i] / _K),
            "-" if mc is None else _u(mc[i] / _K),
            "-" if mc is None else format_number(mc[i] / result.std[i], digits=3),
        ])
    return rows


UNCERTAINTY_HEADER = ["coefficient", "unit", "truth", "std (analytic)", "std (Monte Carlo)",
                      "MC / analytic"]


def error_header(result: StudyResult) -> list[str]:
    """Header of the error-transfer tables: case, then one column per coefficient."""
    return ["machine error", *[f"{n} [{u}]" for n, u in zip(result.names, result.units,
                                                              strict=True)]]


def _u(std: float) -> str:
    """A standard uncertainty to two significant digits (GUM 7.2.6)."""
    return round_to_uncertainty(float(std), float(std))[1]


def error_rows(result: StudyResult, *, compensated: bool = False) -> list[list[str]]:
    """Identification error (estimate - truth) per case, engineering units.

    The errors are noise-free (deterministic), so four significant digits; an error below
    1e-12 of the coefficient's scale (its truth or its noise std) is round-off, printed 0.
    """
    scale = np.maximum(np.abs(np.asarray(result.plan.truth, float)), np.asarray(result.std))

    def err_cells(err) -> list[str]:
        return [format_number(float(e) / _K, scale=float(s) / _K)
                for e, s in zip(err, scale, strict=True)]

    rows = [["1 sigma (noise)", *[_u(s / _K) for s in result.std]]]
    if not compensated:
        rows.append(["closed form without Earth-rate Coriolis",
                     *err_cells(result.closed_form_error)])
    for c in result.cases:
        err = c.error_compensated if compensated else c.error
        rows.append([c.case.label, *err_cells(err)])
    return rows


def error_figure(result: StudyResult):
    """Bar chart (log scale) of |error| / sigma per coefficient and machine error."""
    n_cases = len(result.cases)
    fig, ax = plt.subplots(figsize=(11, 5))
    width = 0.8 / max(n_cases, 1)
    x = np.arange(len(result.names))
    for j, c in enumerate(result.cases):
        ratio = np.maximum(np.abs(c.error) / result.std, 1e-6)
        ax.bar(x + (j - (n_cases - 1) / 2) * width, ratio, width, label=c.case.label)
    ax.axhline(1.0, color="k", lw=0.8, ls="--", label="1 sigma of the noise")
    ax.set_yscale("log")
    ax.set_xticks(x, result.names)
    ax.set_ylabel("|estimate - truth| / sigma")
    ax.set_title("Identification error caused by each machine error alone (ideal regressors)")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(axis="y", which="both", alpha=0.3)
    plain_figure_text(fig)
    return fig


def study_sections(result: StudyResult) -> list[Section]:
    """Sections: settings, uncertainty, error transfer (table + figure), compensation, notes."""
    p = result.plan
    settings = [
        ["radius R", f"{format_number(p.radius_m)} m"],
        ["latitude", f"{format_number(p.latitude_rad / DEG_TO_RAD)} deg"],
        ["gravity", f"{format_number(p.gravity_m_s2, digits=7)} m/s^2"],
        ["main-axis rates", ", ".join(format_number(float(w)) for w in p.omegas_rad_s)
         + " rad/s"],
        ["sample rate", f"{format_number(p.sample_rate_hz)} Hz"],
        ["revolutions per run", str(p.revolutions)],
        ["white noise (1 sigma per sample)", f"{format_number(p.noise_sigma_rad_s)} rad/s"],
    ]
    return [
        Section("Settings", [table_html(["setting", "value"], settings, left_columns=1)]),
        Section("Uncertainty of the coefficients", [
            table_html(UNCERTAINTY_HEADER, uncertainty_rows(result), left_columns=2),
            paragraph("Standard uncertainty from the analytic covariance of the whole-revolution "
                      "least-squares fit with the noise known; the Monte Carlo column is the "
                      "scatter of the estimates over repeated noisy simulations of the same "
                      "runs."),
        ]),
        Section("Error transfer: each machine error alone", [
            figure_html(error_figure(result),
                        "|estimate - truth| in units of the noise sigma, log scale"),
            table_html(error_header(result), error_rows(result)),
            paragraph("Gyro output simulated noise-free on the exact erroneous machine, fitted "
                      "with the regressors of the error-free machine (exact kinematics, Earth "
                      "rate included). The second row is the cost of this project's closed form "
                      "without the Earth-rate terms (2 W x v, W x (W x p)) on an error-free "
                      "machine; Sun, Ren & Wang list a Coriolis part (Ak) in its "
                      "eq. (9)."),
        ]),
        Section("Compensation with the error model and the measured dgamma(t)", [
            table_html(error_header(result), error_rows(result, compensated=True)),
            paragraph("Same outputs fitted with the regressors of the machine's error model; the "
                      "non-synchronisation enters as its samples at the output rate "
                      "(spline-interpolated), so a dgamma that varies within a sample interval "
                      "leaves a small residual."),
        ]),
        Section("Exact kinematics versus the first-order results of Sun, Ren & Wang",
                [paragraph(n, note=True) for n in result.notes]),
        Section("Reference", [paragraph(REFERENCE + ".")]),
    ]


def study_page(result: StudyResult, *, identity: Sequence[Sequence[object]] = ()) -> str:
    """The complete HTML report; ``identity`` rows state the input (plan file, SHA-256, ...)."""
    return page("Dual-axis centrifuge: error study of the nine-position method",
                study_sections(result), subtitle=result.plan.name, identity=identity)
