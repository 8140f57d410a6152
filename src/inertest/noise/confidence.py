"""Equivalent degrees of freedom and chi-squared confidence intervals of Allan-family variances.

The EDF of a variance estimate that averages ``M`` squared, correlated, Gaussian differences
``z_k`` follows from matching the mean and variance of a chi-squared law::

    edf = M / (1 + 2 sum_{k=1}^{M-1} (1 - k/M) rho_k**2)

with ``rho_k`` the correlation of ``z_0`` and ``z_k``. For power-law noise the correlation comes
in closed form from the generalised autocovariance of the integrated phase (Greenhall & Riley,
"Uncertainty of stability variances based on finite differences", PTTI 2003; NIST SP 1065,
section 5.3); this is the "basic sum" of their algorithm, evaluated without its large-``M``
table approximation. The noise type (power-law exponent ``alpha`` of ``S_y(f) ~ f**alpha``) at
each tau comes from the lag-1 autocorrelation method (Riley & Greenhall 2004, SP 1065 5.5.6).
TOTDEV uses the EDF of SP 1065 Table 11 (Howe): ``edf = b T/tau - c``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import stats as _stats

#: Default confidence level: the 1-sigma interval, as Stable32 and SP 1065 print it.
ONE_SIGMA = 0.682689492137086

# Lags (in tau) beyond which the correlation of the differences is negligible for
# -2 <= alpha <= 2 (it vanishes or decays at least as t**-2); also where cancellation starts.
_T_MAX = 100.0
_MAX_LAGS = 20000


def _sw(t: NDArray, alpha: int) -> NDArray:
    """Generalised autocovariance of the integrated phase, up to factor and polynomial terms."""
    a = np.abs(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        lg = np.where(a > 0, np.log(np.where(a > 0, a, 1.0)), 0.0)
    if alpha == 2:
        return -a
    if alpha == 1:
        return a**2 * lg
    if alpha == 0:
        return a**3
    if alpha == -1:
        return -(a**4) * lg
    if alpha == -2:
        return -(a**5)
    if alpha == -3:
        return a**6 * lg
    return a**7


def _sx(t: NDArray, f: float, alpha: int) -> NDArray:
    """Autocovariance of the phase averaged over tau/F (F = 1: modified statistics)."""
    if f >= 1000 and alpha <= 0:
        # The limit F -> infinity (second derivative of sw) avoids cancellation.
        return _sw(t, alpha + 2)
    h = 1.0 / f
    return f * f * (2.0 * _sw(t, alpha) - _sw(t - h, alpha) - _sw(t + h, alpha))


def _sz(t: NDArray, f: float, alpha: int, d: int) -> NDArray:
    """Autocovariance of the d-th difference (d = 2 Allan, d = 3 Hadamard) at lag t [tau]."""
    out = math.comb(2 * d, d) * _sx(t, f, alpha)
    for k in range(1, d + 1):
        c = (-1) ** k * math.comb(2 * d, d + k)
        out = out + c * (_sx(t - k, f, alpha) + _sx(t + k, f, alpha))
    return out


def edf_difference(alpha: int, d: int, m: int, terms: int, *, modified: bool,
                   overlapping: bool) -> float:
    """EDF of an Allan (d=2) or Hadamard (d=3) variance, plain or modified.

    Parameters
    ----------
    alpha : int
        Power-law exponent of the frequency noise, -2 (random walk FM) .. 2 (white PM).
    d : int
        Order of the phase difference.
    m : int
        Averaging factor, tau = m tau0.
    terms : int
        Number of squared differences averaged (``M``).
    modified, overlapping : bool
        Modified statistic (phase averaged over tau: F = 1) or not (F = m); overlapping
        estimator (lag step tau0) or not (lag step tau).
    """
    if terms <= 1:
        return 1.0
    f = 1.0 if modified else float(m)
    step = 1.0 / m if overlapping else 1.0  # lag between neighbouring terms [tau]
    kmax = terms - 1
    kmax = min(kmax, int(_T_MAX / step))
    if kmax < 1:
        return float(terms)
    if kmax <= _MAX_LAGS:
        k = np.arange(1, kmax + 1, dtype=float)
        w = np.ones_like(k)
    else:
        # Riemann sum on a coarser lag grid: rho**2 is smooth between integer t.
        every = math.ceil(kmax / _MAX_LAGS)
        k = np.arange(1, kmax + 1, every, dtype=float)
        w = np.full_like(k, float(every))
    z0 = float(_sz(np.zeros(1), f, alpha, d)[0])
    rho = _sz(k * step, f, alpha, d) / z0
    s = float(np.sum(w * (1.0 - k / terms) * rho**2))
    return float(terms / (1.0 + 2.0 * s))


# SP 1065 Table 11: TOTVAR edf = b T/tau - c, per noise type (alpha 0, -1, -2).
_TOTDEV_BC = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}


def edf_totdev(alpha: int, m: int, n_freq: int) -> float:
    """EDF of the total variance (SP 1065 Table 11).

    PM noises, and tau = tau0 (where TOTVAR equals the overlapping Allan variance), use the
    overlapping-Allan EDF; the reflected data never give fewer degrees of freedom than that.
    """
    oa = edf_difference(alpha, 2, m, n_freq + 1 - 2 * m, modified=False, overlapping=True)
    if alpha >= 1 or m == 1:
        return oa
    b, c = _TOTDEV_BC[max(alpha, -2)]
    return max(oa, b * n_freq / m - c)


def lag1_alpha(y: NDArray, *, dmax: int = 2) -> int | None:
    """Noise type alpha of frequency data by the lag-1 autocorrelation method.

    Riley & Greenhall (2004), SP 1065 5.5.6: difference the averaged frequencies ``y`` until the
    lag-1 autocorrelation ``r1`` gives ``delta = r1/(1+r1) < 0.25``; then
    ``alpha = -2 (delta + d)`` rounded. Returns None when fewer than 30 values are given.
    """
    z = np.asarray(y, dtype=float)
    d = 0
    while True:
        if z.size < 30:
            return None
        zc = z - z.mean()
        den = float(np.dot(zc, zc))
        r1 = float(np.dot(zc[:-1], zc[1:])) / den if den > 0 else 0.0
        delta = r1 / (1.0 + r1) if r1 > -1.0 else -1.0
        if delta < 0.25 or d >= dmax:
            alpha = round(-2.0 * (delta + d))
            return int(min(2, max(-2, alpha)))
        z = np.diff(z)
        d += 1


def chi2_interval(var: NDArray, edf: NDArray, confidence: float) -> tuple[NDArray, NDArray]:
    """Two-sided chi-squared interval of variances ``var`` with ``edf`` degrees of freedom."""
    lo_q = _stats.chi2.ppf(0.5 + confidence / 2.0, edf)
    hi_q = _stats.chi2.ppf(0.5 - confidence / 2.0, edf)
    return var * edf / lo_q, var * edf / hi_q
