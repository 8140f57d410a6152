"""Figure, tables and report sections of the Allan-family analysis (IEEE Std 952 noise terms)."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from inertest.noise.deviations import DeviationResult
from inertest.noise.identification import TERMS, NoiseModel
from inertest.report.html import Section, figure_html, paragraph, table_html

_TERM_STYLE = {"Q": "C4", "N": "C1", "B": "C2", "K": "C3", "R": "C5"}


def allan_figure(
    results: Mapping[str, DeviationResult], model: NoiseModel | None = None, *,
    unit: str = "rad/s", title: str = "", scale: float = 1.0,
) -> Figure:
    """Log-log deviations with confidence bars, the fitted model and each term's asymptote.

    ``results`` are in ``unit``; the model is in SI and multiplied by ``scale`` (SI to
    ``unit``) before it is drawn.
    """
    fig, ax = plt.subplots(figsize=(8, 5.6))
    for i, (name, r) in enumerate(results.items()):
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
            label = f"{term}: {nt.value_eng:.3g} ± {nt.std_eng:.2g} {nt.unit}"
            ax.plot(t, scale * model.model_dev(t, term), "--", lw=1.0, color=_TERM_STYLE[term],
                    label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"deviation [{unit}]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def deviation_rows(results: Mapping[str, DeviationResult]) -> tuple[list[str], list[list[str]]]:
    """Table: tau, then each statistic's deviation with its interval and terms."""
    names = list(results)
    header = ["tau [s]"] + [f"{n}  [lo, hi]  (n)" for n in names]
    taus = sorted({float(t) for r in results.values() for t in r.taus})
    rows = []
    for t in taus:
        row = [f"{t:.6g}"]
        for n in names:
            r = results[n]
            hit = np.flatnonzero(np.isclose(r.taus, t, rtol=1e-12))
            if hit.size:
                i = int(hit[0])
                row.append(f"{r.dev[i]:.5e} [{r.dev_lo[i]:.3e}, {r.dev_hi[i]:.3e}] ({r.n[i]})")
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
            rows.append([f"{k} {t.description}", f"{t.value_eng:.4g}", f"{t.std_eng:.2g}",
                         t.unit, "resolved"])
        else:
            rows.append([f"{k} {t.description}", f"< {t.upper_bound_eng:.3g}", "", t.unit,
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
                      "somewhere on the tau range; otherwise only its upper bound is known.",
                      note=True),
        ]))
    h, r = deviation_rows(results)
    out.append(Section("Deviations (NIST SP 1065 conventions)", [table_html(h, r)]))
    return out
