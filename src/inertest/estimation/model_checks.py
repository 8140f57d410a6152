"""Checks that a fitted model, with its noise model, describes the data.

The residuals are reduced to the unit of independence (a position or run: the mean of its
readings) and whitened by the noise model's covariance, so that under the model they are
independent N(0, 1) apart from the fitted directions. Then: a variance test (chi-square against
a given noise, or the lack-of-fit F test of the unit means against the scatter within units),
the Ljung-Box test of the whitened unit residuals in time order, studentised unit residuals
above a Bonferroni bound, and the mean-shift test of one or two units against the others
(:class:`~inertest.results.ModelChecks`). Written once for every procedure.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np
import scipy.linalg
import scipy.special
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.estimation.least_squares import DEFAULT_RCOND
from inertest.estimation.units import Units
from inertest.results import ModelChecks, Outlier

#: Significance level of the model checks (per test); low, so that good data rarely warn.
CHECK_ALPHA = 1e-3
#: Largest number of units whose pairs the mean-shift check tries (G (G - 1) / 2 of them).
_MAX_PAIR_UNITS = 400
#: Position offsets larger than this many times the white noise per reading are implausible
#: (a wrong label or a missing term absorbed as an "offset"), see :func:`_plausibility`.
OFFSET_PLAUSIBLE_RATIO = 100.0


def outlier_threshold(n: int, alpha: float = CHECK_ALPHA) -> float:
    """``max(4, Phi^-1(1 - alpha / (2 n)))``: Bonferroni bound on ``n`` standardised residuals."""
    return max(4.0, -float(scipy.special.ndtri(alpha / (2 * n))))  # = scipy.stats.norm.isf


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
    """Model checks of a fit made outside :func:`~inertest.estimation.identify.solve`.

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
    u = Units.of_values(e, A, labels)
    c = unit_checks(u, np.zeros(A.shape[1]), V, noise_model, sigma_given, np.nan, alpha)
    return with_message(replace(c, unit=unit))


def unit_checks(
    u: Units, x: NDArray[np.float64], V: NDArray[np.float64], model: str, given: bool,
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
        p = chi2_sf(chi2, dof) if dof > 0 else None
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
        serial_p = chi2_sf(serial, lags)
    z = e / np.sqrt(np.clip(1 - h, 1e-12, None))
    thr = outlier_threshold(G, alpha)
    outliers = tuple(Outlier(u.label(int(i)), float(z[i]))
                     for i in np.flatnonzero(np.abs(z) > thr))
    # Residuals at the rounding level of the data (noise-free data) test nothing.
    rounding = float(np.max(np.abs(resid), initial=0.0)) <= 1e-9 * float(
        np.max(np.abs(u.y), initial=0.0))
    shift_units, shift_f, shift_dof, shift_p = mean_shift(
        e, Q, 0 if rounding else dof, u.label, scale_known=given and model == "white")
    bad = any(q is not None and q < alpha for q in (p, serial_p, shift_p))
    return ModelChecks(
        noise_model=model, unit="reading" if u.labels is None else "position",
        n_units=G, statistic=statistic, chi_square=chi2, dof=dof, p_value=p,
        serial_chi_square=serial, serial_dof=lags if serial is not None else 0,
        serial_p_value=serial_p, outliers=outliers, outlier_threshold=thr, alpha=alpha,
        verdict="model does not fit" if bad or outliers else "consistent",
        shift_units=shift_units, shift_f=shift_f, shift_dof=shift_dof, shift_p_value=shift_p)


def with_message(c: ModelChecks) -> ModelChecks:
    """``c`` with its :attr:`~inertest.results.ModelChecks.message` (None when it fits)."""
    return replace(c, message=None if c.fits else misfit_message(c))


def mean_shift(
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


def plausibility(components: Mapping[str, float]) -> str | None:
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


#: Outlying units named in a message (the rest counted; all are in the checks' JSON).
_OUTLIERS_SHOWN = 6
#: What the generic misfit message asks to check.
CHECK_LABELS = ("the labels (mounting, angle, position), the settling of the table, and the "
                "noise model")


def misfit_message(c: ModelChecks, *, what: str = "the data", check: str = CHECK_LABELS,
                   prefix: str = "") -> str:
    """Why the model does not fit, and what to check, in one sentence.

    Parameters
    ----------
    c : ModelChecks
        Checks whose verdict is "model does not fit".
    what : str
        What the model was fitted to (``"the windows"``, ``"the session"``).
    check : str
        What the user should look at.
    prefix : str
        A procedure's name and colon, when the message stands alone in a list.
    """
    why = []
    if c.p_value is not None and c.p_value < c.alpha:
        why.append(f"residuals too large (chi-square {c.chi_square:.4g} for {c.dof} dof, "
                   f"p = {c.p_value:.2g})")
    if c.serial_p_value is not None and c.serial_p_value < c.alpha:
        why.append(f"neighbouring residuals alike (Ljung-Box {c.serial_chi_square:.4g} for "
                   f"{c.serial_dof} dof, p = {c.serial_p_value:.2g})")
    if c.outliers:
        shown = ", ".join(f"{o.label} (z = {o.z:+.1f})" for o in c.outliers[:_OUTLIERS_SHOWN])
        more = len(c.outliers) - _OUTLIERS_SHOWN
        why.append(f"outlying {shown}" + (f" and {more} more" if more > 0 else ""))
    if c.shift_p_value is not None and c.shift_p_value < c.alpha:
        why.append(f"{' and '.join(c.shift_units)} off the model against the scatter of the "
                   f"other {c.unit}s (F = {c.shift_f:.4g} for {c.shift_dof[0]}, "
                   f"{c.shift_dof[1]} dof, p = {c.shift_p_value:.2g} over every one or two "
                   f"{c.unit}s)")
    if c.plausibility:
        why.append(c.plausibility)
    return (f'{prefix}the model with "{c.noise_model}" noise does not fit {what}: '
            f'{"; ".join(why)}; check {check}; the uncertainties are not reliable')


def chi2_sf(x: float, dof: int) -> float:
    """Upper tail probability of chi-square with ``dof`` degrees of freedom at ``x``.

    ``Q(dof/2, x/2)`` (regularised upper incomplete gamma), the function behind
    ``scipy.stats.chi2.sf``; scipy.special is used so that scipy.stats (~1 s to import) is
    not loaded by every fit.
    """
    return float(scipy.special.chdtrc(dof, x))
