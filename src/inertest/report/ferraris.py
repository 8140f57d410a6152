"""Figure and report section of the Ferraris calibration (six faces, three turns)."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.equipment.ferraris_session import FACE_LABELS, TURN_LABELS
from inertest.models.triad import AXES
from inertest.procedures.ferraris import FACE_GRAVITY_TOLERANCE_M_S2, FerrarisResult
from inertest.report.calibration import result_calibration_rows
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.identification import identification_section
from inertest.report.rounding import format_number
from inertest.units import MILLI_G_TO_M_PER_S2

_OFF = [(i, k) for i in range(3) for k in range(3) if i != k]


def ferraris_figure(result: FerrarisResult) -> Figure:
    """Calibrated |a| - g per face, and the face-pair tilt disagreement (the residuals)."""
    fig, (ax, axr) = plt.subplots(1, 2, figsize=(9, 3.4))
    err = result.face_gravity_error_m_s2 / MILLI_G_TO_M_PER_S2
    ax.bar(FACE_LABELS, err, color="C0")
    tol = FACE_GRAVITY_TOLERANCE_M_S2 / MILLI_G_TO_M_PER_S2
    if np.abs(err).max() > 0.2 * tol:
        for s in (-tol, tol):
            ax.axhline(s, color="C3", lw=0.8, ls="--")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_ylabel("calibrated |a| - g [mg]")
    ax.set_title("static faces after calibration", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    accelerometer = result.calibration.accelerometer
    assert accelerometer is not None  # Ferraris always calibrates the accelerometers
    si_per_raw = np.diag(accelerometer.matrix)  # (m/s^2) per raw unit
    labels = [f"{AXES[i]}-pair, {AXES[j]}" for i, j in _OFF]
    resid_mg = np.array([result.residual_output[n] * si_per_raw[j] / MILLI_G_TO_M_PER_S2
                         for n, (_, j) in enumerate(_OFF)])
    axr.bar(labels, resid_mg, color="C1")
    axr.axhline(0, color="k", lw=0.6)
    axr.set_ylabel("off-axis pair sum [mg]")
    axr.set_title(f"face tilt disagreement (tilt scatter {result.tilt_scatter_deg:.2f} deg)",
                  fontsize=9)
    axr.tick_params(axis="x", labelrotation=45, labelsize=7)
    axr.grid(alpha=0.3, axis="y")
    finish_figure(fig)
    return fig


def ferraris_sections(
    result: FerrarisResult, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Coefficients, calibration matrices, checks and the figure."""
    sec = identification_section(f"{title}: scale factors, misalignments, biases",
                                 result.identification, truth)
    sec.parts.append(paragraph(
        "Calibration: calibrated = matrix @ (raw - offset) (gyroscope: raw - g_sensitivity @ "
        "a_calibrated - offset), in SI units; each entry ± its standard uncertainty (first "
        "order from those of K, M and B)."))
    sec.parts.append(table_html(["triad row", "matrix 1", "matrix 2", "matrix 3", "offset [raw]",
                                 "matrix unit"], result_calibration_rows(result)))
    turns = [[lab, *(float(v) for v in result.turn_angle_deg[j])]
             for j, lab in enumerate(TURN_LABELS)]
    sec.parts.append(table_html(["turn", "about x [deg]", "about y [deg]", "about z [deg]"],
                                turns))
    sec.parts.append(paragraph(
        f"Each turn integrates (with the calibration) to {result.rotation_deg:g} deg about its "
        "own axis by construction; the static faces' |a| - g and the off-axis face-pair sums "
        "(how much the two faces of each pair were tilted differently) are the independent "
        "checks. Biases use only the faces where the axis is vertical (tilt enters to second "
        "order); the face tilt scatter is included in the misalignment uncertainty."))
    c = result.identification.checks
    if c is not None:
        rows = [[c.name, c.verdict, format_number(float(c.chi_square)), str(c.dof),
                 "" if c.p_value is None else format_number(float(c.p_value), digits=2),
                 ", ".join(f"{o.label} (z = {o.z:+.1f})" for o in c.outliers) or "none"]]
        sec.parts.append(table_html(["check", "verdict", "chi-square", "dof", "p", "outliers"],
                                    rows))
        if not c.fits:
            sec.parts.append(paragraph(
                "The session does not fit its noise model: check the face and turn labels, the "
                "plan's face_tilt_deg and the noise model; the uncertainties are not reliable.",
                note=True))
    for m in result.messages:
        sec.parts.append(paragraph(m, note=True))
    sec.parts.append(figure_html(ferraris_figure(result), "face checks"))
    return [sec]
