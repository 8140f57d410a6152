"""Figures of the rotation modulation studies.

Component level: stator rotation of a suspended gyro. System level: a rotating IMU in an INS.
"""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np

from inertest.ins.error_model import SIGN_CONVENTION
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.rounding import format_number
from inertest.studies.rotation_modulation import SystemRun
from inertest.studies.stator_modulation import ComponentStudy, ModulationRun, drift_gain
from inertest.units import (
    ARCSEC_TO_RAD,
    DEG_PER_H_TO_RAD_PER_S,
    HOUR_TO_S,
    MICRO_G_TO_M_PER_S2,
    NAUTICAL_MILE_M,
)


def component_figure(runs: Sequence[ModulationRun], *, drift_freqs_hz: np.ndarray | None = None):
    """Residual drift vs time, RMS residual vs stator rate, drift gain vs frequency, tracking."""
    k = DEG_PER_H_TO_RAD_PER_S
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    first = runs[0]
    a = ax[0, 0]
    fixed = first.residual_fixed[:, 0] / k
    scale = max(float(np.max(np.abs(fixed), initial=0.0)),
                float(np.max(np.abs(first.true_rate[:, 0]), initial=0.0)) / k)
    a.plot(first.t_out, clip_round_off(fixed, scale), label="no modulation (x)")
    a.plot(first.t_out, clip_round_off(first.residual_modulated[:, 0] / k, scale),
           label=f"stator at {first.stator_rate_rad_s / (2 * np.pi):g} Hz (x)")
    a.set_xlabel("time [s]")
    a.set_ylabel("rate error [deg/h]")
    a.set_title("Residual drift after the integral filter")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    b = ax[0, 1]
    F = np.array([r.stator_rate_rad_s / (2 * np.pi) for r in runs])
    without = np.array([r.rms(False) / k for r in runs])
    floor = PLOT_ROUND_OFF * float(np.max(without, initial=0.0))
    with_mod = clip_round_off(np.array([r.rms(True) / k for r in runs]), float(np.max(
        without, initial=0.0)))
    shown = with_mod > 0
    if shown.any():
        b.loglog(F[shown], with_mod[shown], "o-", label="with modulation")
    if (~shown).any() and floor > 0:  # round-off: drawn as an upper bound, not as a value
        b.loglog(F[~shown], np.full(int((~shown).sum()), floor), "v", color="C0", ms=8,
                 label=f"with modulation: 0 (round-off, < {format_number(floor, digits=1)} "
                       "deg/h)")
    b.loglog(F, without, "s--", color="C1", label="without")
    b.set_xlabel("stator rotation frequency [Hz]")
    b.set_ylabel("RMS residual [deg/h]")
    b.set_title("Residual drift vs stator rate")
    b.legend(fontsize=8)
    b.grid(alpha=0.3, which="both")
    c = ax[1, 0]
    Fs = F[0]
    nu = np.linspace(0, 3 * Fs, 600) if drift_freqs_hz is None else drift_freqs_hz
    g = drift_gain(nu, Fs)
    c.plot(nu, 0.5 * (g[:, 0] + g[:, 1]), label=f"with modulation (F = {Fs:g} Hz)")
    c.plot(nu, drift_gain(nu, 0.0)[:, 0], "--", label="without (same window)")
    c.set_xlabel("drift frequency in the stator frame [Hz]")
    c.set_ylabel("gain to the rate output")
    c.set_title("Drift spectrum → residual (closed form)")
    c.legend(fontsize=8)
    c.grid(alpha=0.3)
    d = ax[1, 1]
    true_x = first.true_rate[:, 0] / k
    d.plot(first.t_out, true_x, label="true house rate (window mean)")
    d.plot(first.t_out, first.estimate_modulated[:, 0] / k, ":", label="estimate")
    hold_round_off(d, np.r_[true_x, first.estimate_modulated[:, 0] / k])
    d.set_xlabel("time [s]")
    d.set_ylabel("house rate X [deg/h]")
    d.set_title(f"Tracking: delay {first.cost.delay_s:.3g} s, "
                f"bandwidth {first.cost.bandwidth_hz:.3g} Hz")
    d.legend(fontsize=8)
    d.grid(alpha=0.3)
    finish_figure(fig)
    return fig


