"""Identification of the SDF-gyro static drift model from 1 g tumble data.

Shared by every 1 g procedure (polar-axis tumble, local-level tumble): given the specific force
on the gyro axes and the true input rate at each observation, solve the linear model of
:mod:`inertest.models.sdf_gyro` by weighted least squares and say what the test determines.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.estimation.least_squares import (
    LinearFit,
    identifiable_combinations,
    weighted_least_squares,
)
from inertest.models.sdf_gyro import COEFFICIENTS, ENGINEERING_UNIT, drift_regressors
from inertest.procedures.results import Combination, Estimate, Identification
from inertest.units import DEG_PER_H_TO_RAD_PER_S

_SQUARES = ("DII", "DOO", "DSS")


def identify_drift(
    f_ios_g: ArrayLike,
    drift_rad_s: ArrayLike,
    *,
    gravity_g: float,
    sigma_rad_s: float | ArrayLike | None = None,
    pivot_order: Sequence[str] = ("DF", "DOO", "DSS", "DII"),
    normalize_to: str | None = "DF",
) -> tuple[LinearFit, Identification]:
    """Fit the 10-term static drift model and report what the data determine.

    Parameters
    ----------
    f_ios_g : array_like, shape (n, 3)
        Specific force along I, O, S [g0].
    drift_rad_s : array_like, shape (n,)
        Observed drift: indicated rate minus true input rate [rad/s].
    gravity_g : float
        Local gravity [g0], used to explain the 1 g constraint.
    sigma_rad_s : float or array_like, optional
        Known noise per observation [rad/s]; estimated from the residuals when omitted.
    pivot_order : sequence of str
        Preferred leading terms of the combinations (others are appended in model order).
    normalize_to : str, optional
        Scale each combination that contains this coefficient so that its weight is 1.

    Returns
    -------
    fit : LinearFit
        The least-squares solution in SI (rad/s per g^k).
    result : Identification
        Coefficients, combinations and statements in deg/h, deg/h/g, deg/h/g^2.
    """
    A = drift_regressors(f_ios_g)
    fit = weighted_least_squares(A, drift_rad_s, sigma=sigma_rad_s)
    k = DEG_PER_H_TO_RAD_PER_S
    ident = fit.identifiable
    coefficients = {
        name: Estimate(name, float(fit.x[i] / k), float(fit.std[i] / k), ENGINEERING_UNIT[name])
        for i, name in enumerate(COEFFICIENTS)
        if ident[i]
    }
    rest = [i for i in range(len(COEFFICIENTS)) if not ident[i]]
    order = [COEFFICIENTS.index(n) for n in pivot_order if COEFFICIENTS.index(n) in rest]
    order += [i for i in rest if i not in order]
    rows = identifiable_combinations(fit.null_space, rest, pivot_order=order)
    combinations = tuple(
        _combination(row, fit, normalize_to) for row in rows if np.count_nonzero(row) > 0
    )
    result = Identification(
        coefficients=coefficients,
        combinations=combinations,
        not_separable=_explain_null_space(fit, A, gravity_g),
        covariance=fit.covariance / k**2,
        names=COEFFICIENTS,
        noise_sigma=float(fit.sigma / k) if fit.sigma_from_residuals else float("nan"),
        noise_unit="deg/h",
        sigma_from_residuals=fit.sigma_from_residuals,
        dof=fit.dof,
        rank=fit.rank,
        residuals=fit.residuals / k,
    )
    return fit, result


def _combination(row: NDArray[np.float64], fit: LinearFit, normalize_to: str | None) -> Combination:
    if normalize_to is not None:
        j = COEFFICIENTS.index(normalize_to)
        if row[j] != 0:
            row = row / row[j]
    nz = [i for i in np.flatnonzero(row)]
    lead = next(i for i in nz if abs(row[i] - 1.0) < 1e-12)
    ordered = [lead] + [i for i in nz if i != lead]
    value, std = fit.combination(row)
    k = DEG_PER_H_TO_RAD_PER_S
    return Combination(
        name=combination_name([(COEFFICIENTS[i], float(row[i])) for i in ordered]),
        terms={COEFFICIENTS[i]: float(row[i]) for i in ordered},
        value=value / k,
        std=std / k,
        unit=ENGINEERING_UNIT[COEFFICIENTS[lead]],
    )


def combination_name(terms: Sequence[tuple[str, float]]) -> str:
    """Readable name of a weighted sum, e.g. ``"DF + 0.996*DII"`` or ``"DOO - DII"``."""
    parts = []
    for j, (name, w) in enumerate(terms):
        mag = abs(w)
        sign = "-" if w < 0 else "+"
        body = name if abs(mag - 1.0) < 1e-12 else f"{mag:.6g}*{name}"
        if j == 0:
            parts.append(body if w > 0 else f"-{body}")
        else:
            parts.append(f"{sign} {body}")
    return " ".join(parts)


def _explain_null_space(
    fit: LinearFit, A: NDArray[np.float64], gravity_g: float
) -> tuple[str, ...]:
    """Plain statements of the directions the data cannot see."""
    if fit.null_space.shape[1] == 0:
        return ()
    out = []
    zero_cols = [COEFFICIENTS[i] for i in range(A.shape[1]) if not np.any(A[:, i])]
    if zero_cols:
        out.append(
            f"{', '.join(zero_cols)}: their regressors are zero at every position (no position "
            "puts specific force on two axes at once), so the data say nothing about them"
        )
    remaining = [i for i in range(A.shape[1]) if COEFFICIENTS[i] not in zero_cols]
    # The 1 g constraint: fI^2 + fO^2 + fS^2 = (g/g0)^2 at every position.
    constraint = np.zeros(A.shape[1])
    constraint[COEFFICIENTS.index("DF")] = -(gravity_g**2)
    for s in _SQUARES:
        constraint[COEFFICIENTS.index(s)] = 1.0
    constraint /= np.linalg.norm(constraint)
    proj = fit.null_space.T @ constraint
    if np.linalg.norm(proj) > 1 - 1e-6:
        out.append(
            "DF, DII, DOO, DSS: not separable from each other; in a 1 g field "
            f"fI^2 + fO^2 + fS^2 = (g/g0)^2 = {gravity_g**2:.6f} at every position, so adding "
            "t to each square term and subtracting t*(g/g0)^2 from DF changes no reading; "
            "only the combinations listed are determined"
        )
    n_explained = len(zero_cols) + (1 if np.linalg.norm(proj) > 1 - 1e-6 else 0)
    if fit.null_space.shape[1] > n_explained:
        rest_names = [
            COEFFICIENTS[i]
            for i in remaining
            if np.linalg.norm(fit.null_space[i]) > 1e-7
        ]
        out.append(
            f"{', '.join(rest_names)}: the positions measured do not separate these; "
            "only the combinations listed are determined (add positions or mountings)"
        )
    return tuple(out)
