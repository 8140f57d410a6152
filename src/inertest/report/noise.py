"""Figure, tables and report sections of the Allan-family analysis (IEEE Std 952 noise terms)."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.noise.deviations import DeviationResult
from inertest.noise.identification import BOUND_DEFINITION, TERMS, NoiseModel
from inertest.report.figure_text import finish_figure
from inertest.report.html import Section, figure_html, paragraph, table_html
from inertest.report.rounding import format_number, format_with_std, round_to_uncertainty

_TERM_STYLE = {"Q": "C4", "N": "C1", "B": "C2", "K": "C3", "R": "C5"}


#: Unit of TDEV (a time deviation: the rate unit times seconds; deg/h x s = 1 arcsec) by the
#: rate unit of the other deviations.
TDEV_UNITS = {"rad/s": "rad", "deg/s": "deg", "deg/h": "arcsec", "arcsec/s": "arcsec",
              "m/s^2": "m/s", "1": "s"}


def tdev_unit(rate_unit: str) -> str:
    """The unit TDEV is in when the other deviations are in ``rate_unit`` (TDEV = tau x ...)."""
    return TDEV_UNITS.get(rate_unit, f"{rate_unit}*s")


def allan_figure(
    results: Mapping[str, DeviationResult], model: NoiseModel | None = None, *,
    unit: str = "rad/s", title: str = "", scale: float = 1.0,
) -> Figure:
    """Log-log deviations with confidence bars, the fitted model and each term's asymptote.

    ``results`` are in ``unit``; the model is in SI and multiplied by ``scale`` (SI to
    ``unit``) before it is drawn. TDEV (a time deviation, in ``unit`` x s:
    :func:`tdev_unit`) is drawn on an axis of its own, labelled with its unit, never on the
    rate deviations' axis.
    """
    rates = {k: r for k, r in results.items() if k != "tdev"}
    tdev = results.get("tdev")
    panels = int(bool(rates) or model is not None) + int(tdev is not None)
    fig, axes = plt.subplots(1, panels, figsize=(8 if panels == 1 else 12.5, 5.6),
                             squeeze=False)
    ax = axes[0, 0]
    if rates or model is not None:
        _draw_deviations(ax, rates, model, scale=scale)
        ax.set_ylabel(f"deviation [{unit}]")
        if title:
            ax.set_title(title, fontsize=10)
    if tdev is not None:
        at = axes[0, -1]
        _draw_deviations(at, {"tdev": tdev}, None, scale=scale, first_colour=len(rates))
        at.set_ylabel(f"time deviation TDEV [{tdev_unit(unit)}]")
        at.set_title("TDEV (rate deviation × τ/√3 for white noise)", fontsize=10)
    finish_figure(fig)
    return fig


def _draw_deviations(ax, results: Mapping[str, DeviationResult], model: NoiseModel | None, *,
                     scale: float, first_colour: int = 0) -> None:
    """Deviations with their intervals on log-log axes, and the fitted model with its terms."""
    for i, (name, r) in enumerate(results.items(), first_colour):
        err = np.vstack([r.dev - r.dev_lo, r.dev_hi - r.dev])
        ax.errorbar(r.taus, r.dev, yerr=err, fmt="o", ms=3, lw=0.8, capsize=2,
                    color=f"C{i if i < 1 else i + 5}", label=f"{name} ({r.confidence:.1%} CI)")
    if model is not None:
        t = np.geomspace(model.taus[0], model.taus[-1], 200)
        label = "fitted IEEE 952 model" + ("" if model.fits else " (does not fit)")
        ax.plot(t, scale * model.model_dev(t), "k-", lw=1.4, label=label)
        for term in TERMS:
            nt = model.terms[term]
            if not nt.resolved:
                continue
            label = f"{term}: {format_with_std(float(nt.value_eng or 0.0), nt.std_eng, nt.unit)}"
            ax.plot(t, scale * model.model_dev(t, term), "--", lw=1.0, color=_TERM_STYLE[term],
                    label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time tau [s]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)


def _dev_cell(dev: float, lo: float, hi: float, n: int) -> str:
    """``dev [lo, hi] (n)``, all three at the decimal of the interval's nearer half-width.

    The half-width (about one std for the 68 % interval) to two significant digits sets the
    decimal (GUM 7.2.6); a degenerate interval leaves four significant digits.
    """
    w = min(float(dev) - float(lo), float(hi) - float(dev))
    u = w if w > 0 and np.isfinite(w) else None
    cells = [round_to_uncertainty(float(x), u)[0] for x in (dev, lo, hi)]
    return f"{cells[0]} [{cells[1]}, {cells[2]}] ({n})"


def deviation_rows(results: Mapping[str, DeviationResult], unit: str | None = None
                   ) -> tuple[list[str], list[list[str]]]:
    """Table: tau, then each statistic's deviation with its interval and terms.

    With ``unit`` (the rate deviations' unit) each column header names its unit (TDEV's is
    :func:`tdev_unit`).
    """
    names = list(results)

    def head(n: str) -> str:
        u = "" if unit is None else f" [{tdev_unit(unit) if n == 'tdev' else unit}]"
        return f"{n}{u} value [lo, hi] (n)"

    header = ["tau [s]"] + [head(n) for n in names]
    taus = sorted({float(t) for r in results.values() for t in r.taus})
    rows = []
    for t in taus:
        row = [format_number(t, digits=6)]
        for n in names:
            r = results[n]
            hit = np.flatnonzero(np.isclose(r.taus, t, rtol=1e-12))
            if hit.size:
                i = int(hit[0])
                row.append(_dev_cell(r.dev[i], r.dev_lo[i], r.dev_hi[i], r.n[i]))
            else:
                row.append("")
        rows.append(row)
    return header, rows


def noise_rows(model: NoiseModel) -> tuple[list[str], list[list[str]]]:
    """Table of the five terms: value ± std in engineering units, or an upper bound."""
    header = ["term", "value", "std", "unit", "status"]
    rows = []
    for k, t in model.terms.items():
        if t.resolved:
            rows.append([f"{k} {t.description}",
                         *round_to_uncertainty(float(t.value_eng or 0.0), float(t.std_eng or 0.0)),
                         t.unit,
                         "resolved"])
        else:
            rows.append([f"{k} {t.description}", f"< {format_number(t.upper_bound_eng)}", "",
                         t.unit,
                         t.note])
    return header, rows


def allan_sections(
    results: Mapping[str, DeviationResult], model: NoiseModel | None, *, unit: str = "rad/s",
    scale: float = 1.0,
) -> list[Section]:
    """Report sections: figure, noise terms (with the fit verdict), deviation table."""
    fig = allan_figure(results, model, unit=unit, scale=scale)
    out = [Section("Allan-family deviations", [figure_html(fig, "deviations with confidence "
                                                                 "intervals; fitted model")])]
    plt.close(fig)
    if model is not None:
        h, r = noise_rows(model)
        out.append(Section("Noise terms (IEEE Std 952-1997 Annex C)", [
            table_html(h, r),
            paragraph(f"Fit: {model.verdict}.", note=not model.fits),
            paragraph("A term is reported only when it is significant and the largest term "
                      "somewhere on the tau range; otherwise only its upper bound is known "
                      f"(< value). Upper bound: {BOUND_DEFINITION}.", note=True),
        ]))
    h, r = deviation_rows(results, unit)
    out.append(Section("Deviations (NIST SP 1065 conventions)", [table_html(h, r)]))
    return out