def system_figure(runs: Sequence[SystemRun]):
    """INS errors of several rotation schemes on the same IMU: position [nmi], attitude [arcsec].

    Magnitudes on log axes, so that bounded (modulated) and growing (static) errors show on
    one plot.
    """
    fig, ax = plt.subplots(2, 3, figsize=(14, 7.5), sharex=True)
    panels = [
        (ax[0, 0], lambda r: r.horizontal_error_m / NAUTICAL_MILE_M, "horizontal position [nmi]"),
        (ax[0, 1], lambda r: r.north_error_m / NAUTICAL_MILE_M, "latitude error R dL [nmi]"),
        (ax[0, 2], lambda r: r.east_error_m / NAUTICAL_MILE_M,
         "longitude error R cosL dλ [nmi]"),
        (ax[1, 0], lambda r: r.x[:, 4] / ARCSEC_TO_RAD, "tilt φE [arcsec]"),
        (ax[1, 1], lambda r: r.x[:, 5] / ARCSEC_TO_RAD, "tilt φN [arcsec]"),
        (ax[1, 2], lambda r: r.x[:, 6] / ARCSEC_TO_RAD, "azimuth φU [arcsec]"),
    ]
    for a, value, title in panels:
        scale = max(float(np.max(np.abs(value(r)), initial=0.0)) for r in runs)
        for r in runs:
            v = clip_round_off(np.abs(value(r)), scale)
            a.semilogy(r.t / HOUR_TO_S, np.where(v > 0, v, np.nan), lw=1.0, label=r.scheme.label)
        a.set_title(f"|{title.split(' [')[0]}|")
        a.set_ylabel(title)
        a.grid(alpha=0.3, which="both")
    for a in ax[1]:
        a.set_xlabel("time [h]")
    ax[0, 0].legend(fontsize=8)
    lat = np.degrees(runs[0].site.latitude_rad)
    fig.suptitle(f"Static-base INS errors with and without IMU rotation (latitude {lat:g} deg; "
                 "vertical channel not modelled)")
    finish_figure(fig)
    return fig


#: Column headers of :func:`system_summary_rows`.
SYSTEM_SUMMARY_HEADER = ["scheme", "cycle [s]", "horizontal position [m]", "[nmi]",
                         "φE [arcsec]", "φN [arcsec]", "φU [arcsec]"]
#: Column headers of :func:`system_residual_rows`.
SYSTEM_RESIDUAL_HEADER = ["scheme", "bE [ug]", "bN [ug]", "eE [deg/h]", "eN [deg/h]",
                          "eU [deg/h]"]


def system_summary_rows(runs: Sequence[SystemRun]) -> list[list[str]]:
    """Per scheme: cycle, max horizontal position error, max attitude errors (engineering)."""
    rows = []
    for r in runs:
        s = r.summary()
        cyc = r.scheme.cycle_s
        rows.append([r.scheme.label, "-" if np.isinf(cyc) else format_number(float(cyc)),
                     format_number(float(s["max_horizontal_position_m"])),
                     format_number(float(s["max_horizontal_position_m"]) / NAUTICAL_MILE_M),
                     *(format_number(float(s[k]) / ARCSEC_TO_RAD)
                       for k in ("max_phiE_rad", "max_phiN_rad", "max_phiU_rad"))])
    return rows


def system_residual_rows(runs: Sequence[SystemRun]) -> list[list[str]]:
    """Per scheme: the equivalent constant errors it leaves (cycle means), ug and deg/h.

    A cycle mean below :data:`PLOT_ROUND_OFF` of its column's largest value (the unmodulated
    error) is the quadrature's round-off and printed as 0 (not -5.8e-17 deg/h or 6.1e-11 deg/h).
    """
    vals = np.array([np.r_[r.cycle_mean_inputs[:2] / MICRO_G_TO_M_PER_S2,
                           r.cycle_mean_inputs[2:] / DEG_PER_H_TO_RAD_PER_S] for r in runs])
    scale = np.max(np.abs(vals), axis=0, initial=0.0)
    return [[r.scheme.label, *(format_number(float(v), scale=float(s), digits=3,
                                             round_off=PLOT_ROUND_OFF)
                               for v, s in zip(row, scale, strict=True))]
            for r, row in zip(runs, vals, strict=True)]


