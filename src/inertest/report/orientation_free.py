"""Report section of the orientation-free calibration (Tedaldi et al., ICRA 2014)."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.procedures.orientation_free import OrientationFreeResult
from inertest.report.calibration import result_calibration_rows
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import identification_section
from inertest.units import MILLI_G_TO_M_PER_S2


def orientation_free_figure(result: OrientationFreeResult) -> Figure:
    """Detector trace with the intervals found; |a| - g and carried-gravity angle before/after."""
    fig, (ax0, ax1, ax2) = plt.subplots(3, 1, figsize=(9, 7.5))
    det = result.detection
    n = det.variance_magnitude.size
    fs = n / max(result.intervals[-1].end_s - result.intervals[0].start_s, 1e-9) \
        if len(result.intervals) > 1 else 1.0
    t = np.arange(n) / fs
    ax0.semilogy(t, det.variance_magnitude, lw=0.6, color="C0")
    ax0.axhline(det.threshold, color="C3", ls="--", lw=0.8,
                label=f"threshold ({det.threshold_factor:g} x initial)")
    for a, b in det.intervals:
        ax0.axvspan(a / fs, b / fs, color="C2", alpha=0.2, lw=0)
    ax0.set_xlabel("time from start [s]")
    ax0.set_ylabel("variance magnitude [raw^2]")
    ax0.set_title(f"static detector: {det.count} intervals (green)", fontsize=9)
    ax0.legend(fontsize=7)
    k = np.arange(len(result.intervals))
    ax1.plot(k, result.gravity_error_before_m_s2 / MILLI_G_TO_M_PER_S2, "o", ms=3,
             label="nominal", color="C1")
    ax1.plot(k, result.gravity_error_m_s2 / MILLI_G_TO_M_PER_S2, "o", ms=3,
             label="calibrated", color="C0")
    ax1.axhline(0, color="k", lw=0.6)
    ax1.set_yscale("symlog", linthresh=1.0)
    ax1.set_xlabel("static interval")
    ax1.set_ylabel("|a| - g [mg]")
    ax1.legend(fontsize=7)
    m = np.arange(result.transport_angle_deg.size)
    ax2.plot(m, result.transport_angle_before_deg, "o", ms=3, label="nominal", color="C1")
    ax2.plot(m, result.transport_angle_deg, "o", ms=3, label="calibrated", color="C0")
    ax2.set_yscale("log")
    ax2.set_xlabel("motion (interval k to k+1)")
    ax2.set_ylabel("carried gravity error [deg]")
    ax2.legend(fontsize=7)
    for a in (ax0, ax1, ax2):
        a.grid(alpha=0.3)
    finish_figure(fig)
    return fig


def orientation_free_sections(
    result: OrientationFreeResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Coefficients, the checks before/after, the intervals found, the calibration, a figure."""
    sec = identification_section(f"{title}: scale factors, misalignments, biases",
                                 result.identification, truth)
    s = result.summary()
    rows = [[name.replace("_", " "), float(v["before"]), float(v["after"]), str(v["unit"])]
            for name, v in s.items()]
    sec.parts.append(paragraph(
        "Physical checks (rms over the static intervals / the motions between them): |a| - g "
        "of each interval mean, and the angle between the gravity direction carried by the "
        "integrated gyro and the next interval's; nominal = the plan's scale guesses."))
    sec.parts.append(table_html(["check", "nominal", "calibrated", "unit"], rows))
    lam, mu = result.noise_scales
    sec.parts.append(paragraph(
        "Uncertainties propagate the noise of the static interval means, of the initial gyro "
        "bias and of each integrated motion through both fits (with the accelerometer-gyro "
        f"cross-covariance); noise levels from the residuals: {lam:.3g} x the white-noise "
        f"variance of the interval means, {mu:.3g} x the gyro angle random walk."))
    iv_rows = [[str(k + 1), float(iv.start_s), float(iv.end_s), float(iv.duration_s),
                float(e / MILLI_G_TO_M_PER_S2)]
               for k, (iv, e) in enumerate(zip(result.intervals, result.gravity_error_m_s2,
                                               strict=True))]
    how = ""
    if result.threshold_search:
        tried = ", ".join(
            f"{c.threshold_factor:g}: {c.intervals} intervals, "
            + (f"{c.residual_rms_m_s2 / MILLI_G_TO_M_PER_S2:.3g} mg"
               if np.isfinite(c.residual_rms_m_s2) else "no fit")
            for c in result.threshold_search)
        how = (" chosen automatically as the factor with the lowest accelerometer residual "
               f"(Tedaldi et al. Sec. IV; tried {tried})")
    sec.parts.append(paragraph(
        f"Static intervals found (threshold {result.detection.threshold_factor:g} x the "
        f"initial variance magnitude{how}, window {result.detection.window} samples; "
        f"{result.detection.n_short} short quiet runs dropped):"))
    sec.parts.append(table_html(["#", "start [s]", "end [s]", "duration [s]",
                                 "calibrated mean |a| − g [mg]"], iv_rows))
    sec.parts.append(paragraph("Calibration: calibrated = matrix @ (raw - offset), SI units; "
                               "each entry ± its standard uncertainty (first order from those "
                               "of K, M and B)."))
    sec.parts.append(table_html(["triad row", "matrix 1", "matrix 2", "matrix 3",
                                 "offset [raw]", "matrix unit"],
                                result_calibration_rows(result)))
    for msg in result.messages:
        sec.parts.append(paragraph(msg, note=True))
    sec.parts.append(figure_html(orientation_free_figure(result), "static detection and checks"))
    return [sec]
