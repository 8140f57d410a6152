"""Generic identification of a linear error model: least squares -> what the data determine.

Every static error model in inertest is linear in its coefficients (DESIGN.md). A procedure
builds the design ``A`` (SI) and observations, then calls :func:`identify`, which solves by
weighted least squares and expresses the result in engineering units: individually identifiable
coefficients, a basis of identifiable combinations of the rest, and the null space in words.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.special
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InertestWarning, InputError, PlanError
from inertest.estimation.least_squares import (
    DEFAULT_RCOND,
    LinearFit,
    identifiable_combinations,
    weighted_least_squares,
)
from inertest.results import (
    Combination,
    Estimate,
    Identification,
    ModelChecks,
    Outlier,
    sum_of_squares,
)

#: Explains the null space of a fit in words: (fit, design) -> statements.
Explainer = Callable[[LinearFit, NDArray[np.float64]], Sequence[str]]
#: Default time scale of the constant (bias-type) terms under flicker, in test durations: the
#: flicker model's spectrum starts at ``1 / (2 * scale)`` cycles per record, ``1/(4 T)`` for a
#: test of duration ``T`` (see :func:`_flicker_unit_kernel`).
BIAS_TIME_SCALE_DEFAULT = 2.0


def identify(
    A: ArrayLike | PositionDesign,
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
    groups: ArrayLike | None = None,
    noise_model: str = "white",
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> tuple[LinearFit, Identification]:
    """Solve ``y = A x`` and report what the data determine, in engineering units.

    Parameters
    ----------
    A : array_like, shape (n, p), or PositionDesign
        Design in SI (columns in the order of ``names``), rows in time order; a
        :class:`PositionDesign` (design row of each position, position of each reading) names
        the positions itself (no ``groups``) and is solved without building the full design.
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
    groups : array_like of str, optional
        Position/run of each row (the unit of independence), see :func:`solve`.
    noise_model : str
        Noise model (:data:`NOISE_MODELS`, see :func:`solve`); default ``white``, the classical
        least squares.
    bias_time_scale : float
        Under flicker, the time over which the constant terms are meant [test durations]
        (see :func:`solve`).

    Returns
    -------
    fit : LinearFit
        SI solution.
    result : Identification
        Engineering-unit summary with the noise model and its checks.

    Notes
    -----
    Combination weights are converted so that ``value = sum(w_k * coef_k)`` holds in engineering
    units, with the unit of the leading (weight-1) term.
    """
    fit, _, result = identify_with_noise(
        A, y, names=names, units=units, si_per_unit=si_per_unit, noise_unit=noise_unit,
        si_per_noise_unit=si_per_noise_unit, sigma_si=sigma_si, pivot_order=pivot_order,
        normalize_to=normalize_to, explain=explain, groups=groups, noise_model=noise_model,
        bias_time_scale=bias_time_scale)
    return fit, result


def identify_with_noise(
    A: ArrayLike | PositionDesign,
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
    groups: ArrayLike | None = None,
    noise_model: str = "white",
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> tuple[LinearFit, NoiseFit, Identification]:
    """:func:`identify`, also returning the :class:`NoiseFit` (unit covariance, labels)."""
    names = tuple(names)
    fit, noise = solve(A, y, sigma_si=sigma_si, groups=groups, noise_model=noise_model,
                       bias_time_scale=bias_time_scale)
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
    design = A.rows if isinstance(A, PositionDesign) else np.asarray(A, dtype=float)
    statements = (explain or _generic_explanation(names))(fit, design)
    result = Identification(
        coefficients=coefficients,
        combinations=combinations,
        not_separable=tuple(statements),
        covariance=fit.covariance / np.outer(fac, fac),
        names=names,
        noise_sigma=float(noise.white_sigma / si_per_noise_unit),
        noise_unit=noise_unit,
        sigma_from_residuals=not noise.sigma_given,
        dof=fit.dof,
        rank=fit.rank,
        residuals=fit.residuals / si_per_noise_unit,
        noise_model=noise.model,
        noise_components={k: v / si_per_noise_unit for k, v in noise.components.items()},
        checks=noise.checks,
        noise_model_weights=dict(noise.weights),
        bias_time_scale=noise.bias_time_scale,
    )
    return fit, noise, result


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


# --------------------------------------------------------------------------------------------
# Noise models: reduce to the unit of independence, estimate the variance components, GLS.
# --------------------------------------------------------------------------------------------

#: Noise models :func:`solve` knows; ``auto`` picks one of the others by AIC.
NOISE_MODELS = ("auto", "white", "position-offsets", "random-walk", "flicker")
#: Significance level of the model checks (per test); low, so that good data rarely warn.
CHECK_ALPHA = 1e-3
#: Units needed beyond the rank before a variance component is estimated.
_MIN_UNIT_DOF = 4
#: Largest number of units for which a correlated noise model is fitted (dense G x G).
_MAX_UNITS = 2000
#: Largest number of units whose pairs the mean-shift check tries (G (G - 1) / 2 of them).
_MAX_PAIR_UNITS = 400
#: Position offsets larger than this many times the white noise per reading are implausible
#: (a wrong label or a missing term absorbed as an "offset"), see :func:`_plausibility`.
OFFSET_PLAUSIBLE_RATIO = 100.0
#: ``auto``: candidate noise models within this much of the best criterion per output count as
#: "close" (the data cannot tell them apart; Burnham & Anderson 2002, sec. 2.6) and their
#: spread is added (:func:`common_noise_model`).
AUTO_CLOSE_AIC = 2.0
#: ``auto``: familywise level of the likelihood-ratio test a correlated noise model must pass
#: against white noise to be chosen (:func:`component_penalty`).
AUTO_ALPHA = 0.05


def check_bias_time_scale(value: object) -> float:
    """Validate ``bias_time_scale`` (test durations, at least 1; a plan key or an argument)."""
    if (isinstance(value, bool) or not isinstance(value, int | float)
            or not np.isfinite(value) or value < 1.0):
        raise PlanError(
            "bias_time_scale is the time over which a constant term is meant, in test "
            f"durations (e.g. calibration interval / test duration), at least 1; got {value!r}")
    return float(value)


def _flicker_low(n: int, bias_time_scale: float) -> float:
    """Lowest frequency of the flicker model [cycles per row] for an ``n``-row record."""
    return 1.0 / (2.0 * check_bias_time_scale(bias_time_scale) * max(n, 1))


def check_noise_model(value: object) -> str:
    """Validate the ``noise_model`` of a plan's ``[procedure]`` table (or an API argument)."""
    if not isinstance(value, str) or value not in NOISE_MODELS:
        raise PlanError(
            f"noise_model must be one of {', '.join(NOISE_MODELS)}, got {value!r}")
    return value


@dataclass(frozen=True)
class NoiseFit:
    """How :func:`solve` modelled the noise (SI, the units of ``y``).

    Attributes
    ----------
    model : str
        Noise model used (never ``auto``).
    white_sigma : float
        White noise per reading (given or estimated).
    sigma_given : bool
        True when the white noise was given by the user.
    components : dict
        Standard deviation of each noise component: ``white`` (per reading), ``position
        offset`` (per unit), ``random walk`` (step per reading), ``flicker`` (per reading).
    unit_index : ndarray of int, shape (n,)
        Unit (position/run) of each row; units are numbered in time order (first row).
    unit_labels : tuple of str or None
        Label of each unit (None when the units are the readings).
    unit_covariance : ndarray, shape (G, G) or (G,)
        Covariance of the unit means under the fitted noise model (its diagonal when the
        model is white).
    checks : ModelChecks
        Goodness of fit.
    weights : dict
        With ``auto``: the Akaike weight of each candidate noise model (empty otherwise);
        ``model`` is the one of largest weight.
    aic : dict
        With ``auto``: the AIC of each candidate (restricted likelihood of the unit means;
        empty otherwise), for a choice common to several outputs (:func:`solve_outputs`).
    bias_time_scale : float or None
        When flicker is behind the covariance (the model, or a close candidate of ``auto``):
        the time over which the constant terms' std holds [test durations]; None otherwise.
    """

    model: str
    white_sigma: float
    sigma_given: bool
    components: dict[str, float]
    unit_index: NDArray[np.intp] = field(repr=False)
    unit_labels: tuple[str, ...] | None = field(repr=False)
    unit_covariance: NDArray[np.float64] = field(repr=False)
    checks: ModelChecks = field(repr=False)
    weights: dict[str, float] = field(default_factory=dict)
    aic: dict[str, float] = field(default_factory=dict)
    bias_time_scale: float | None = None

    def unit_means(self, values: ArrayLike) -> NDArray[np.float64]:
        """Mean of ``values`` (one per row) over each unit."""
        v = np.asarray(values, dtype=float)
        counts = np.bincount(self.unit_index)
        return np.bincount(self.unit_index, v) / counts


