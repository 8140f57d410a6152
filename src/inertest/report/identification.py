"""Tables of what a linear test determined: estimates, combinations, what it could not find."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from inertest.report.html import Section, paragraph, table_html
from inertest.report.rounding import format_number, format_with_std, round_to_uncertainty
from inertest.results import Identification


def fmt(value: float, std: float | None = None) -> str:
    """``value ± std``, rounded by :func:`~inertest.report.rounding.round_to_uncertainty`.

    The std to two significant digits and the value to the same decimal (GUM 7.2.6); zero to
    the rounding is printed as zero; without a std, four significant digits.
    """
    return format_with_std(float(value), None if std is None else float(std))


def _z(value: float, truth: float, std: float) -> str:
    """(estimate - truth)/std to two decimals (a test statistic, not a measured value)."""
    return f"{(value - truth) / std:+.2f}" if std > 0 else "-"


def _at(value: float, std: float) -> str:
    """``value`` rounded at the decimal of ``std`` (GUM 7.2.6), without the std."""
    return round_to_uncertainty(float(value), float(std))[0]


def coefficient_rows(
    ident: Identification, truth: Mapping[str, float] | None = None
) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the estimates (and truth, for simulated data).

    The truth is an exact number: it is printed at the decimal of the estimate's std (to
    compare the two digit by digit), without a ``± std`` of its own.
    """
    header = ["quantity", "estimate ± std", "unit"] + (["truth", "error/std"] if truth else [])
    rows = []
    for name, e in ident.coefficients.items():
        row = [name, fmt(e.value, e.std), e.unit]
        if truth is not None:
            t = float(truth.get(name, 0.0))
            row += [_at(t, e.std), _z(e.value, t, e.std)]
        rows.append(row)
    for c in ident.combinations:
        row = [c.name, fmt(c.value, c.std), c.unit]
        if truth is not None:
            t = c.evaluate(truth)
            row += [_at(t, c.std), _z(c.value, t, c.std)]
        rows.append(row)
    return header, rows


#: How each noise component is described (its std, per reading or per position).
_COMPONENT_TEXT = {
    "white": "white noise per reading",
    "position offset": "offset per position",
    "random walk": "random-walk step per reading",
    "flicker": "flicker per reading",
}


def noise_model_text(ident: Identification) -> str:
    """One sentence naming the noise model behind the uncertainties and its fitted parts.

    E.g. ``noise model: position-offsets (auto, Akaike weight 0.97; flicker 0.03): white
    noise per reading 1.9 count (from the residuals), offset per position 3.6e3 count``.
    """
    model = ident.noise_model
    w = dict(ident.noise_model_weights)
    how = ""
    if w:
        top = max(w.values())
        others = sorted((m for m in w if m != model and w[m] >= 0.01),
                        key=lambda m: -w[m])
        close = [m for m in others if w[m] >= np.exp(-1.0) * top]
        how = f" (auto, Akaike weight {w.get(model, top):.2f}"
        if others:
            how += "; " + ", ".join(f"{m} {w[m]:.2f}" for m in others)
        if close:
            how += f"; the spread of the estimates under {', '.join(close)} is in the std"
        how += ")"
    parts = []
    for k, v in ident.noise_components.items():
        if v is None or not np.isfinite(v):
            continue
        text = f"{_COMPONENT_TEXT.get(k, k)} {format_number(float(v))} {ident.noise_unit}"
        if k == "white":
            text += (f" (from the residuals, {ident.dof} dof)" if model == "white"
                     and ident.sigma_from_residuals else " (from the residuals)"
                     if ident.sigma_from_residuals else " (given)")
        parts.append(text)
    if not parts and np.isfinite(ident.noise_sigma):
        parts.append(f"{_COMPONENT_TEXT['white']} {format_number(ident.noise_sigma)} "
                     f"{ident.noise_unit}" + (f" (from the residuals, {ident.dof} dof)"
                                              if ident.sigma_from_residuals else " (given)"))
    return f"noise model: {model}{how}" + (": " + ", ".join(parts) if parts else "")


def misfit_notes(doc: Mapping[str, object]) -> list[str]:
    """The warnings of the envelope's checks whose model does not fit (one per check)."""
    checks = doc.get("checks")
    if not isinstance(checks, list):
        return []
    return [str(c["message"]) for c in checks
            if isinstance(c, Mapping) and c.get("message")
            and c.get("verdict") not in ("consistent", "ok")]


def identification_section(
    title: str, ident: Identification, truth: Mapping[str, float] | None = None
) -> Section:
    """Table of what the test determined, and what it could not, with reasons."""
    header, rows = coefficient_rows(ident, truth)
    sec = Section(title, [table_html(header, rows)])
    noise = noise_model_text(ident)
    sec.parts.append(paragraph(f"{noise[0].upper()}{noise[1:]}; rank {ident.rank} of "
                               f"{len(ident.names)}."))
    for s in ident.not_separable:
        sec.parts.append(paragraph("Not determined: " + s, note=True))
    return sec
