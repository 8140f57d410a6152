"""Figures and report sections of the static-base INS error propagation (seed 002)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from inertest.ins.error_model import SIGN_CONVENTION, STATES
from inertest.ins.propagation import SOURCES, CharacteristicPeriods, SourceResponses
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.rounding import format_number
from inertest.units import ARCMIN_TO_RAD, ARCSEC_TO_RAD, HOUR_TO_S

if TYPE_CHECKING:  # sympy is slow to import; only the closed-form table needs it
    from inertest.ins.closed_forms import ClosedForms

#: Display unit of each state: (label, factor SI -> unit).
DISPLAY_UNITS: dict[str, tuple[str, float]] = {
    "dVE": ("m/s", 1.0),
    "dVN": ("m/s", 1.0),
    "dL": ("arcmin", 1.0 / ARCMIN_TO_RAD),
    "dlambda": ("arcmin", 1.0 / ARCMIN_TO_RAD),
    "phiE": ("arcsec", 1.0 / ARCSEC_TO_RAD),
    "phiN": ("arcsec", 1.0 / ARCSEC_TO_RAD),
    "phiU": ("arcmin", 1.0 / ARCMIN_TO_RAD),
}
_TITLES = {
    "dVE": "east velocity error dVE",
    "dVN": "north velocity error dVN",
    "dL": "latitude error dL",
    "dlambda": "longitude error dlambda",
    "phiE": "east attitude error phiE",
    "phiN": "north attitude error phiN",
    "phiU": "azimuth error phiU",
}


def responses_figure(
    resp: SourceResponses,
    *,
    sigma: NDArray[np.float64] | None = None,
    title: str = "",
) -> Figure:
    """Seven panels (one per state) against time [h]: one curve per active source.

    The combined response is black; when ``sigma`` is given, the +-1 sigma envelope of the
    random sources is a grey band around zero.

    Parameters
    ----------
    resp : SourceResponses
        From :func:`inertest.ins.propagation.source_responses`.
    sigma : ndarray, shape (n, 7), optional
        1-sigma of each state from the random sources at the same times, SI.
    title : str
        Figure title.
    """
    th = resp.t / HOUR_TO_S
    fig, axes = plt.subplots(4, 2, figsize=(12, 12), sharex=True)
    flat = axes.ravel()
    colours = plt.get_cmap("tab20").colors  # type: ignore[attr-defined]
    for i, st in enumerate(STATES):
        ax = flat[i]
        unit, k = DISPLAY_UNITS[st]
        for j, src in enumerate(resp.sources):
            if resp.active[j]:
                ax.plot(th, resp.per_source[j, :, i] * k, lw=0.9, label=src,
                        color=colours[(2 * j) % 20 + (2 * j) // 20])
        ax.plot(th, resp.combined[:, i] * k, color="k", lw=1.6, label="combined")
        if sigma is not None:
            ax.fill_between(th, -sigma[:, i] * k, sigma[:, i] * k, color="0.6", alpha=0.35,
                            lw=0, label="±1σ random")
        ax.set_title(_TITLES[st], fontsize=10)
        ax.set_ylabel(f"[{unit}]")
        ax.grid(alpha=0.3)
    for ax in (flat[5], flat[6]):
        ax.xaxis.set_tick_params(labelbottom=True)
        ax.set_xlabel("time [h]")
    leg_ax = flat[7]
    leg_ax.axis("off")
    handles, labels = flat[0].get_legend_handles_labels()
    leg_ax.legend(handles, labels, loc="center", ncol=2, fontsize=9, title="error source")
    if title:
        fig.suptitle(title)
    finish_figure(fig)
    return fig


def periods_rows(periods: CharacteristicPeriods) -> list[list[str]]:
    """Table rows ``[name, from eigenvalues, closed form]`` with periods in minutes/hours."""
    rows = [["Schuler", f"{format_number(periods.schuler_s / 60)} min", "2π/√(ω_s² + ω_f²)"]]
    if periods.foucault_s is not None:
        rows.append(["Foucault", f"{format_number(periods.foucault_s / HOUR_TO_S)} h",
                     "2π/(W |sin L|)"])
    if math.isfinite(periods.earth_s):
        rows.append(["Earth", f"{format_number(periods.earth_s / 60)} min", "2π/W"])
    for p in periods.modes_s:
        rows.append(["mode", f"{format_number(float(p) / 60)} min", "eigenvalue of A"])
    return rows


def final_rows(resp: SourceResponses) -> list[list[str]]:
    """Each state at the last sample, per active source and combined, in display units."""
    # Exact zeros (e.g. no cross-channel coupling without Coriolis) come out as rounding noise
    # ~1e-16 of the largest response of that state; print them as 0.
    floor = 1e-11 * np.abs(resp.per_source).max(axis=(0, 1))
    rows = []
    for j, src in [*enumerate(resp.sources), (-1, "combined")]:
        if j >= 0 and not resp.active[j]:
            continue
        x = resp.combined[-1] if j < 0 else resp.per_source[j, -1]
        x = np.where(np.abs(x) <= floor, 0.0, x)
        rows.append([src, *(format_number(float(x[i] * DISPLAY_UNITS[st][1]))
                            for i, st in enumerate(STATES))])
    return rows


def closed_form_rows(
    forms: ClosedForms,
    c0: NDArray[np.float64],
    c1: NDArray[np.float64],
    fitted: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    active: Sequence[bool],
) -> list[list[str]]:
    """``[state, source, constant, secular, value, fitted]`` rows (display units, per hour).

    ``c0, c1`` (12, 7) are the closed forms evaluated for the scenario; ``fitted`` the same
    parts fitted to the numerical solution (or ``None`` when the run is too short).
    """
    rows = []
    for st, src, e0, e1 in forms.rows():
        j, i = SOURCES.index(src), STATES.index(st)
        if not active[j]:
            continue
        unit, k = DISPLAY_UNITS[st]
        secular = c1[j, i] != 0
        val = _part(c0[j, i] * k, c1[j, i] * k * HOUR_TO_S, unit, secular)
        fit = "—"
        if fitted is not None:
            fit = _part(fitted[0][j, i] * k, fitted[1][j, i] * k * HOUR_TO_S, unit, secular)
        rows.append([st, src, e0, e1, val, fit])
    return rows


def _part(c0: float, c1_per_h: float, unit: str, secular: bool) -> str:
    if not secular:
        return f"{format_number(float(c0))} {unit}"
    return (f"{format_number(float(c1_per_h))} {unit}/h × t"
            + (f" + {format_number(float(c0))} {unit}" if abs(c0) > 1e-9 else ""))


def ins_error_sections(
    resp: SourceResponses,
    periods: CharacteristicPeriods,
    *,
    closed_form_table: list[list[str]] | None = None,
    sigma: NDArray[np.float64] | None = None,
    title: str = "INS error propagation (static base)",
) -> list[Section]:
    """Report sections: the 7-panel figure, the periods, final errors and the closed forms."""
    fig = responses_figure(resp, sigma=sigma)
    units = ", ".join(f"{st} [{DISPLAY_UNITS[st][0]}]" for st in STATES)
    sections = [
        Section(title, [figure_html(fig, "Error response per source and combined"),
                        paragraph(f"Exact solution of the linear error equations; {units}."),
                        paragraph(f"Sign convention: {SIGN_CONVENTION}.", note=True)]),
        Section("Characteristic periods",
                [table_html(["period", "value", "closed form"], periods_rows(periods))]),
        Section("Errors at the end of the run",
                [table_html(["source", *(f"{st} [{DISPLAY_UNITS[st][0]}]" for st in STATES)],
                            final_rows(resp))]),
    ]
    if closed_form_table is not None:
        sections.append(Section(
            "Constant and secular parts (final value theorem)",
            [paragraph("x(t) = constant + secular·t + oscillations at the natural periods. "
                       "Expressions in g, R, W, L (SI); 'fitted' is the same part fitted to the "
                       "numerical solution."),
             table_html(["state", "source", "constant", "secular [1/s]", "value", "fitted"],
                        closed_form_table, left_columns=4)]))
    return sections
