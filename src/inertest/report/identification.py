"""Tables of what a linear test determined: estimates, combinations, what it could not find."""

from __future__ import annotations

from collections.abc import Mapping

from inertest.report.html import Section, paragraph, table_html
from inertest.report.rounding import format_number, format_with_std
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


def coefficient_rows(
    ident: Identification, truth: Mapping[str, float] | None = None
) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the estimates (and truth, for simulated data)."""
    header = ["quantity", "estimate ± std", "unit"] + (["truth", "error/std"] if truth else [])
    rows = []
    for name, e in ident.coefficients.items():
        row = [name, fmt(e.value, e.std), e.unit]
        if truth is not None:
            t = float(truth.get(name, 0.0))
            row += [fmt(t, e.std), _z(e.value, t, e.std)]
        rows.append(row)
    for c in ident.combinations:
        row = [c.name, fmt(c.value, c.std), c.unit]
        if truth is not None:
            t = c.evaluate(truth)
            row += [fmt(t, c.std), _z(c.value, t, c.std)]
        rows.append(row)
    return header, rows


def identification_section(
    title: str, ident: Identification, truth: Mapping[str, float] | None = None
) -> Section:
    """Table of what the test determined, and what it could not, with reasons."""
    header, rows = coefficient_rows(ident, truth)
    sec = Section(title, [table_html(header, rows)])
    noise = (
        "Noise per reading estimated from the residuals: "
        f"{format_number(ident.noise_sigma)} "
        f"{ident.noise_unit} ({ident.dof} degrees of freedom, rank {ident.rank} of "
        f"{len(ident.names)})."
        if ident.sigma_from_residuals
        else f"Noise per reading given by the user; rank {ident.rank} of {len(ident.names)}."
    )
    sec.parts.append(paragraph(noise))
    for s in ident.not_separable:
        sec.parts.append(paragraph("Not determined: " + s, note=True))
    return sec
