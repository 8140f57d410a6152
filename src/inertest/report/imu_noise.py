"""Figures, tables and report sections of the whole-IMU noise analysis (``inertest noise``)."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.noise.identification import BOUND_DEFINITION
from inertest.noise.imu import ChannelNoise, ImuNoiseResult, KalibrTerm, TermComparison
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.rounding import format_number, format_with_std


def _fmt_term(t: KalibrTerm) -> str:
    if t.status == "fitted" and t.std is not None:
        return format_with_std(float(t.value), float(t.std))
    return f"< {format_number(t.value)} (bound at {format_number(t.tau_s)} s)"


def channel_figure(ch: ChannelNoise, comparisons: Sequence[TermComparison] = ()) -> Figure:
    """Allan deviation of one channel beside its one-sided PSD.

    Left: confidence bars, the fitted model (when it fits), the N and K lines (fitted or
    tangent bounds), claimed lines. Right: the Welch PSD and the white level 2 N^2.
    """
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.4))
    r = ch.oadev
    err = np.vstack([r.dev - r.dev_lo, r.dev_hi - r.dev])
    ax.errorbar(r.taus, r.dev, yerr=err, fmt="o", ms=3, lw=0.8, capsize=2, color="C0",
                label=f"oadev ({r.confidence:.1%} CI)")
    t = np.geomspace(r.taus[0], r.taus[-1], 200)
    if ch.model.fits:
        ax.plot(t, ch.model.model_dev(t), "k-", lw=1.2, label="fitted IEEE 952 model")
    n, k = ch.density, ch.random_walk
    ax.plot(t, n.value / np.sqrt(t), "--", color="C1", lw=1.0,
            label=f"N line ({n.status}): {n.value:.3g} {n.unit}")
    ax.plot(t, k.value * np.sqrt(t / 3.0), "--", color="C3", lw=1.0,
            label=f"K line ({k.status}): {k.value:.3g} {k.unit}")
    for c in comparisons:
        if c.channel != ch.name:
            continue
        line = (c.claimed / np.sqrt(t) if c.parameter.endswith("noise_density")
                else c.claimed * np.sqrt(t / 3.0))
        bad = c.verdict == "exceeds the claim" or c.consistency == "inconsistent with"
        ax.plot(t, line, ":", lw=1.4, color="C6" if bad else "C2",
                label=f"claimed {c.parameter.split('_', 1)[1]}: {c.verdict}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"overlapping Allan deviation [{ch.unit}]")
    ax.set_title(ch.name, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    bx.loglog(ch.psd_freq_hz, ch.psd, lw=0.7, color="C0", label="Welch PSD, one-sided")
    bx.axhline(2.0 * n.value**2, color="C1", ls="--", lw=1.0,
               label=f"2 N^2 (white level of the N line, {n.status})")
    bx.set_xlabel("frequency [Hz]")
    bx.set_ylabel(f"PSD [({ch.unit})^2/Hz]")
    bx.grid(alpha=0.3, which="both")
    bx.legend(fontsize=7)
    finish_figure(fig)
    return fig


def summary_rows(result: ImuNoiseResult) -> tuple[list[str], list[list[str]]]:
    """Per channel: Kalibr noise density and random walk, bias instability, fit verdict."""
    header = ["channel", "noise density N", "random walk K", "Kalibr units",
              "bias instability B", "five-term fit", "outliers"]
    rows = []
    for c in result.channels:
        b = c.model.terms["B"]
        b_txt = (format_with_std(float(b.value_eng or 0.0), b.std_eng, b.unit) if b.resolved
                 else f"< {format_number(b.upper_bound_eng)} {b.unit}")
        chi = format_number(c.model.chi2_per_dof)
        fit = (f"fits (chi2/dof {chi})" if c.model.fits else f"does not fit (chi2/dof {chi})")
        rows.append([c.name, _fmt_term(c.density), _fmt_term(c.random_walk),
                     f"{c.density.unit}; {c.random_walk.unit}", b_txt, fit, str(c.outliers)])
    return header, rows


def timing_rows(result: ImuNoiseResult) -> tuple[list[str], list[list[str]]]:
    """The time-stamp checks as a two-column table."""
    tm = result.timing
    a, b = tm.segment
    rows = [
        ["samples in the file", str(tm.n_samples)],
        ["time stamps", "yes" if tm.from_stamps else "none (equal spacing at the rate given)"],
        ["nominal interval", f"{format_number(tm.interval_s)} s "
                             f"({format_number(tm.rate_hz)} Hz)"],
        ["jitter (std of the intervals)", f"{format_number(tm.jitter_s, digits=2)} s"],
        ["gaps (missing samples)", f"{len(tm.gaps)} ({sum(g.missing for g in tm.gaps)} "
                                   "samples)" if tm.gaps else "0"],
        ["duplicated / non-increasing stamps", str(len(tm.non_increasing))],
        ["segment analysed", f"samples {a} to {b - 1} ({format_number(result.duration_s)} s)"],
        ["straight line removed", "yes" if result.detrended else "no"],
        ["outliers", f"{result.outlier_policy}, threshold "
                     f"{format_number(result.outlier_threshold)} robust sigmas from a running "
                     "median"],
    ]
    return ["check", "value"], rows


def comparison_rows(comparisons: Sequence[TermComparison]) -> tuple[list[str], list[list[str]]]:
    """Claimed parameters against the measured channels."""
    header = ["channel", "parameter", "claimed", "measured", "unit",
              "verdict (claim as a maximum)", "consistency (as the largest over the axes)"]
    rows = [[c.channel, c.parameter, format_number(c.claimed), _fmt_term(c.measured),
             c.measured.unit, c.verdict, c.consistency] for c in comparisons]
    return header, rows


def imu_noise_sections(result: ImuNoiseResult,
                       comparisons: Sequence[TermComparison] = ()) -> list[Section]:
    """Report sections: checks, summary, comparison, one figure per channel, conventions."""
    h, r = timing_rows(result)
    out = [Section("Record and time-stamp checks", [table_html(h, r)] + [
        paragraph(m, note=True) for m in result.messages])]
    h, r = summary_rows(result)
    out.append(Section("Noise per channel (Kalibr parameters, IEEE Std 952-1997 Annex C)", [
        table_html(h, r),
        paragraph("Noise density = angle (velocity) random walk N, the N/sqrt(tau) line at "
                  "tau = 1 s; random walk = rate (acceleration) random walk K, the "
                  "K sqrt(tau/3) line at tau = 3 s. A term the five-term fit does not resolve "
                  "(N, K or B) is given as an upper bound (< value), the same as in the "
                  f"IEEE 952 terms: {BOUND_DEFINITION}. The bias instability B is not the "
                  "random walk."),
    ]))
    if comparisons:
        h, r = comparison_rows(comparisons)
        out.append(Section("Claimed values against the record", [
            table_html(h, r), *[paragraph(f"{c.channel} {c.parameter}: {c.text}")
                                for c in comparisons]]))
    for c in result.channels:
        fig = channel_figure(c, comparisons)
        out.append(Section(f"{c.name}: Allan deviation and PSD", [
            figure_html(fig, f"{c.name}: overlapping Allan deviation and one-sided PSD"),
            paragraph(f"Fit: {c.model.verdict}.", note=not c.model.fits)]))
    out.append(Section("Conventions", [paragraph(
        "PSD one-sided (Welch, Hann window) in unit^2/Hz; IEEE Std 952-1997 Annex C uses the "
        "two-sided S = S1/2, so white rate noise has S1 = 2 N^2. Allan deviation overlapping, "
        "with chi-squared intervals (NIST SP 1065).")]))
    return out
