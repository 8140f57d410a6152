"""Figures of the stator rotation modulation study."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np

from inertest.analysis.stator_modulation import ModulationRun, drift_gain
from inertest.units import DEG_PER_H_TO_RAD_PER_S


def component_figure(runs: Sequence[ModulationRun], *, drift_freqs_hz: np.ndarray | None = None):
    """Residual drift vs time, RMS residual vs stator rate, drift gain vs frequency, tracking."""
    k = DEG_PER_H_TO_RAD_PER_S
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    first = runs[0]
    a = ax[0, 0]
    a.plot(first.t_out, first.residual_fixed[:, 0] / k, label="no modulation (x)")
    a.plot(first.t_out, first.residual_modulated[:, 0] / k,
           label=f"stator at {first.stator_rate_rad_s / (2 * np.pi):g} Hz (x)")
    a.set_xlabel("time [s]")
    a.set_ylabel("rate error [deg/h]")
    a.set_title("Residual drift after the integral filter")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    b = ax[0, 1]
    F = np.array([r.stator_rate_rad_s / (2 * np.pi) for r in runs])
    b.loglog(F, [r.rms(True) / k for r in runs], "o-", label="with modulation")
    b.loglog(F, [r.rms(False) / k for r in runs], "s--", label="without")
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
    d.plot(first.t_out, first.true_rate[:, 0] / k, label="true house rate (window mean)")
    d.plot(first.t_out, first.estimate_modulated[:, 0] / k, ":", label="estimate")
    d.set_xlabel("time [s]")
    d.set_ylabel("house rate X [deg/h]")
    d.set_title(f"Tracking: delay {first.cost.delay_s:.3g} s, "
                f"bandwidth {first.cost.bandwidth_hz:.3g} Hz")
    d.legend(fontsize=8)
    d.grid(alpha=0.3)
    fig.tight_layout()
    return fig
