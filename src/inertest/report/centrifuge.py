"""Report section of the nine-position centrifuge test: coefficients, runs, residuals."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np

from inertest.procedures.centrifuge_nine_position import CentrifugeNinePositionResult
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import identification_section
from inertest.report.rounding import format_column, format_number, round_to_uncertainty


def runs_figure(result: CentrifugeNinePositionResult):
    """Whole-revolution mean drift per run with the model, and the run residuals.

    One marker per run (position on the x axis, one colour per main-axis rate); the drift is the
    mean output minus the mean input rate on I [deg/h], the residual (drift minus model) is in
    deg/h beside it.
    """
    rates = np.unique(result.run_omega)
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(7.0, 5.4), sharex=True,
                                  gridspec_kw={"height_ratios": [2, 1]})
    width = 0.6 / max(rates.size, 1)
    for j, w in enumerate(rates):
        sel = result.run_omega == w
        x = result.run_position[sel] + (j - (rates.size - 1) / 2) * width
        line, = ax.plot(x, result.drift_deg_h[sel], "o", mfc="none", label=f"{w:g} rad/s")
        ax.plot(x, result.fitted_deg_h[sel], "_", ms=12, mew=2, color=line.get_color())
        axr.plot(x, result.drift_deg_h[sel] - result.fitted_deg_h[sel], "o", ms=4,
                 color=line.get_color())
    ax.set_ylabel("mean drift ω_out − ω_I [deg/h]")
    ax.legend(title="main-axis rate (— model)", fontsize=8, title_fontsize=8)
    ax.grid(alpha=0.3)
    axr.axhline(0, color="k", lw=0.6)
    axr.set_ylabel("residual [deg/h]")
    axr.set_xlabel("position")
    axr.set_xticks(range(1, 10))
    axr.grid(alpha=0.3)
    finish_figure(fig)
    return fig


def nine_position_sections(
    result: CentrifugeNinePositionResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Report sections of a nine-position centrifuge test.

    The coefficient table (deg/h, deg/h/g, deg/h/g^2, with standard uncertainties and, when
    ``truth`` is given, the truth), the statements of what is not determined, one row per run and
    the figure of run means and residuals.
    """
    sec = identification_section(f"{title}: whole-cycle least squares", result.identification,
                                 truth)
    sec.parts.append(paragraph(
        f"Dual-axis centrifuge, arm radius {format_number(result.radius_m)} m, platform "
        f"heading {format_number(result.platform_heading_deg)} deg. Each run (one position at "
        "one main-axis rate) is reduced to its mean over whole revolutions; the ten regressors, "
        "built from the exact inputs of the error-free machine with the Earth's rotation, are "
        "averaged over the same samples with the same weights, and the mean Earth rate on I is "
        "subtracted (eqs. 18-22 of Sun Yingbo, Ren Shunqing, Wang "
        "Changhong, Harbin Institute of Technology). One observation per run; omega is the "
        "signed arm rate (negative = clockwise seen from above)."))
    ident = result.identification
    u = float(ident.noise_sigma) if ident.noise_unit == "deg/h" else None

    def at(x: float, std: float | None) -> str:
        return round_to_uncertainty(float(x), std)[0] if std else format_number(float(x))

    ome = format_column([float(w) for w in result.run_omega])
    earth = format_column([float(e) for e in result.earth_rate_deg_h])
    rows = [
        [str(int(p)), w, str(int(r)), str(int(n)), at(d, u), at(f, u), e, at(d - f, u)]
        for p, w, r, n, d, f, e in zip(
            result.run_position, ome, result.run_revolutions, result.run_samples,
            result.drift_deg_h, result.fitted_deg_h, earth, strict=True)
    ]
    sec.parts.append(table_html(
        ["position", "ω [rad/s]", "revolutions", "samples", "drift [deg/h]", "model [deg/h]",
         "ω_I [deg/h]", "residual [deg/h]"], rows,
        caption="Drift, model and residual rounded at the noise per run "
                + ("(not known)" if u is None else f"({round_to_uncertainty(u, u)[1]} deg/h)")
                + "; ω_I round-off (1e-16 deg/h) printed as 0"))
    sec.parts.append(figure_html(runs_figure(result),
                                 "Whole-revolution mean drift per run with the model, and the "
                                 "run residuals"))
    for msg in result.messages:
        sec.parts.append(paragraph("Warning: " + msg, note=True))
    return [sec]
