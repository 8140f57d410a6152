"""Generic identification of a linear error model: least squares -> what the data determine.

Every static error model in inertest is linear in its coefficients (DESIGN.md). A procedure
builds the design ``A`` (SI) and observations, then calls :func:`identify`, which solves by
weighted least squares and expresses the result in engineering units: individually identifiable
coefficients, a basis of identifiable combinations of the rest, and the null space in words.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.estimation.least_squares import (
    LinearFit,
    identifiable_combinations,
    weighted_least_squares,
)
from inertest.results import Combination, Estimate, Identification

#: Explains the null space of a fit in words: (fit, design) -> statements.
Explainer = Callable[[LinearFit, NDArray[np.float64]], Sequence[str]]


def identify(
    A: ArrayLike,
    y: ArrayLike,
    *,
    names: Sequence[str],
    units: Mapping[str, str],
    si_per_unit: Mapping[str, float],
    noise_unit: str,
    si_per_noise_unit: float,
    sigma_si: float | ArrayLike | None = None,
    pivot_order: Sequence[str] = (),
    normalize_to: str | None = None,
    explain: Explainer | None = None,
) -> tuple[LinearFit, Identification]:
    """Solve ``y = A x`` and report what the data determine, in engineering units.

    Parameters
    ----------
    A : array_like, shape (n, p)
        Design in SI (columns in the order of ``names``).
    y : array_like, shape (n,)
        Observations in SI.
    names : sequence of str
        Coefficient names.
    units : mapping
        Engineering unit of each coefficient.
    si_per_unit : mapping
        SI value of one engineering unit of each coefficient (value_eng = value_si / factor).
    noise_unit, si_per_noise_unit : str, float
        Unit in which residuals and the noise level are reported, and its SI value.
    sigma_si : float or array_like, optional
        Known noise per observation (SI); estimated from the residuals when omitted.
    pivot_order : sequence of str
        Preferred leading terms of combinations (the rest follow in model order).
    normalize_to : str, optional
        Scale each combination containing this coefficient so that its weight is 1.
    explain : callable, optional
        Statements about the null space; default: a generic one naming the coefficients involved.

    Returns
    -------
    fit : LinearFit
        SI solution.
    result : Identification
        Engineering-unit summary.

    Notes
    -----
    Combination weights are converted so that ``value = sum(w_k * coef_k)`` holds in engineering
    units, with the unit of the leading (weight-1) term.
    """
    names = tuple(names)
    fit = weighted_least_squares(A, y, sigma=sigma_si)
    fac = np.array([si_per_unit[n] for n in names])
    ident = fit.identifiable
    coefficients = {
        n: Estimate(n, float(fit.x[i] / fac[i]), float(fit.std[i] / fac[i]), units[n])
        for i, n in enumerate(names)
        if ident[i]
    }
    rest = [i for i in range(len(names)) if not ident[i]]
    order = [names.index(n) for n in pivot_order if n in names and names.index(n) in rest]
    order += [i for i in rest if i not in order]
    rows = identifiable_combinations(fit.null_space, rest, pivot_order=order)
    combinations = tuple(
        _combination(row, fit, names, units, fac, normalize_to, order)
        for row in rows
        if np.count_nonzero(row) > 0
    )
    statements = (explain or _generic_explanation(names))(fit, np.asarray(A, dtype=float))
    result = Identification(
        coefficients=coefficients,
        combinations=combinations,
        not_separable=tuple(statements),
        covariance=fit.covariance / np.outer(fac, fac),
        names=names,
        noise_sigma=(
            float(fit.sigma / si_per_noise_unit) if fit.sigma_from_residuals else float("nan")
        ),
        noise_unit=noise_unit,
        sigma_from_residuals=fit.sigma_from_residuals,
        dof=fit.dof,
        rank=fit.rank,
        residuals=fit.residuals / si_per_noise_unit,
    )
    return fit, result


def _combination(
    row: NDArray[np.float64],
    fit: LinearFit,
    names: tuple[str, ...],
    units: Mapping[str, str],
    fac: NDArray[np.float64],
    normalize_to: str | None,
    order: Sequence[int],
) -> Combination:
    # Express the SI combination row . x_si in engineering units: x_si = fac * x_eng.
    row_eng = row * fac
    if normalize_to is not None and normalize_to in names and row[names.index(normalize_to)]:
        lead = names.index(normalize_to)
    else:
        lead = next(i for i in order if row[i] != 0)  # the row-echelon pivot
    scale = row_eng[lead]
    w = row_eng / scale
    value, std = fit.combination(row)
    nz = [lead] + [i for i in np.flatnonzero(w) if i != lead]
    return Combination(
        name=combination_name([(names[i], float(w[i])) for i in nz]),
        terms={names[i]: float(w[i]) for i in nz},
        value=value / scale,
        std=std / abs(scale),
        unit=units[names[lead]],
    )


def combination_name(terms: Sequence[tuple[str, float]]) -> str:
    """Readable name of a weighted sum, e.g. ``"DF + 0.996*DII"`` or ``"DOO - DII"``."""
    parts = []
    for j, (name, w) in enumerate(terms):
        mag = abs(w)
        body = name if abs(mag - 1.0) < 1e-12 else f"{mag:.6g}*{name}"
        if j == 0:
            parts.append(body if w > 0 else f"-{body}")
        else:
            parts.append(f"{'-' if w < 0 else '+'} {body}")
    return " ".join(parts)


def _generic_explanation(names: tuple[str, ...]) -> Explainer:
    def explain(fit: LinearFit, A: NDArray[np.float64]) -> list[str]:
        if fit.null_space.shape[1] == 0:
            return []
        out = []
        zero = [names[i] for i in range(A.shape[1]) if not np.any(A[:, i])]
        if zero:
            out.append(f"{', '.join(zero)}: never excited by this test (regressor zero at every "
                       "observation), so the data say nothing about them")
        mixed = [names[i] for i in range(A.shape[1])
                 if names[i] not in zero and np.linalg.norm(fit.null_space[i]) > 1e-7]
        if mixed:
            out.append(f"{', '.join(mixed)}: not separable by this test; only the combinations "
                       "listed are determined")
        return out

    return explain