@dataclass(frozen=True)
class PositionDesign:
    """A design whose rows repeat by position: row ``i`` of the design is ``rows[index[i]]``.

    A static test holds the instrument in a few positions for many readings each; the design
    of each position once (``G x p``) and the position of each reading (``n`` ints) say
    everything the full ``n x p`` design does, at ``G p + n`` numbers instead of ``n p``.
    :func:`solve` then works on the sufficient statistics of each position (count, mean,
    sum of squares) and never builds the full design. Build it with :meth:`from_codes`.

    Attributes
    ----------
    rows : ndarray, shape (G, p)
        Design row of each position, positions in time order (of their first reading).
    index : ndarray of int, shape (n,)
        Position of each reading (every position has readings).
    labels : tuple of str
        Name of each position.
    """

    rows: NDArray[np.float64]
    index: NDArray[np.intp]
    labels: tuple[str, ...]

    @classmethod
    def from_codes(
        cls, rows: ArrayLike, codes: ArrayLike, labels: Sequence[str]
    ) -> PositionDesign:
        """Design from the row and label of each position and a code per reading.

        Parameters
        ----------
        rows : array_like, shape (k, p)
            Design row of each position, in any order.
        codes : array_like of int, shape (n,)
            Position of each reading, ``0 <= codes < k``, readings in time order.
        labels : sequence of str, length k
            Name of each position.

        Returns
        -------
        PositionDesign
            Positions without readings dropped, the others in the order of their first reading.
        """
        R = np.asarray(rows, dtype=float)
        c = np.asarray(codes, dtype=np.intp)
        if R.ndim != 2 or len(labels) != R.shape[0] or c.ndim != 1:
            raise InputError(f"position design: {R.shape} rows, {len(labels)} labels and codes "
                             f"of shape {c.shape}; give one row and one label per position and "
                             "one code per reading")
        if c.size and (c.min() < 0 or c.max() >= R.shape[0]):
            raise InputError(f"position codes must lie in 0..{R.shape[0] - 1}")
        change = np.ones(c.size, dtype=bool)
        change[1:] = c[1:] != c[:-1]
        starts = np.flatnonzero(change)
        used, first = np.unique(c[starts], return_index=True)
        order = used[np.argsort(first, kind="stable")]  # positions in time order
        rank = np.full(R.shape[0], -1, dtype=np.intp)
        rank[order] = np.arange(order.size)
        index = np.repeat(rank[c[starts]], np.diff(np.append(starts, c.size)))
        return cls(rows=R[order], index=index, labels=tuple(str(labels[k]) for k in order))

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of the full design, ``(n, p)``."""
        return int(self.index.size), int(self.rows.shape[1])

    def __matmul__(self, x: ArrayLike) -> NDArray[np.float64]:
        """``A @ x`` for every reading, from the ``G`` positions' values."""
        return np.asarray(self.rows @ np.asarray(x, dtype=float))[self.index]