#: Relative size below which a computed error (a cycle mean, a modulated residual) is round-off
#: of the quadrature and the filters: printed as 0 and not plotted as a "step".
PLOT_ROUND_OFF = 1e-8


def hold_round_off(ax, values: np.ndarray) -> None:
    """Axis limits that do not magnify round-off into a "step" (a constant drawn as constant).

    A curve whose spread is below :data:`PLOT_ROUND_OFF` of its magnitude gets limits of
    ±5 % about its mean, and the axis shows no offset (``1e-10 + 3.6e1``).
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return
    mid, mag = float(np.mean(v)), float(np.max(np.abs(v)))
    if mag > 0 and float(np.ptp(v)) < PLOT_ROUND_OFF * mag:
        ax.set_ylim(mid - 0.05 * mag, mid + 0.05 * mag)
    ax.ticklabel_format(axis="y", useOffset=False)


def component_rows(study: ComponentStudy) -> tuple[list[str], list[list[str]], list[str]]:
    """Header, rows and notes of the stator-modulation table (terminal and report alike).

    A residual below :data:`PLOT_ROUND_OFF` of the unmodulated one is the round-off of the
    quadrature and the integral filter: printed as 0, and a note says so (not 6.1e-11 deg/h).
    """
    header = ["stator [Hz]", "RMS residual [deg/h]", "no modulation [deg/h]", "delay [s]",
              "bandwidth [Hz]"]
    rows, zero = [], False
    for r in study.rows():
        scale = float(r["rms_residual_fixed_deg_h"])
        res = format_number(float(r["rms_residual_modulated_deg_h"]), scale=scale,
                            round_off=PLOT_ROUND_OFF)
        zero |= res == "0"
        rows.append([format_number(float(r["stator_hz"])), res, format_number(scale),
                     format_number(float(r["delay_s"])), format_number(float(r["bandwidth_hz"]))])
    notes = ([f"RMS residual 0: below the round-off of the integration ({PLOT_ROUND_OFF:g} of "
              "the unmodulated residual); whole-period integration cancels a drift fixed to "
              "the stator exactly."] if zero else [])
    return header, rows, notes


def clip_round_off(values: np.ndarray, scale: float) -> np.ndarray:
    """``values`` with entries below ``PLOT_ROUND_OFF * scale`` in magnitude set to 0."""
    v = np.asarray(values, dtype=float)
    return np.where(np.abs(v) < PLOT_ROUND_OFF * scale, 0.0, v)


def system_sections(runs: Sequence[SystemRun]) -> list[Section]:
    """HTML report sections of the system-level study: figure, error table, what is left."""
    hours = runs[0].t[-1] / HOUR_TO_S
    return [
        Section("Navigation errors with and without IMU rotation", [
            figure_html(system_figure(runs),
                        f"INS errors over {hours:g} h, same IMU errors for every scheme"),
            table_html(SYSTEM_SUMMARY_HEADER, system_summary_rows(runs)),
            paragraph("Static-base INS error equations (Source: Error propagation of an inertial "
                      "navigation system); the vertical channel is not "
                      "modelled, so the vertical accelerometer error does not enter.", note=True),
            paragraph(f"Sign convention: {SIGN_CONVENTION}.", note=True),
        ]),
        Section("What each scheme leaves", [
            table_html(SYSTEM_RESIDUAL_HEADER, system_residual_rows(runs)),
            paragraph("Mean navigation-frame error over one whole cycle: the equivalent constant "
                      "bias and drift the INS integrates as if the IMU were static (sensor "
                      "output errors in ENU: bE, bN enter dV' with +, eE, eN, eU enter phi' "
                      "with -). Rotation "
                      "cannot cancel errors along a single rotation axis, scale factor x "
                      "rotation rate unless the direction alternates, nor the trace of the gyro "
                      "scale-factor errors on the Earth rate."),
        ]),
    ]
