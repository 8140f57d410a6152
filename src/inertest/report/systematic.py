"""Report section of the systematic calibration of a strapdown IMU (navigation mode)."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.procedures.systematic import SystematicResult
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import identification_section


def systematic_figure(result: SystematicResult) -> Figure:
    """Calibrated navigation velocity error over the run, the dwells' observations marked."""
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    t = result.velocity_time_s
    for k, (ax, name) in enumerate(zip(axes, ("east", "north", "up"), strict=True)):
        ax.plot(t, result.velocity_m_s[:, k] * 1e3, lw=0.7, color="C0",
                label="calibrated navigation")
        for d in result.dwells:
            ax.axvspan(d.start_s, d.end_s, color="C2", alpha=0.12, lw=0)
            ax.plot(d.time_s, d.residual_m_s[:, k] * 1e3, "o", ms=2.5, color="C3")
        ax.set_ylabel(f"{name} [mm/s]")
        ax.grid(alpha=0.3)
    axes[0].set_title("velocity error of the calibrated navigation (dwells green, observations "
                      "red)", fontsize=9)
    axes[-1].set_xlabel("time [s]")
    finish_figure(fig)
    return fig


def systematic_sections(result: SystematicResult, truth: Mapping[str, float] | None = None, *,
                        title: str) -> list[Section]:
    """The estimates, the sequence as found, each dwell's residuals, PSINS's structs, a figure."""
    sec = identification_section(f"{title}: every error term of the strapdown IMU",
                                 result.identification, truth)
    sec.parts.append(paragraph(
        "Navigation-mode calibration: the unit navigates at the site through the whole run; "
        "its velocity error during the dwells (zero for the right model) is fitted by "
        f"Gauss-Newton ({result.iterations} iterations) with the covariance of the sensors' "
        "noise propagated through the navigation equations."))
    rows = []
    for k, tc in enumerate(result.turns):
        planned = "-" if tc.planned is None else f"{tc.planned[0]} {tc.planned[1]:+g} deg"
        rows.append([str(k + 1), float(tc.start_s), float(tc.end_s), *(
            float(v) for v in tc.rotation_deg), planned])
    sec.parts.append(paragraph("The sequence as the gyros measured it (integrated rates on "
                               "the body axes), against the plan:"))
    sec.parts.append(table_html(["turn", "start [s]", "end [s]", "x [deg]", "y [deg]",
                                 "z [deg]", "plan"], rows))
    drows = [[str(k + 1), float(d.start_s), float(d.end_s), str(d.time_s.size),
              *(float(v) * 1e3 for v in d.rms_m_s)] for k, d in enumerate(result.dwells)]
    sec.parts.append(paragraph("Residual velocity error of each dwell's observations after "
                               "calibration (rms):"))
    sec.parts.append(table_html(["dwell", "from [s]", "to [s]", "observations", "east [mm/s]",
                                 "north [mm/s]", "up [mm/s]"], drows))
    ps = result.psins()["sysclbt"]
    prow = []
    for key in ("Kg", "Ka"):
        m = (np.asarray(ps[key]) - np.eye(3)) * 1e6
        for i in range(3):
            prow.append([f"{key} - I, row {i + 1}", *(f"{v:.4g}" for v in m[i]), "1e-6"])
    for key, unit in (("eb", "deg/h"), ("db", "ug (PSINS)"), ("Ka2", "ug/g^2 (PSINS)"),
                      ("rx", "m"), ("ry", "m")):
        prow.append([key, *(f"{v:.6g}" for v in np.asarray(ps[key])), unit])
    prow.append(["tGA", f"{float(ps['tGA']):.6g}", "", "", "s"])  # type: ignore[arg-type]
    sec.parts.append(paragraph("The same estimate as PSINS's correction struct (kf/sysclbt.m: "
                               "wm = Kg wm - eb ts, vm = Ka vm - (db + Ka2 fb^2 + fL + tGA wb x "
                               "fb) ts):"))
    sec.parts.append(table_html(["PSINS", "1", "2", "3", "unit"], prow))
    for msg in result.messages:
        sec.parts.append(paragraph(msg, note=True))
    sec.parts.append(figure_html(
        systematic_figure(result),
        "velocity error of the calibrated navigation: a free navigation drifts with the gyros' "
        "angle random walk and its heading's error; the fit weights the observations by that "
        "covariance (the model checks test what is left)"))
    return [sec]