def _residuals(
    A: NDArray[np.float64] | PositionDesign, x: NDArray[np.float64], y: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``y - A @ x`` in one new array (no second record-length temporary)."""
    out = np.asarray(A @ x)
    return np.subtract(y, out, out=out)


@dataclass(frozen=True)
class _Units:
    """Rows reduced to units (positions/runs): means, design, counts, time order."""

    index: NDArray[np.intp]
    labels: tuple[str, ...] | None  # None: the units are the readings
    counts: NDArray[np.float64]
    first: NDArray[np.intp]
    last: NDArray[np.intp]
    y: NDArray[np.float64]
    A: NDArray[np.float64]
    n_rows: int

    @property
    def size(self) -> int:
        return int(self.counts.size)

    def label(self, i: int) -> str:
        return f"reading {i + 1}" if self.labels is None else self.labels[i]

    @property
    def contiguous(self) -> bool:
        return bool(np.all(self.last - self.first + 1 == self.counts))


def _position_units(P: PositionDesign, y: NDArray[np.float64]) -> _Units:
    """The units of a :class:`PositionDesign`: its positions, from per-position sums."""
    n, G = y.size, P.rows.shape[0]
    idx = P.index
    change = np.ones(n, dtype=bool)
    change[1:] = idx[1:] != idx[:-1]
    starts = np.flatnonzero(change)
    ends = np.append(starts[1:], n) - 1
    first = np.full(G, n, dtype=np.intp)
    np.minimum.at(first, idx[starts], starts)
    last = np.zeros(G, dtype=np.intp)
    np.maximum.at(last, idx[starts], ends)
    counts = np.bincount(idx, minlength=G).astype(float)
    return _Units(index=idx, labels=P.labels, counts=counts, first=first, last=last,
                  y=np.bincount(idx, y, minlength=G) / counts, A=P.rows, n_rows=n)


def _position_row_fit(
    P: PositionDesign, u: _Units, y: NDArray[np.float64], sigma_si: float | ArrayLike | None,
) -> LinearFit:
    """:func:`weighted_least_squares` over the readings of a :class:`PositionDesign`.

    Rows of one position share the design row, so ``sum_i w_i (y_i - a_g x)^2`` over a
    position is ``W_g (ybar_g - a_g x)^2`` plus a constant, with ``W_g = sum_i w_i`` and
    ``ybar_g`` the ``w``-weighted mean: the least squares over the ``G`` weighted position
    means has the same normal equations, singular values and null space as over the readings.
    Residuals, degrees of freedom and the noise level are those of the readings.
    """
    n = y.size
    if sigma_si is None or np.ndim(sigma_si) == 0:
        s2 = 1.0 if sigma_si is None else float(np.asarray(sigma_si)) ** 2
        if not (np.isfinite(s2) and s2 > 0):
            raise InputError("observation sigmas must be finite and positive")
        W, ymean = u.counts / s2, u.y
    else:
        s = np.broadcast_to(np.asarray(sigma_si, dtype=float), (n,))
        if not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError("observation sigmas must be finite and positive")
        inv = 1.0 / s**2
        W = np.bincount(u.index, inv, minlength=u.size).astype(float)
        ymean = np.bincount(u.index, y * inv, minlength=u.size) / W
    sq = np.sqrt(W)
    red = weighted_least_squares(P.rows * sq[:, None], ymean * sq, sigma=1.0)
    residuals = _residuals(P, red.x, y)
    dof = n - red.rank
    if sigma_si is not None:
        return replace(red, residuals=residuals, dof=dof)
    if dof <= 0:
        raise IdentifiabilityError(
            f"{n} observations leave no degree of freedom to estimate the noise "
            f"({red.rank} independent unknowns); add positions or samples, or give the noise "
            "level")
    sigma0 = float(np.sqrt(sum_of_squares(residuals) / dof))
    return replace(red, covariance=red.covariance * sigma0**2, residuals=residuals,
                   sigma=sigma0, sigma_from_residuals=True, dof=dof)


def _units(A: NDArray[np.float64], y: NDArray[np.float64], groups: ArrayLike | None) -> _Units:
    n = y.size
    if groups is None:
        idx = np.arange(n, dtype=np.intp)
        return _Units(index=idx, labels=None, counts=np.ones(n), first=idx, last=idx, y=y, A=A,
                      n_rows=n)
    labels_row = np.asarray(groups).astype(str, copy=False)
    if labels_row.shape != (n,):
        raise InputError(f"groups has shape {labels_row.shape}; give one label per row ({n})")
    # np.unique over the runs of equal labels only (the readings of a position come together).
    change = np.ones(n, dtype=bool)
    change[1:] = labels_row[1:] != labels_row[:-1]
    starts = np.flatnonzero(change)
    lengths = np.diff(np.append(starts, n))
    uniq, first_run, inv_run = np.unique(labels_row[starts], return_index=True,
                                         return_inverse=True)
    first = starts[first_run]
    order = np.argsort(first, kind="stable")  # units in time order
    rank_of = np.empty_like(order)
    rank_of[order] = np.arange(order.size)
    index = np.repeat(rank_of[inv_run], lengths)
    counts = np.bincount(index).astype(float)
    last = np.zeros(order.size, dtype=np.intp)
    np.maximum.at(last, rank_of[inv_run], starts + lengths - 1)
    ybar = np.bincount(index, y) / counts
    Abar = np.stack([np.bincount(index, A[:, j], minlength=order.size) for j in
                     range(A.shape[1])], axis=1) / counts[:, None]
    # Column by column: no temporary of the whole design.
    scale = max(max((float(np.max(np.abs(A[:, j]))) for j in range(A.shape[1])), default=0.0),
                1e-300)
    spread = max((float(np.max(np.abs(A[:, j] - Abar[index, j]))) for j in range(A.shape[1])),
                 default=0.0)
    if groups is not None and spread > 1e-9 * scale:
        # The design varies inside a group: the labels are not positions; use the readings.
        return _units(A, y, None)
    return _Units(index=index, labels=tuple(uniq[order].tolist()), counts=counts,
                  first=first[order].astype(np.intp), last=last, y=ybar, A=Abar, n_rows=n)


def _geo(rho: float, m: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_{j<m} rho^j``."""
    return m if rho == 0 else (1.0 - rho**m) / (1.0 - rho)


def _ar1_unit_kernel(u: _Units, rho: float) -> NDArray[np.float64]:
    """Covariance of unit means of a unit-variance AR(1) process over rows (lag-1 corr rho)."""
    if u.contiguous:
        m = u.counts
        g = _geo(rho, m)
        gap = u.first[None, :] - u.last[:, None]  # start of later unit - end of earlier unit
        gap = np.where(gap > 0, gap, gap.T)
        K = np.outer(g, g) * np.power(rho, np.maximum(gap, 1))
        within = m * (1 + rho) / (1 - rho) - 2 * rho * (1 - rho**m) / (1 - rho) ** 2
        np.fill_diagonal(K, within)
        return K / np.outer(m, m)
    return _generic_unit_kernel(u, lambda v: _ar1_apply(v, rho))


def _rw_unit_kernel(u: _Units) -> NDArray[np.float64]:
    """Covariance of unit means of a random walk with unit step variance per row.

    The walk is ``W_t = sum_{k<=t} e_k`` over the row index t, ``Cov(W_i, W_k) = min(i, k) + 1``.
    """
    if u.contiguous:
        m, a = u.counts, u.first.astype(float)
        mean_t = a + 1 + (m - 1) / 2  # mean of (i + 1) over the unit's rows
        earlier = u.first[:, None] < u.first[None, :]
        K = np.where(earlier, mean_t[:, None], mean_t[None, :])
        within = (a + 1) + (2 * m - 1) * (m - 1) / (6 * m)
        np.fill_diagonal(K, within)
        return K
    return _generic_unit_kernel(
        u, lambda v: np.cumsum(np.cumsum(v[::-1], axis=0)[::-1], axis=0))


def _ar1_apply(v: NDArray[np.float64], rho: float) -> NDArray[np.float64]:
    """``K v`` for the AR(1) correlation ``K[i, k] = rho^|i - k|`` (two first-order filters)."""
    import scipy.signal  # here: its import takes longer than most fits

    fwd = scipy.signal.lfilter([1.0], [1.0, -rho], v, axis=0)
    bwd = scipy.signal.lfilter([1.0], [1.0, -rho], v[::-1], axis=0)[::-1]
    return fwd + bwd - v


def _generic_unit_kernel(
    u: _Units, apply: Callable[[NDArray[np.float64]], NDArray[np.float64]]
) -> NDArray[np.float64]:
    """``M K M^T`` for a row kernel given as ``v -> K v`` (units not contiguous in time)."""
    G, out = u.size, np.empty((u.size, u.size))
    for start in range(0, G, 16):
        cols = np.arange(start, min(G, start + 16))
        Mt = (u.index[:, None] == cols[None, :]) / u.counts[cols]
        KMt = apply(Mt)
        out[:, cols] = np.stack([np.bincount(u.index, KMt[:, j], minlength=G)
                                 for j in range(cols.size)], axis=1) / u.counts[:, None]
    return 0.5 * (out + out.T)


def _flicker_row_covariance(
    n: int, bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT
) -> NDArray[np.float64]:
    """Autocovariance at lags ``0..n`` of flicker noise over an ``n``-row record (arbitrary scale).

    The spectrum is ``1/f`` from ``f_lo = 1 / (2 s n)`` (``s`` the ``bias_time_scale`` in
    record lengths) to the Nyquist frequency (cycles per row), so
    ``c(L) = int cos(2 pi f L) / f df = Ci(pi L) - Ci(2 pi f_lo L)`` and
    ``c(0) = ln(1 / (2 f_lo))`` (Ci the cosine integral).
    """
    f_lo = _flicker_low(n, bias_time_scale)
    lag = np.arange(1, n + 1, dtype=float)
    c = np.empty(n + 1)
    c[0] = np.log(0.5 / f_lo)
    c[1:] = scipy.special.sici(np.pi * lag)[1] - scipy.special.sici(2 * np.pi * f_lo * lag)[1]
    return c


def _flicker_phi(
    n: int, lags: NDArray[np.intp], block: int = 65536,
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> tuple[float, NDArray[np.float64]]:
    """``c(0)``, and ``Phi`` at ``lags`` (sorted, ``0..n + 1``) of the flicker row covariance.

    ``Phi(k) = sum_{j<k} (c(0) / 2 + c(1) + ... + c(j))``, the even second antidifference of the
    row autocovariance ``c`` (:func:`_flicker_row_covariance`), by the same running sums as
    over the whole record (so the same numbers to the last bit), ``block`` lags at a time:
    O(block) memory instead of five arrays of the record's length (~48 MB at 1e6 rows).
    """
    f_lo = _flicker_low(n, bias_time_scale)
    c0 = float(np.log(0.5 / f_lo))
    out = np.empty(lags.size)
    s_prev = phi_prev = 0.0  # running sum of c(1..j), and Phi at the block's start
    taken = 0
    for j0 in range(0, n + 1, block):
        j1 = min(j0 + block, n + 1)
        lag = np.arange(max(j0, 1), j1, dtype=float)
        cb = scipy.special.sici(np.pi * lag)[1] - scipy.special.sici(2 * np.pi * f_lo * lag)[1]
        sums = np.cumsum(np.concatenate(([s_prev], cb)))  # sum c(1..j), j = j0 - 1 .. j1 - 1
        if j0 > 0:
            sums = sums[1:]
        phi = np.cumsum(np.concatenate(([phi_prev], c0 / 2 + sums)))  # Phi(j0 .. j1)
        stop = int(np.searchsorted(lags, j1, side="right"))
        out[taken:stop] = phi[lags[taken:stop] - j0]
        taken = stop
        s_prev, phi_prev = float(sums[-1]), float(phi[-1])
    if taken < lags.size:
        raise InputError(f"flicker kernel: lag {lags[taken]} beyond the record ({n} rows)")
    return c0, out


def _flicker_unit_kernel(
    u: _Units, bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT
) -> NDArray[np.float64]:
    """Covariance of unit means of flicker (1/f) noise of unit variance per row.

    Flicker is band-limited 1/f noise over the row index: power ``1/f`` from
    ``1/(2 s n)`` cycles per row (n rows in the record, ``s = bias_time_scale``, default 2:
    ``1/(4 n)``) to the Nyquist frequency, autocovariance by the cosine integral
    (:func:`_flicker_row_covariance`). Slower wander is a constant over the record,
    indistinguishable from the constant terms of the model. The lower edge is that of an
    ``1/f`` periodogram over ``s`` records (lines ``k / (s n)``, the first standing for the
    band from ``1/(2 s n)``), the usual way 1/f noise is synthesised (Kasdin, Proc. IEEE 83(5),
    1995, doi:10.1109/5.381848): the reported uncertainties of the constant terms match the
    scatter under such noise with a history of ``s`` records, i.e. they are uncertainties of
    the constant terms as the mean over a time of ``s`` test durations that holds the test
    (Monte Carlo in the procedures' tests). For 1/f noise the variance of a mean grows as the
    logarithm of that time, so a bias-type term has a std only for a stated time scale; the
    terms that change sign within the test (slopes, harmonics) barely depend on it. An
    earlier kernel, a sum of AR(1) processes with correlation times 1, 4, 16, ... rows up to
    a quarter of the record (Keshner, Proc. IEEE 70(3), 1982), is flat below
    ``1/(2 pi n / 4)`` and so put too much of the flicker into the record mean relative to
    the residuals: the biases of a 12-position triad test came out 1.2-1.4x conservative.

    Notes
    -----
    With ``Phi`` the even second antidifference of the row autocovariance ``c``
    (``Phi(d + 1) - 2 Phi(d) + Phi(d - 1) = c(d)``, ``Phi(0) = 0``), the sum of ``c(b - a)``
    over rows ``a`` in ``[a0, a1)`` and ``b`` in ``[b0, b1)`` is
    ``Phi(b1 - a0) - Phi(b1 - a1) - Phi(b0 - a0) + Phi(b0 - a1)``.
    """
    n = u.n_rows
    if u.contiguous:
        a0, a1 = u.first.astype(np.intp), u.last.astype(np.intp) + 1
        lags = [np.abs(a1[None, :] - a0[:, None]), np.abs(a1[None, :] - a1[:, None]),
                np.abs(a0[None, :] - a0[:, None]), np.abs(a0[None, :] - a1[:, None])]
        want = np.unique(np.concatenate([d.ravel() for d in lags]))
        c0, phi = _flicker_phi(n, want, bias_time_scale=bias_time_scale)

        def Phi(d: NDArray[np.intp]) -> NDArray[np.float64]:
            return phi[np.searchsorted(want, d)]

        S = Phi(lags[0]) - Phi(lags[1]) - Phi(lags[2]) + Phi(lags[3])
        K = S / np.outer(u.counts, u.counts)
        return 0.5 * (K + K.T) / c0
    c = _flicker_row_covariance(n, bias_time_scale)
    col = c[:n] / c[0]
    return _generic_unit_kernel(
        u, lambda v: scipy.linalg.matmul_toeplitz((col, col), v, check_finite=False))


@dataclass(frozen=True)
class _Reml:
    """REML criterion on the unit means (Patterson & Thompson, Biometrika 58(3), 1971).

    The covariance of the unit means is ``s2 * (W + theta K)`` with ``W`` diagonal (white
    noise) and ``K`` a component; ``s2 = 1`` when the white level is known, else profiled out.
    One eigendecomposition of ``W^-1/2 K W^-1/2`` makes every evaluation cheap.
    """

    u: _Units
    basis: NDArray[np.float64]  # orthonormal basis of the column space of the unit design
    white: NDArray[np.float64]  # diagonal of W
    scale_known: bool

    @property
    def dof(self) -> int:
        return self.u.size - self.basis.shape[1]

    def criterion(
        self, K: NDArray[np.float64] | None
    ) -> Callable[[float], tuple[float, float]]:
        """``theta -> (negative restricted log-likelihood, scale s2)`` for component ``K``."""
        sw = np.sqrt(self.white)
        if K is None:
            lam, Xt, yt = np.zeros(self.u.size), self.basis / sw[:, None], self.u.y / sw
        else:
            lam, Qe = np.linalg.eigh(K / np.outer(sw, sw))
            lam = np.clip(lam, 0.0, None)
            Xt, yt = Qe.T @ (self.basis / sw[:, None]), Qe.T @ (self.u.y / sw)
        logdet_w = float(np.sum(np.log(self.white)))
        dof = self.dof

        def nll(theta: float) -> tuple[float, float]:
            d = 1.0 + theta * lam
            sd = np.sqrt(d)
            q, r = np.linalg.qr(Xt / sd[:, None])
            yw = yt / sd
            res = yw - q @ (q.T @ yw)
            rss = float(res @ res)
            logdet = logdet_w + float(np.sum(np.log(d))) + 2 * float(
                np.sum(np.log(np.abs(np.diag(r)))))
            if self.scale_known:
                return 0.5 * (logdet + rss), 1.0
            s2 = max(rss / dof, 1e-300)
            return 0.5 * (logdet + dof * np.log(s2) + dof), s2

        return nll

    def fit(self, K: NDArray[np.float64], ref: float) -> tuple[float, float]:
        """``theta >= 0`` minimising the criterion (grid, then Brent), and the minimum."""
        nll = self.criterion(K)
        # Up to 1e8 x the white variance of a unit mean: long units (a centrifuge run of
        # thousands of samples) make even modest offsets that many times larger.
        grid = ref * np.logspace(-4, 8, 25)
        vals = [nll(t)[0] for t in grid]
        i = int(np.argmin(vals))
        best_t, best = float(grid[i]), float(vals[i])
        lo, hi = np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, grid.size - 1)])
        opt_x, opt_fun = _bounded_minimum(lambda lt: nll(float(np.exp(lt)))[0], lo, hi,
                                          xatol=1e-3)
        if opt_fun < best:
            best_t, best = float(np.exp(opt_x)), float(opt_fun)
        zero = nll(0.0)[0]
        return (0.0, zero) if zero <= best else (best_t, best)


