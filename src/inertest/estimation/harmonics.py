"""Harmonic (Fourier series) fit of a signal sampled at angles.

``y(theta) = B0 + sum_k (Sk sin k theta + Ck cos k theta)``, fitted by least squares with the
covariance of the terms (seed ``000_dad8be616c6569c7.txt``, sec. 2(4): the polar-axis tumble's
``Y = A X`` with ``X = [B0, S1, C1, S2, C2]``, solved as ``X = (A^T A)^-1 A^T Y``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InputError
from inertest.estimation.least_squares import LinearFit, weighted_least_squares


def harmonic_names(order: int) -> tuple[str, ...]:
    """Names of the terms up to ``order``: ``("B0", "S1", "C1", "S2", "C2", ...)``."""
    names = ["B0"]
    for k in range(1, order + 1):
        names += [f"S{k}", f"C{k}"]
    return tuple(names)


def harmonic_design(angle_rad: ArrayLike, order: int) -> NDArray[np.float64]:
    """Columns ``1, sin t, cos t, ..., sin(order t), cos(order t)`` at ``angle_rad`` [rad]."""
    t = np.asarray(angle_rad, dtype=float)
    cols = [np.ones_like(t)]
    for k in range(1, order + 1):
        cols += [np.sin(k * t), np.cos(k * t)]
    return np.column_stack(cols)


@dataclass(frozen=True)
class HarmonicFit:
    """Fourier terms of a signal over angle, with covariance.

    Attributes
    ----------
    names : tuple of str
        ``("B0", "S1", "C1", ...)``.
    values : ndarray
        Term values (units of the signal).
    covariance : ndarray
        Covariance of the terms.
    fit : LinearFit
        The underlying least-squares solution (residuals, noise level, dof).
    """

    names: tuple[str, ...]
    values: NDArray[np.float64]
    covariance: NDArray[np.float64]
    fit: LinearFit

    @property
    def std(self) -> NDArray[np.float64]:
        """Standard uncertainty of each term."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def order(self) -> int:
        """Highest harmonic."""
        return (len(self.names) - 1) // 2

    def evaluate(self, angle_rad: ArrayLike) -> NDArray[np.float64]:
        """The fitted series at ``angle_rad`` [rad]."""
        return harmonic_design(angle_rad, self.order) @ self.values

    def as_dict(self) -> dict[str, float]:
        """Term name -> value."""
        return dict(zip(self.names, self.values.tolist(), strict=True))


def harmonic_fit(
    angle_rad: ArrayLike,
    y: ArrayLike,
    *,
    order: int = 2,
    sigma: float | ArrayLike | None = None,
) -> HarmonicFit:
    """Least-squares Fourier series of ``y`` sampled at ``angle_rad``.

    Parameters
    ----------
    angle_rad : array_like, shape (n,)
        Angles [rad].
    y : array_like, shape (n,)
        Signal samples.
    order : int
        Highest harmonic (2 for the polar-axis tumble).
    sigma : float or array_like, optional
        Known noise per sample; estimated from the residuals when omitted.

    Raises
    ------
    IdentifiabilityError
        Fewer distinct angles than ``2 order + 1`` terms: the terms cannot be separated.
    """
    t = np.asarray(angle_rad, dtype=float)
    if order < 0:
        raise InputError(f"harmonic order must be >= 0, got {order}")
    n_terms = 2 * order + 1
    distinct = np.unique(np.round(np.mod(t, 2 * np.pi), 12)).size
    if distinct < n_terms:
        raise IdentifiabilityError(
            f"{distinct} distinct angle(s) cannot separate {n_terms} Fourier terms up to "
            f"harmonic {order}; measure at least {n_terms} distinct table angles"
        )
    fit = weighted_least_squares(harmonic_design(t, order), y, sigma=sigma)
    return HarmonicFit(
        names=harmonic_names(order), values=fit.x, covariance=fit.covariance, fit=fit
    )
