"""Identification of the SDF-gyro static drift model from 1 g tumble data.

Shared by every 1 g procedure (polar-axis tumble, local-level tumble): the inputs of each data
row come from the fixture's motion (:func:`row_inputs`); given the specific force on the gyro axes
and the true input rate at each observation, solve the linear model of
:mod:`inertest.models.sdf_gyro` by weighted least squares and say what the test determines.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.equipment.motion import StaticPositions, unique_by_runs
from inertest.errors import InputError
from inertest.estimation.identify import NoiseFit, identify_with_noise
from inertest.estimation.least_squares import LinearFit
from inertest.estimation.noise_models import BIAS_TIME_SCALE_DEFAULT
from inertest.estimation.units import PositionDesign
from inertest.models.sdf_gyro import COEFFICIENTS, ENGINEERING_UNIT, drift_regressors
from inertest.results import Identification
from inertest.units import DEG_PER_H_TO_RAD_PER_S, G0

_SQUARES = ("DII", "DOO", "DSS")


def row_inputs(
    motion: StaticPositions, labels: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Inputs of the drift model for each data row: :func:`position_inputs` spread over the rows.

    ``labels`` (array_like of str, shape (n,)) is the position label of each row; the returns
    are ``f_ios_g`` of shape (n, 3) [g0] and ``rate_in_rad_s`` of shape (n,) [rad/s].
    """
    # The inputs of each position once, then spread over its rows (no per-row attitude).
    uniq, inv = unique_by_runs(np.asarray(labels).astype(str, copy=False))
    f, w = position_inputs(motion, uniq)
    return f[inv], w[inv]


def position_inputs(
    motion: StaticPositions, labels: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Inputs of the drift model at each position (no per-row arrays).

    Parameters
    ----------
    motion : StaticPositions
        The fixture's positions (segments by label).
    labels : array_like of str, shape (G,)
        Position labels.

    Returns
    -------
    f_ios_g : ndarray, shape (G, 3)
        Specific force on I, O, S [g0] at each position.
    rate_in_rad_s : ndarray, shape (G,)
        Inertial angular rate on the input axis I [rad/s] (the Earth rate at rest).
    """
    parts = [motion.inputs_of_rows(np.array([u])) for u in np.asarray(labels).astype(str)]
    f = np.concatenate([p.f_i for p in parts]).reshape(-1, 3)
    w = np.concatenate([p.omega_i[:, 0] for p in parts])
    return f / G0, w


def identify_drift(
    f_ios_g: ArrayLike,
    drift_rad_s: ArrayLike,
    *,
    gravity_g: float,
    sigma_rad_s: float | ArrayLike | None = None,
    pivot_order: Sequence[str] = ("DF", "DOO", "DSS", "DII"),
    normalize_to: str | None = "DF",
    groups: ArrayLike | None = None,
    noise_model: str = "auto",
    position_index: ArrayLike | None = None,
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> tuple[LinearFit, NoiseFit, Identification]:
    """Fit the 10-term static drift model and report what the data determine.

    Parameters
    ----------
    f_ios_g : array_like, shape (n, 3), or (G, 3) with ``position_index``
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
    groups : array_like of str, optional
        Position of each row (rows of one position share the specific force); the noise is
        modelled per position (see :func:`inertest.estimation.identify.solve`).
    noise_model : str
        ``auto``, ``white``, ``position-offsets``, ``random-walk`` or ``flicker``.
    position_index : array_like of int, shape (n,), optional
        Position of each row (``0 <= position_index < G``) when ``f_ios_g`` holds one row
        per position and ``groups`` their ``G`` labels: the design is then solved per position
        (:class:`~inertest.estimation.identify.PositionDesign`), never built row by row; the
        same estimates.
    bias_time_scale : float
        Under flicker, the time over which the constant terms (DF and its combinations) are
        meant, in test durations (:func:`inertest.estimation.identify.solve`).

    Returns
    -------
    fit : LinearFit
        The least-squares solution in SI (rad/s per g^k).
    noise : NoiseFit
        The noise model used, the covariance of the position means and the model checks.
    result : Identification
        Coefficients, combinations and statements in deg/h, deg/h/g, deg/h/g^2.
    """
    rows = drift_regressors(f_ios_g)
    A: NDArray[np.float64] | PositionDesign = rows
    if position_index is not None:
        if groups is None:
            raise InputError("position_index needs the label of each position (groups)")
        A = PositionDesign.from_codes(rows, position_index,
                                      [str(g) for g in np.asarray(groups)])
        groups = None
    k = DEG_PER_H_TO_RAD_PER_S
    return identify_with_noise(
        A,
        drift_rad_s,
        names=COEFFICIENTS,
        units=ENGINEERING_UNIT,
        si_per_unit={n: k for n in COEFFICIENTS},
        noise_unit="deg/h",
        si_per_noise_unit=k,
        sigma_si=sigma_rad_s,
        pivot_order=pivot_order,
        normalize_to=normalize_to,
        explain=lambda fit, design: _explain_null_space(fit, design, gravity_g),
        groups=groups,
        noise_model=noise_model,
        bias_time_scale=bias_time_scale,
    )


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
