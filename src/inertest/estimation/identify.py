"""Generic identification of a linear error model: least squares -> what the data determine.

Every static error model in inertest is linear in its coefficients (DESIGN.md). A procedure
builds the design ``A`` (SI) and observations, then calls :func:`identify`, which solves by
weighted least squares under a noise model of the instrument and expresses the result in
engineering units: individually identifiable coefficients, a basis of identifiable combinations
of the rest, and the null space in words.

The parts, each written once: the rows reduced to units of independence
(:mod:`~inertest.estimation.units`), the noise models as values
(:mod:`~inertest.estimation.noise_models`), REML and GLS (:mod:`~inertest.estimation.reml`),
the choice of ``auto`` (:mod:`~inertest.estimation.selection`) and the model checks
(:mod:`~inertest.estimation.model_checks`); :func:`solve` puts them together.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InertestWarning, InputError
from inertest.estimation.least_squares import (
    LinearFit,
    identifiable_combinations,
    weighted_least_squares,
)
from inertest.estimation.model_checks import CHECK_ALPHA, plausibility, unit_checks, with_message
from inertest.estimation.noise_models import (
    BIAS_TIME_SCALE_DEFAULT,
    CORRELATED,
    MODELS,
    NOISE_MODELS,
    check_bias_time_scale,
)
from inertest.estimation.reml import Component, Reml, components, gls
from inertest.estimation.selection import common_noise_model, with_selection_spread
from inertest.estimation.units import (
    PositionDesign,
    position_row_fit,
    position_units,
    residuals_of,
    units_of_rows,
)
from inertest.results import Combination, Estimate, Identification, ModelChecks, sum_of_squares

#: Explains the null space of a fit in words: (fit, design) -> statements.
Explainer = Callable[[LinearFit, NDArray[np.float64]], Sequence[str]]


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

#: Units needed beyond the rank before a variance component is estimated.
_MIN_UNIT_DOF = 4
#: Largest number of units for which a correlated noise model is fitted (dense G x G).
_MAX_UNITS = 2000


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
            ``1 / (2 bias_time_scale)`` cycles per record (:func:`flicker_unit_kernel`).
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
            the models within :data:`AUTO_CLOSE_AIC` of it (:func:`with_selection_spread`).
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
        u = position_units(A, y)
        row_fit = position_row_fit(A, u, y, sigma_si)
    else:
        A = np.asarray(A, dtype=float)
        row_fit = weighted_least_squares(A, y, sigma=sigma_si)
        u = units_of_rows(A, y, groups)
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
    # The correlated candidates: each noise model's kernel of its component over the units.
    def kernel(m: str) -> Callable[[], NDArray[np.float64]]:
        return lambda: MODELS[m].unit_kernel(u, bias_time_scale=bias_time_scale)

    kernels = {m: kernel(m) for m in CORRELATED}
    if n == G and not given:
        kernels.pop("position-offsets")  # no repeated readings: offsets are white noise
    consider = [m for m in kernels if noise_model in ("auto", m)]
    if not can_estimate or (noise_model == "auto" and given):
        consider = []
    # Candidates fitted by REML on the unit means; white first, with no component.
    cands: dict[str, Component] = {}
    reml: Reml | None = None
    if consider:
        reml = Reml.of(u.A, u.y, white_diag, scale_known=scale_known, rank=r)
        cands = components(reml, {m: kernels[m] for m in consider},
                           with_white=noise_model == "auto")
    model = (common_noise_model([{m: c.aic for m, c in cands.items()}])[0]
             if noise_model == "auto" and len(cands) > 1
             else min(cands, key=lambda m: cands[m].aic) if cands else "white")

    def under(m: str) -> tuple[LinearFit, NDArray[np.float64], dict[str, float]]:
        """Fit, unit covariance and noise components under candidate ``m``."""
        c = cands.get(m)
        if c is None or c.kernel is None:
            Vm: NDArray[np.float64] = white_diag if given else row_fit.sigma**2 / u.counts
            return row_fit, Vm, {"white": _given_sigma(sigma_si) if given
                                 else float(row_fit.sigma)}
        assert reml is not None
        s2, Vm = c.fitted(reml)
        fitted = gls(u.A, u.y, Vm)
        wsig2 = sw2 if scale_known else s2
        fm = replace(fitted, residuals=residuals_of(A, fitted.x, y),
                     sigma=float(np.sqrt(wsig2)), sigma_from_residuals=not given,
                     dof=G - fitted.rank)
        label = str(MODELS[m].component)
        return fm, Vm, {"white": _given_sigma(sigma_si) if given else float(np.sqrt(wsig2)),
                        label: c.level(s2)}

    fit, V, noise_components = under(model)
    weights: dict[str, float] = {}
    aic: dict[str, float] = {}
    x_checked = fit.x
    near = [model]
    if noise_model == "auto" and len(cands) > 1:
        aic = {m: c.aic for m, c in cands.items()}
        _, weights, near = common_noise_model([aic])
        if len(near) > 1:
            fit = with_selection_spread(
                fit, {m: x_checked if m == model else under(m)[0].x for m in near},
                {m: weights[m] for m in near})
    checks = unit_checks(u, x_checked, V, model, given, sw2 if n > G else np.nan, alpha)
    implausible = plausibility(noise_components)
    if implausible is not None:
        checks = replace(checks, plausibility=implausible, verdict="model does not fit")
    checks = with_message(checks)
    noise = NoiseFit(model=model, white_sigma=noise_components["white"], sigma_given=given,
                     components=noise_components, unit_index=u.index, unit_labels=u.labels,
                     unit_covariance=V, checks=checks, weights=weights, aic=aic,
                     bias_time_scale=float(bias_time_scale) if "flicker" in near else None)
    if not checks.fits:
        warnings.warn(str(checks.message), InertestWarning, stacklevel=3)
    return fit, noise


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
            fit = with_selection_spread(fit, x, {m: weights[m] for m in near})
        out.append((fit, replace(noise, weights=weights, aic=first[i][1].aic,
                                 bias_time_scale=float(bias_time_scale) if "flicker" in near
                                 else None)))
    return out


def _given_sigma(sigma_si: float | ArrayLike | None) -> float:
    """The given white noise per reading as reported: itself, or the RMS of per-row values."""
    s = np.asarray(sigma_si, dtype=float)
    return float(s) if s.ndim == 0 else float(np.sqrt(np.mean(s**2)))