def _bounded_minimum(
    func: Callable[[float], float], lo: float, hi: float, *, xatol: float, maxiter: int = 500,
) -> tuple[float, float]:
    """Minimum of ``func`` on ``[lo, hi]``: Brent's golden-section search with parabolic steps.

    The algorithm of ``scipy.optimize.minimize_scalar(method="bounded")`` (``fminbound``:
    Forsythe, Malcolm & Moler, *Computer Methods for Mathematical Computations*, Prentice-Hall
    1977; Brent, *Algorithms for Minimization Without Derivatives*, 1973), transcribed step for
    step from SciPy 1.17 (BSD-3-Clause) so that the same iterates give the same numbers (tested)
    without importing scipy.optimize (~0.1 s of every fit's start-up). Returns ``(x, f(x))``.
    """
    sqrt_eps = np.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - np.sqrt(5.0))
    a, b = lo, hi
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = func(x)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while np.abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = True
        if np.abs(e) > tol1:  # try a parabola through the three best points
            golden = False
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = np.abs(q)
            r = e
            e = rat
            if (np.abs(p) < np.abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
                rat = (p + 0.0) / q
                x = xf + rat
                if ((x - a) < tol2) or ((b - x) < tol2):
                    rat = tol1 * (np.sign(xm - xf) + ((xm - xf) == 0))
            else:
                golden = True
        if golden:
            e = a - xf if xf >= xm else b - xf
            rat = golden_mean * e
        x = xf + (np.sign(rat) + (rat == 0)) * np.maximum(np.abs(rat), tol1)
        fu = func(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return float(xf), float(fx)


def solve(
    A: ArrayLike | PositionDesign,
    y: ArrayLike,
    *,
    sigma_si: float | ArrayLike | None = None,
    groups: ArrayLike | None = None,
    noise_model: str = "auto",
    alpha: float = CHECK_ALPHA,
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> tuple[LinearFit, NoiseFit]:
    """Least squares under a noise model of the instrument, with model checks.

    Parameters
    ----------
    A : array_like, shape (n, p), or PositionDesign
        Design, one row per reading in time order; or a :class:`PositionDesign` (then no
        ``groups``: its positions are the units), solved from the count, mean and sum of
        squares of each position, never building the ``n x p`` design (same estimates).
    y : array_like, shape (n,)
        Readings.
    sigma_si : float or array_like, optional
        Known white noise per reading (units of ``y``); estimated when omitted.
    groups : array_like of str, shape (n,), optional
        Unit of independence of each row (the position or run it belongs to). Rows of a unit
        share the design row. Without groups every reading is its own unit.
    noise_model : str
        One of :data:`NOISE_MODELS`:

        ``white``
            Independent readings: ordinary (weighted) least squares over the rows, the noise
            from the residuals (the classical solution).
        ``position-offsets``
            White noise plus a random offset per unit (the table re-settles, the drift moves
            between positions): one-way random effects. The white variance comes from the
            scatter within units, the offset variance by REML from the unit means, and the
            unit means are fitted by GLS with weights ``1/(sigma_b^2 + sigma_w^2/n_g)``.
        ``random-walk``
            White noise plus a random walk over the row index (a drift that wanders during the
            test); its step variance by REML, GLS over the unit means.
        ``flicker``
            White noise plus flicker (1/f) noise over the row index, band-limited from
            ``1 / (2 bias_time_scale)`` cycles per record (:func:`_flicker_unit_kernel`).
            The std of a constant (bias-type) term is then that of the term as its mean over
            ``bias_time_scale`` test durations holding the test (default 2: about the bias
            during this test); the long-term bias wanders by the bias instability beyond it.
        ``auto``
            Every model above fitted on the restricted likelihood of the unit means; white
            unless a correlated model beats it by the likelihood-ratio test (boundary
            corrected, :data:`AUTO_ALPHA` for the family), else the correlated model of
            smallest AIC gives the estimate (``white`` when the noise is given or too few
            units are left to tell; :func:`common_noise_model`), and the uncertainty of
            that choice is added to its covariance: the weighted spread of the estimates of
            the models within :data:`AUTO_CLOSE_AIC` of it (:func:`_with_selection_spread`).
            With few positions the models are hard to tell apart (flicker from random walk
            or offsets); the best model alone gave reported std / scatter down to 0.70 under
            flicker, with the spread 0.83-1.23 under each noise (Monte Carlo in the tests).
            Every candidate's weight is in ``NoiseFit.weights``.
    alpha : float
        Significance level of the model checks.
    bias_time_scale : float
        Time over which the constant terms are meant under ``flicker`` (and the flicker
        candidate of ``auto``), in test durations, at least 1: e.g. the calibration interval
        divided by the test's duration, so that their std includes the slow wander of the
        bias over that interval (:data:`BIAS_TIME_SCALE_DEFAULT`: about the test itself).

    Returns
    -------
    fit : LinearFit
        Estimate and covariance under the noise model; ``residuals`` per row, ``sigma`` the
        white noise per reading, ``dof`` the residual degrees of freedom of the units.
    noise : NoiseFit
        The noise model used, its components and :class:`~inertest.results.ModelChecks`.

    Notes
    -----
    The reported standard uncertainty is honest only when the noise model describes the data;
    the checks test that: a variance test (chi-square against a given noise, or the lack-of-fit
    F test of the unit means against the scatter within units), the Ljung-Box test of the
    whitened unit residuals in time order, and studentised unit residuals above a
    Bonferroni bound. Patterson & Thompson, Biometrika 58(3), 1971,
    doi:10.1093/biomet/58.3.545 (REML); Searle, Casella & McCulloch, *Variance Components*,
    Wiley 1992, ch. 3 (one-way random effects).
    """
    if noise_model not in NOISE_MODELS:
        raise InputError(
            f'unknown noise model "{noise_model}"; use one of {", ".join(NOISE_MODELS)}')
    check_bias_time_scale(bias_time_scale)
    y = np.asarray(y, dtype=float)
    if isinstance(A, PositionDesign):
        # Per-position sufficient statistics: the n x p design is never built.
        if groups is not None:
            raise InputError("a PositionDesign names its positions; give no groups with it")
        if y.shape != (A.index.size,):
            raise InputError(f"design of {A.index.size} readings and observations {y.shape} "
                             "do not match")
        u = _position_units(A, y)
        row_fit = _position_row_fit(A, u, y, sigma_si)
    else:
        A = np.asarray(A, dtype=float)
        row_fit = weighted_least_squares(A, y, sigma=sigma_si)
        u = _units(A, y, groups)
    G, n = u.size, y.size
    given = sigma_si is not None
    if given:
        s2_rows = np.broadcast_to(np.asarray(sigma_si, dtype=float) ** 2, (n,))
        white_diag = np.bincount(u.index, s2_rows) / u.counts**2
        sw2 = float(np.mean(s2_rows))
    else:
        dof_w = n - G
        sw2 = sum_of_squares(y, u.y, u.index) / dof_w if dof_w > 0 else np.nan
        white_diag = (sw2 if dof_w > 0 else 1.0) / u.counts
    scale_known = given or n > G
    r = row_fit.rank
    can_estimate = (G <= _MAX_UNITS and G - r >= _MIN_UNIT_DOF
                    and (scale_known or G - r > _MIN_UNIT_DOF))
    if noise_model not in ("white", "auto") and not can_estimate:
        raise IdentifiabilityError(
            f"{G} positions/runs for {r} independent unknowns: too "
            + ("many to model" if G > _MAX_UNITS else "few to estimate")
            + f' the "{noise_model}" noise; '
            + ("give the position of each reading (groups)" if G > _MAX_UNITS
               else "add positions")
            + ', or use noise_model = "white"')
    kernels: dict[str, Callable[[], NDArray[np.float64]]] = {
        "position-offsets": lambda: np.eye(G),
        "random-walk": lambda: _rw_unit_kernel(u),
        "flicker": lambda: _flicker_unit_kernel(u, bias_time_scale),
    }
    if n == G and not given:
        kernels.pop("position-offsets")  # no repeated readings: offsets are white noise
    consider = [m for m in kernels if noise_model in ("auto", m)]
    if not can_estimate or (noise_model == "auto" and given):
        consider = []
    # Candidates: (AIC of the restricted likelihood, theta, kernel of mean diagonal 1, its
    # scale c); white first, with no component (one parameter fewer).
    cands: dict[str, tuple[float, float, NDArray[np.float64] | None, float]] = {}
    reml: _Reml | None = None
    if consider:
        Xs = u.A / np.where(np.linalg.norm(u.A, axis=0) > 0, np.linalg.norm(u.A, axis=0), 1.0)
        U, _, _ = np.linalg.svd(Xs, full_matrices=False)
        reml = _Reml(u, U[:, :r], white_diag, scale_known)
        ref = float(np.mean(white_diag)) if scale_known else 1.0
        if noise_model == "auto":
            cands["white"] = (2 * reml.criterion(None)(0.0)[0], 0.0, None, 1.0)
        for name in consider:
            Kc = kernels[name]()
            cc = float(np.mean(np.diag(Kc)))
            th, nll = reml.fit(Kc / cc, ref)
            cands[name] = (2 * nll + 2, th, Kc / cc, cc)
    model = (common_noise_model([{m: a for m, (a, *_) in cands.items()}])[0]
             if noise_model == "auto" and len(cands) > 1
             else min(cands, key=lambda m: cands[m][0]) if cands else "white")

    def under(m: str) -> tuple[LinearFit, NDArray[np.float64], dict[str, float]]:
        """Fit, unit covariance and noise components under candidate ``m``."""
        _, th, Km, cm = cands.get(m, (0.0, 0.0, None, 1.0))
        if Km is None:
            Vm: NDArray[np.float64] = white_diag if given else row_fit.sigma**2 / u.counts
            return row_fit, Vm, {"white": _given_sigma(sigma_si) if given
                                 else float(row_fit.sigma)}
        assert reml is not None
        s2 = reml.criterion(Km)(th)[1]
        Vm = s2 * (np.diag(white_diag) + th * Km)
        L = np.linalg.cholesky(Vm)
        Aw = scipy.linalg.solve_triangular(L, u.A, lower=True)
        yw = scipy.linalg.solve_triangular(L, u.y, lower=True)
        gls = weighted_least_squares(Aw, yw, sigma=1.0)
        wsig2 = sw2 if scale_known else s2
        fm = replace(gls, residuals=_residuals(A, gls.x, y), sigma=float(np.sqrt(wsig2)),
                     sigma_from_residuals=not given, dof=G - gls.rank)
        label = {"position-offsets": "position offset", "random-walk": "random walk",
                 "flicker": "flicker"}[m]
        # Km was divided by cm (mean diagonal 1): the component's size per reading.
        return fm, Vm, {"white": _given_sigma(sigma_si) if given else float(np.sqrt(wsig2)),
                        label: float(np.sqrt(s2 * th / cm))}

    fit, V, components = under(model)
    weights: dict[str, float] = {}
    aic: dict[str, float] = {}
    x_checked = fit.x
    near = [model]
    if noise_model == "auto" and len(cands) > 1:
        aic = {m: a for m, (a, *_) in cands.items()}
        _, weights, near = common_noise_model([aic])
        if len(near) > 1:
            fit = _with_selection_spread(
                fit, {m: x_checked if m == model else under(m)[0].x for m in near},
                {m: weights[m] for m in near})
    checks = _checks(u, x_checked, V, model, given, sw2 if n > G else np.nan, alpha)
    implausible = _plausibility(components)
    if implausible is not None:
        checks = replace(checks, plausibility=implausible, verdict="model does not fit")
    checks = _with_message(checks)
    noise = NoiseFit(model=model, white_sigma=components["white"], sigma_given=given,
                     components=components, unit_index=u.index, unit_labels=u.labels,
                     unit_covariance=V, checks=checks, weights=weights, aic=aic,
                     bias_time_scale=float(bias_time_scale) if "flicker" in near else None)
    if not checks.fits:
        warnings.warn(str(checks.message), InertestWarning, stacklevel=3)
    return fit, noise


def common_noise_model(aic: Sequence[Mapping[str, float]]
                       ) -> tuple[str, dict[str, float], list[str]]:
    """The choice of ``auto`` for one or several outputs described by one noise model.

    ``aic``: per output, the AIC of each candidate model, ``white`` (no variance component)
    among them: ``2 nll`` for white and ``2 nll + 2`` for a correlated model (nll the negative
    restricted log-likelihood). The outputs' noises are independent, so the joint model's
    log-likelihood is the sum. The criterion is ``2 nll`` summed over the outputs, plus, for a
    correlated model, :func:`component_penalty` of its ``k`` components (one per output)
    instead of AIC's ``2 k``: a correlated model is chosen only when it beats white by the
    likelihood-ratio test at :data:`AUTO_ALPHA` for the family of candidates, and among those
    that do, the one of highest likelihood (as by AIC: each has one component per output).

    Returns the model of smallest criterion, the weights ``exp(-delta / 2)`` of the criterion
    (Akaike weights, with the test's penalty), and the models within :data:`AUTO_CLOSE_AIC`
    per output of the best (the best first), whose per-output estimates give each output's
    spread (:func:`selection_spread`) with those weights.

    Why not AIC alone: the variance component is on the boundary of its space under white
    noise, so the likelihood-ratio statistic of each candidate is ``0.5 chi2_0 + 0.5 chi2_1``
    (Self & Liang, JASA 82(398), 1987, doi:10.1080/01621459.1987.10478472), and AIC takes
    one of three candidates on about one white record in eight: the gyro rate table's bias
    came out 1.27x conservative under white noise (a random walk's variance of the bias
    includes the walk's level), 1.10 with the test. Why the close set grows with the outputs:
    the pooled criterion's differences add up over them; a cut at 2 for three gyros left
    flicker out of the spread when a random walk was chosen under flicker, whose bias is
    then poorly estimated (gyro triad rotation: 0.78, 0.85 with 2 per output).
    """
    names = list(aic[0])
    k = len(aic)
    pen = component_penalty(k, sum(m != "white" for m in names))
    crit = {m: float(sum(a[m] for a in aic)) for m in names}
    crit = {m: c if m == "white" else c - 2 * k + pen for m, c in crit.items()}
    best = min(crit, key=lambda m: crit[m])
    near = [best, *(m for m in names
                    if m != best and crit[m] <= crit[best] + AUTO_CLOSE_AIC * k)]
    return best, _akaike_weights(crit), near


@functools.lru_cache(maxsize=64)
def component_penalty(outputs: int, candidates: int, alpha: float = AUTO_ALPHA) -> float:
    """Critical value of the likelihood-ratio test of white noise against a correlated model.

    The model adds one variance component per output (``outputs`` of them, independent), each
    zero under white noise, on the boundary of its space: the statistic
    ``2 (nll_white - nll_model)`` is then chi-bar-square, ``sum_j C(k, j) 2^-k chi2_j`` over
    ``j = 0..k`` (Self & Liang, JASA 82(398), 1987, doi:10.1080/01621459.1987.10478472,
    case 6). Returned: its upper ``alpha / candidates`` point (Bonferroni over the correlated
    candidates, so that white data choose one of them with probability at most ``alpha``).
    One output, three correlated candidates (``alpha`` 0.05): 4.53, where AIC's penalty of 2 is the
    point at 0.079 for each candidate.
    """
    k = int(outputs)
    level = alpha / max(int(candidates), 1)
    p = np.array([float(scipy.special.comb(k, j)) for j in range(1, k + 1)]) / 2.0**k

    def tail(c: float) -> float:
        return float(p @ scipy.special.chdtrc(np.arange(1, k + 1), c))

    lo, hi = 0.0, 1.0
    while tail(hi) > level:
        lo, hi = hi, 2 * hi
    for _ in range(100):  # bisection: tail decreases with c
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if tail(mid) > level else (lo, mid)
    return 0.5 * (lo + hi)


def solve_outputs(
    A: ArrayLike,
    Y: ArrayLike,
    *,
    sigma_si: float | ArrayLike | None = None,
    groups: ArrayLike | None = None,
    noise_model: str = "auto",
    alpha: float = CHECK_ALPHA,
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> list[tuple[LinearFit, NoiseFit]]:
    """:func:`solve` for each column of ``Y`` (shape (n, k)) over one design, one noise model.

    With ``auto`` the model is common to the outputs (a triad's axes are described alike):
    :func:`common_noise_model` of their AICs (the likelihood-ratio test against white noise
    and AIC, pooled over the outputs), each output's covariance plus the spread of its
    estimates under the models within :data:`AUTO_CLOSE_AIC` per output of it, with the
    weights of the pooled criterion. ``NoiseFit.weights`` holds those
    common weights, ``NoiseFit.aic`` the output's own AICs. Refitting every output with the
    model picked most often and no spread gave reported std / scatter 0.74 under a random
    walk (triad multiposition); adding each output's own spread back onto that refit, 1.40
    under position offsets.
    """
    Y = np.asarray(Y, dtype=float)

    def one(i: int, m: str) -> tuple[LinearFit, NoiseFit]:
        return solve(A, Y[:, i], sigma_si=sigma_si, groups=groups, noise_model=m, alpha=alpha,
                     bias_time_scale=bias_time_scale)

    k = Y.shape[1]
    if noise_model != "auto":
        return [one(i, noise_model) for i in range(k)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)  # warned below, for the model used
        first = [one(i, "auto") for i in range(k)]
    if not first[0][1].aic:  # noise given, or too few units: white, as solve decides
        return [one(i, "auto") for i in range(k)]
    model, weights, near = common_noise_model([nf.aic for _, nf in first])
    out = []
    for i in range(k):
        fit, noise = one(i, model)
        if len(near) > 1:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", InertestWarning)
                x = {m: fit.x if m == model else one(i, m)[0].x for m in near}
            fit = _with_selection_spread(fit, x, {m: weights[m] for m in near})
        out.append((fit, replace(noise, weights=weights, aic=first[i][1].aic,
                                 bias_time_scale=float(bias_time_scale) if "flicker" in near
                                 else None)))
    return out


def _with_selection_spread(
    best: LinearFit, x: Mapping[str, NDArray[np.float64]], weights: Mapping[str, float],
) -> LinearFit:
    """The AIC-best fit with the uncertainty of the choice of noise model added (``auto``).

    ``x``: the estimates of the models the data cannot tell from the best (within
    :data:`AUTO_CLOSE_AIC` of it, the best included), ``weights`` their Akaike weights
    ``exp(-dAIC_m / 2)`` (renormalised here over them). The estimate stays the best
    model's, ``x_b``; its covariance gains the spread of the close models' estimates:
    ``C = C_b + sum w_m (x_m - x_b)(x_m - x_b)^T``, the between-model term of Buckland,
    Burnham & Augustin, Biometrics 53(2), 1997, doi:10.2307/2533961 (Burnham & Anderson,
    *Model Selection and Multimodel Inference*, 2nd ed., Springer 2002, sec. 4.3.2).

    Why not their full model average: averaging the estimates would make the reported value
    that of no model (the closed forms agree with the white fit, not with a mixture), and
    averaging the candidates' own covariances overshoots, since a wrong model's covariance is
    itself wrong (flicker fitted to position offsets is up to 2x conservative, offsets fitted to
    flicker up to 2x optimistic). Why not the largest covariance among the close models: with
    12-24 positions flicker is often within 2 AIC of true position offsets, and taking it gave
    std / scatter up to 1.54. Monte Carlo in tests/estimation/test_identify.py.
    """
    cov = best.covariance + selection_spread(best.x, x, weights, best.null_space)
    return replace(best, covariance=0.5 * (cov + cov.T))


def selection_spread(
    x_best: ArrayLike, x: Mapping[str, ArrayLike], weights: Mapping[str, float],
    null_space: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """``sum w_m (x_m - x_b)(x_m - x_b)^T``, the weights renormalised over ``x``'s models.

    The between-model term of ``auto`` (:func:`_with_selection_spread`), also for procedures
    with their own noise models; ``null_space`` (orthonormal columns): directions the data do
    not determine, removed from the differences.
    """
    names = list(x)
    w = np.array([weights[m] for m in names])
    w /= w.sum()
    D = np.array([np.asarray(x[m], dtype=float) for m in names]) - np.asarray(x_best, float)
    if null_space is not None and np.shape(null_space)[1]:
        N = np.asarray(null_space, dtype=float)
        D = D - (D @ N) @ N.T  # only identifiable directions carry the spread
    S: NDArray[np.float64] = (D.T * w) @ D
    return 0.5 * (S + S.T)


def _akaike_weights(aic: Mapping[str, float]) -> dict[str, float]:
    """``exp(-dAIC / 2)`` normalised over the candidates."""
    lo = min(aic.values())
    w = {m: float(np.exp(-0.5 * (a - lo))) for m, a in aic.items()}
    total = sum(w.values())
    return {m: v / total for m, v in w.items()}


def _given_sigma(sigma_si: float | ArrayLike | None) -> float:
    """The given white noise per reading as reported: itself, or the RMS of per-row values."""
    s = np.asarray(sigma_si, dtype=float)
    return float(s) if s.ndim == 0 else float(np.sqrt(np.mean(s**2)))


def model_checks(
    residuals: ArrayLike,
    design: ArrayLike,
    covariance: ArrayLike,
    *,
    noise_model: str,
    sigma_given: bool,
    labels: Sequence[str] | None = None,
    unit: str = "reading",
    alpha: float = CHECK_ALPHA,
) -> ModelChecks:
    """Model checks of a fit made outside :func:`solve` (a procedure's own GLS).

    Parameters
    ----------
    residuals : array_like, shape (G,)
        Observation minus fitted model, one per unit of independence, in time order.
    design : array_like, shape (G, p)
        Design of the fit (any scaling of its columns).
    covariance : array_like, shape (G, G) or (G,)
        Covariance of the observations under the fitted noise model (its diagonal when white).
    noise_model : str
        Name of the fitted noise model.
    sigma_given : bool
        True when the noise level was given (the chi-square is then a test; otherwise the level
        was fitted to the same residuals and only the serial test and the outliers test).
    labels : sequence of str, optional
        Name of each unit (for the outliers); default ``reading k``.
    unit : str
        What a unit is (``window``, ``face``...).
    alpha : float
        Significance level of the tests.

    Returns
    -------
    ModelChecks
        Chi-square of the residuals standardised by the noise model (dof and p when it is a
        test), Ljung-Box test of the standardised residuals, studentised outliers above a
        Bonferroni bound, verdict; see :func:`solve`.
    """
    e = np.asarray(residuals, dtype=float)
    A = np.asarray(design, dtype=float)
    V = np.asarray(covariance, dtype=float)
    G = e.size
    if A.shape[0] != G or V.shape[0] != G:
        raise InputError(f"residuals ({G}), design ({A.shape[0]}) and covariance "
                         f"({V.shape[0]}) must have one row per unit")
    idx = np.arange(G, dtype=np.intp)
    u = _Units(index=idx, labels=None if labels is None else tuple(labels), counts=np.ones(G),
               first=idx, last=idx, y=e, A=A, n_rows=G)
    c = _checks(u, np.zeros(A.shape[1]), V, noise_model, sigma_given, np.nan, alpha)
    return _with_message(replace(c, unit=unit))


def _checks(
    u: _Units, x: NDArray[np.float64], V: NDArray[np.float64], model: str, given: bool,
    sw2: float, alpha: float,
) -> ModelChecks:
    """Variance test, Ljung-Box test and outliers of the whitened unit residuals."""
    G = u.size
    resid = u.y - u.A @ x
    if V.ndim == 1:
        sd = np.sqrt(V)
        Xw, e = u.A / sd[:, None], resid / sd
    else:
        L = np.linalg.cholesky(V)
        Xw = scipy.linalg.solve_triangular(L, u.A, lower=True)
        e = scipy.linalg.solve_triangular(L, resid, lower=True)
    Us, sv, _ = np.linalg.svd(Xw, full_matrices=False)
    r = int(np.sum(sv > DEFAULT_RCOND * sv[0])) if sv.size and sv[0] > 0 else 0
    Q = Us[:, :r]
    h = np.sum(Q**2, axis=1)
    dof = G - r
    chi2 = float(e @ e)
    p: float | None = None
    if given and model == "white":
        statistic = "chi-square of the whitened unit residuals against the given noise"
        p = _chi2_sf(chi2, dof) if dof > 0 else None
    elif model == "white" and np.isfinite(sw2) and dof > 0:
        statistic = ("lack of fit: scatter of the unit means about the model against the "
                     "scatter within units (dof * F)")
        F = float(np.sum(u.counts * resid**2)) / dof / sw2
        chi2 = dof * F
        p = float(scipy.special.fdtrc(dof, u.n_rows - G, F))  # = scipy.stats.f.sf
    else:
        statistic = ("sum of squared whitened unit residuals (noise level fitted to these "
                     "residuals: not a test)")
    serial = serial_p = None
    lags = min(10, G // 5)
    if G >= 10 and dof > lags and chi2 > 0:
        # Portmanteau of the lag-k products e'S_k e (S_k the symmetric lag-k shift / 2), each
        # standardised by its exact mean and variance under the model, e ~ N(0, I - Q Q'):
        # mean -tr(Q'S_k Q), variance 2 tr(R S_k R S_k) = (G-k)/2 - 2|S_k Q|^2 + |Q'S_k Q|^2
        # (quadratic forms in normal variables), so that the fitted directions (smooth in
        # time for a tumble) bias neither its mean nor its spread. Residuals far below the
        # noise level (noise-free data) are scaled by the expected sum, not their own.
        es = e * np.sqrt(dof / max(float(e @ e), float(dof)))
        serial = 0.0
        for k in range(1, lags + 1):
            SQ = np.zeros_like(Q)
            SQ[:-k] += 0.5 * Q[k:]
            SQ[k:] += 0.5 * Q[:-k]
            QSQ = Q.T @ SQ
            mean = -float(np.trace(QSQ))
            var = 2 * ((G - k) / 2 - 2 * float(np.sum(SQ**2)) + float(np.sum(QSQ**2)))
            serial += (float(es[:-k] @ es[k:]) - mean) ** 2 / max(var, 1e-300)
        serial_p = _chi2_sf(serial, lags)
    z = e / np.sqrt(np.clip(1 - h, 1e-12, None))
    thr = max(4.0, -float(scipy.special.ndtri(alpha / (2 * G))))  # = scipy.stats.norm.isf
    outliers = tuple(Outlier(u.label(int(i)), float(z[i]))
                     for i in np.flatnonzero(np.abs(z) > thr))
    # Residuals at the rounding level of the data (noise-free data) test nothing.
    rounding = float(np.max(np.abs(resid), initial=0.0)) <= 1e-9 * float(
        np.max(np.abs(u.y), initial=0.0))
    shift_units, shift_f, shift_dof, shift_p = _mean_shift(
        e, Q, 0 if rounding else dof, u.label, scale_known=given and model == "white")
    bad = any(q is not None and q < alpha for q in (p, serial_p, shift_p))
    return ModelChecks(
        noise_model=model, unit="reading" if u.labels is None else "position",
        n_units=G, statistic=statistic, chi_square=chi2, dof=dof, p_value=p,
        serial_chi_square=serial, serial_dof=lags if serial is not None else 0,
        serial_p_value=serial_p, outliers=outliers, outlier_threshold=thr, alpha=alpha,
        verdict="model does not fit" if bad or outliers else "consistent",
        shift_units=shift_units, shift_f=shift_f, shift_dof=shift_dof, shift_p_value=shift_p)


def _with_message(c: ModelChecks) -> ModelChecks:
    """``c`` with its :attr:`~inertest.results.ModelChecks.message` (None when it fits)."""
    return replace(c, message=None if c.fits else _misfit_message(c))


def _mean_shift(
    e: NDArray[np.float64], Q: NDArray[np.float64], dof: int, label: Callable[[int], str],
    *, scale_known: bool = False,
) -> tuple[tuple[str, ...], float | None, tuple[int, int], float | None]:
    """Most significant shift of one or two units against the scatter of the others.

    ``e``: whitened unit residuals, ``Q``: orthonormal basis of the fitted directions. For a
    set ``S`` of one or two units, adding a free mean to each (the mean-shift outlier model)
    lowers the residual sum of squares by ``d_S = e_S' (I - QQ')_SS^-1 e_S``; under the model
    ``F_S = (d_S / |S|) / ((|e|^2 - d_S) / (dof - |S|))`` is ``F(|S|, dof - |S|)`` whatever the
    level of the noise, so the test holds when that level was fitted to these same residuals
    (Cook & Weisberg, *Residuals and Influence in Regression*, Chapman & Hall 1982, sec. 2.2).
    The p-value is Bonferroni over the ``G`` single units and the ``G (G - 1) / 2`` pairs
    (pairs only up to :data:`_MAX_PAIR_UNITS` units): a swapped pair of labels shifts two units
    by opposite amounts that the fit spreads over the others, masking each unit on its own.
    With ``scale_known`` (``e`` whitened by a given noise level) the others' variance is taken
    as at least 1, the level given: residuals far below it (noise-free data) test nothing.
    Returns the units, ``F``, its dof and the p-value (None when there are too few dof).
    """
    G = e.size
    rss = float(e @ e)
    if dof < 3 or rss <= 0:
        return (), None, (0, 0), None
    m = np.clip(1.0 - np.sum(Q**2, axis=1), 0.0, None)  # diagonal of I - QQ'
    ok = m > 1e-8
    best: tuple[tuple[int, ...], float, tuple[int, int], float] = ((), 0.0, (0, 0), 1.0)
    pairs = dof >= 4 and 2 <= G <= _MAX_PAIR_UNITS
    tests = G + (G * (G - 1) // 2 if pairs else 0)
    floor = 1.0 if scale_known else 0.0
    d1 = np.where(ok, e**2 / np.where(ok, m, 1.0), 0.0)
    rest = np.maximum(rss - d1, 1e-12 * rss)  # all the misfit in the tested units: F large
    f1 = d1 / np.maximum(rest / (dof - 1), floor)
    i = int(np.argmax(f1))
    p1 = min(1.0, tests * float(scipy.special.fdtrc(1, dof - 1, f1[i])))
    if ok[i]:
        best = ((i,), float(f1[i]), (1, dof - 1), p1)
    if pairs:
        M = -(Q @ Q.T)
        M[np.diag_indices(G)] = m
        iu, ju = np.triu_indices(G, 1)
        a, b, c = m[iu], m[ju], M[iu, ju]
        det = a * b - c**2
        good = det > 1e-8 * np.maximum(a * b, 1e-300)
        det = np.where(good, det, 1.0)
        ei, ej = e[iu], e[ju]
        d2 = np.where(good, (b * ei**2 - 2 * c * ei * ej + a * ej**2) / det, 0.0)
        rest2 = np.maximum(rss - d2, 1e-12 * rss)
        f2 = (d2 / 2) / np.maximum(rest2 / (dof - 2), floor)
        k = int(np.argmax(f2))
        p2 = min(1.0, tests * float(scipy.special.fdtrc(2, dof - 2, f2[k])))
        if good[k] and p2 < best[3]:
            best = ((int(iu[k]), int(ju[k])), float(f2[k]), (2, dof - 2), p2)
    if not best[0]:
        return (), None, (0, 0), None
    return tuple(label(j) for j in best[0]), best[1], best[2], best[3]


def _plausibility(components: Mapping[str, float]) -> str | None:
    """Why the fitted position offsets are implausible, or None.

    An offset per position whose std is more than :data:`OFFSET_PLAUSIBLE_RATIO` times the
    white noise per reading is what a wrong label (two positions swapped, an angle read off)
    or a missing term looks like once ``position-offsets`` absorbs it: the variance test is
    then no test (the offset level is fitted to the same residuals), and the estimates carry
    the misfit with a std to match. A fixture that really re-settles that much calls for a
    better fixture or for the noise given (``--sigma``).
    """
    offset, white = components.get("position offset"), components.get("white")
    if offset is None or white is None or not (white > 0):
        return None
    ratio = offset / white
    if not ratio > OFFSET_PLAUSIBLE_RATIO:
        return None
    return (f"the fitted position offsets (std {ratio:.3g} times the noise per reading, above "
            f"{OFFSET_PLAUSIBLE_RATIO:g}) are implausible for a fixture: a wrong label or a "
            "missing term taken for offsets")


def _misfit_message(c: ModelChecks) -> str:
    why = []
    if c.p_value is not None and c.p_value < c.alpha:
        why.append(f"residuals too large (chi-square {c.chi_square:.4g} for {c.dof} dof, "
                   f"p = {c.p_value:.2g})")
    if c.serial_p_value is not None and c.serial_p_value < c.alpha:
        why.append(f"neighbouring residuals alike (Ljung-Box {c.serial_chi_square:.4g} for "
                   f"{c.serial_dof} dof, p = {c.serial_p_value:.2g})")
    if c.outliers:
        why.append("outlying " + ", ".join(f"{o.label} (z = {o.z:+.1f})" for o in c.outliers))
    if c.shift_p_value is not None and c.shift_p_value < c.alpha:
        why.append(f"{' and '.join(c.shift_units)} off the model against the scatter of the "
                   f"other {c.unit}s (F = {c.shift_f:.4g} for {c.shift_dof[0]}, "
                   f"{c.shift_dof[1]} dof, p = {c.shift_p_value:.2g} over every one or two "
                   f"{c.unit}s)")
    if c.plausibility:
        why.append(c.plausibility)
    return (f'the model with "{c.noise_model}" noise does not fit the data: {"; ".join(why)}; '
            "check the labels (mounting, angle, position), the settling of the table, and the "
            "noise model; the uncertainties are not reliable")


def _chi2_sf(x: float, dof: int) -> float:
    """Upper tail probability of chi-square with ``dof`` degrees of freedom at ``x``.

    ``Q(dof/2, x/2)`` (regularised upper incomplete gamma), the function behind
    ``scipy.stats.chi2.sf``; scipy.special is used so that scipy.stats (~1 s to import) is
    not loaded by every fit.
    """
    return float(scipy.special.chdtrc(dof, x))
