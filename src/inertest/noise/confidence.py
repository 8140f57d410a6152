"""Noise identification, equivalent degrees of freedom and confidence intervals (NIST SP 1065).

Noise type
    The power-law exponent ``alpha`` of ``S_y(f) ~ f**alpha`` at each averaging factor ``m`` is
    identified on the whole record with the statistics of SP 1065 section 5.6: the lag-1
    autocorrelation method (Riley & Greenhall, "Power law noise identification using the lag 1
    autocorrelation", EFTF 2004; SP 1065 5.6.4) when there are at least
    :data:`MIN_ACF_AVERAGES` averages at that tau, otherwise the B1 bias ratio (Barnes 1969,
    Howe et al. 1981; SP 1065 5.6.2) with the R(n) ratio MVAR/AVAR to tell white from flicker
    phase noise (SP 1065 5.6.3), as Stable32 does. Unlike Stable32, a phase-noise verdict of the
    lag-1 method is checked by R(n), and a tau of few averages takes the type of the longest
    lag-1 tau unless R(n) or B1 shows a change (``deviations._settle_types``); which rule
    decided each tau is recorded (:data:`NOISE_RULES`).

EDF
    Allan, modified Allan, Hadamard (plain and overlapping): Greenhall's algorithm (C. A.
    Greenhall & W. J. Riley, "Uncertainty of stability variances based on finite differences",
    PTTI 2003; SP 1065 5.3.2), with its basic sum, its large-``J`` tables and the exact closed
    form for white phase noise. Total deviation: SP 1065 Table 11 (Howe), ``edf = b N/m - c``.

Interval
    ``var edf / chi2_{(1+p)/2}(edf) <= var <= var edf / chi2_{(1-p)/2}(edf)`` (SP 1065 eq. 45).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

#: Default confidence level: the 1-sigma interval, as Stable32 and SP 1065 print it.
ONE_SIGMA = 0.682689492137086
#: Fewest averages at a tau for which the lag-1 autocorrelation method is used (SP 1065 5.6.4).
MIN_ACF_AVERAGES = 30
#: Fewest averages at which the B1 ratio may move the noise type away from that of the longest
#: tau the lag-1 method decided (one step): with 3-7 averages B1 is wrong for 35-75 % of
#: records of one pure noise type (Monte Carlo, tests/noise/test_noise_type_mc.py).
B1_MIN_AVERAGES = 8
#: Smallest averaging factor at which R(n) = MVAR/AVAR checks a phase-noise verdict: there the
#: expected R(n) of flicker PM is 2.5x that of white PM (1.5x at m = 4, equal at m = 2).
RN_MIN_M = 8
#: What decided the noise type at a tau (``DeviationResult.alpha_rule``).
NOISE_RULES = {
    "lag1": "lag-1 autocorrelation of the decimated phase (Riley & Greenhall 2004), "
            "at least 30 averages",
    "lag1+cap": "lag-1 autocorrelation says phase noise after frequency noise at the tau "
                "before: that frequency noise (the type cannot rise with tau)",
    "lag1+rn": "lag-1 autocorrelation says phase noise and R(n) = MVAR/AVAR agrees",
    "lag1|rn": "lag-1 autocorrelation and R(n) = MVAR/AVAR disagree: the type of the two with "
               "the smaller EDF",
    "b1": "B1 ratio (SP 1065 5.6.2), 3-29 averages",
    "b1+rn": "B1 ratio says phase noise, R(n) = MVAR/AVAR tells which (Stable32's rule)",
    "rn": "3-29 averages after phase noise at the longest lag-1 tau: R(n) = MVAR/AVAR says "
          "whether phase noise goes on",
    "anchor": "3-29 averages: the type of the longest lag-1 tau (B1 is not decisive with "
              "fewer than 8 averages, and the type cannot rise with tau)",
    "b1-step": "8-29 averages: B1 says a lower type than at the longest lag-1 tau; one step "
               "lower",
    "min-edf": "fewer than 3 averages: the type of smallest EDF (the widest interval)",
}
#: Greenhall's J_max: longer basic sums are replaced by his asymptotic tables.
_J_MAX = 100

# ----------------------------------------------------------------------------- Greenhall EDF
# The sums themselves (eqs. 7-10 and Tables 1-3) are numba kernels in inertest.noise.kernels:
# a dense tau grid needs one EDF per tau, and the basic sum has up to 100 lags of 5-7 terms.


def edf_greenhall(alpha: int, d: int, m: int, terms: int, *, modified: bool,
                  overlapping: bool) -> float:
    """EDF of an Allan (d=2) or Hadamard (d=3) variance by Greenhall's algorithm.

    Parameters
    ----------
    alpha : int
        Power-law exponent of the frequency noise, ``alpha + 2 d > 1`` (Allan: -2 .. 2,
        Hadamard: -4 .. 2).
    d : int
        Order of the phase difference (1, 2 or 3).
    m : int
        Averaging factor, tau = m tau0.
    terms : int
        Number of squared differences averaged, Greenhall's ``M`` (SP 1065 term counts).
    modified, overlapping : bool
        Modified statistic (phase averaged over tau: F = 1) or not (F = m); overlapping
        estimator (stride tau0: S = m) or not (S = 1).

    Notes
    -----
    Greenhall & Riley (2003), cases 1-4. The basic sum runs over lags up to ``J = min(M,
    (d+1) S)``; beyond ``J_max = 100`` the sum is replaced by the tabulated asymptote
    ``(a0 - a1/r)/r``, ``r = M/S``. White phase noise of the unmodified statistics (case 4)
    has only the correlations at whole multiples of tau, ``rho_k = (-1)^k C(2d, d+k)/C(2d, d)``,
    and is summed exactly: ``1/edf = (1 + 2 sum_{k<r} (1 - k/r) rho_k^2) / M``.
    """
    m_terms = int(terms)
    if m_terms <= 1:
        return 1.0
    if alpha + 2 * d <= 1 or alpha > 2:
        raise ValueError(f"alpha {alpha} is not defined for difference order {d}")
    from inertest.noise import kernels  # numba: loaded on first use

    return float(kernels.greenhall_edf(int(alpha), int(d), int(m), m_terms, bool(modified),
                                       bool(overlapping)))


def edf_greenhall_many(alpha: NDArray, d: int, m: NDArray, terms: NDArray, *, modified: bool,
                       overlapping: bool) -> NDArray:
    """:func:`edf_greenhall` at many taus at once: arrays ``alpha``, ``m``, ``terms`` [-]."""
    al = np.ascontiguousarray(alpha, dtype=np.int64)
    if np.any(al + 2 * d <= 1) or np.any(al > 2):
        bad = int(al[(al + 2 * d <= 1) | (al > 2)][0])
        raise ValueError(f"alpha {bad} is not defined for difference order {d}")
    from inertest.noise import kernels  # numba: loaded on first use

    return kernels.greenhall_edf_many(al, int(d), np.ascontiguousarray(m, dtype=np.int64),
                                      np.ascontiguousarray(terms, dtype=np.int64),
                                      bool(modified), bool(overlapping))


def edf_difference(alpha: int, d: int, m: int, terms: int, *, modified: bool,
                   overlapping: bool) -> float:
    """Alias of :func:`edf_greenhall` (kept for callers of the earlier name)."""
    return edf_greenhall(alpha, d, m, terms, modified=modified, overlapping=overlapping)


# SP 1065 Table 11: TOTVAR edf = b N/m - c (N phase points), per noise type (alpha 0, -1, -2).
_TOTDEV_BC = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}


def edf_totdev(alpha: int, m: int, n_phase: int) -> float:
    """EDF of the total variance, SP 1065 Table 11 (Howe): ``b N/m - c``, N phase points.

    The table covers the frequency noises (alpha 0, -1, -2); for phase noises (alpha 1, 2),
    for which it gives nothing, the overlapping-Allan EDF is used. Stable32 and allantools
    apply the table from tau = tau0 on, with N the number of phase points; this multiplies it
    by ``4 m^2 / (4 m^2 + 5)``, the small-m factor of Greenhall's white-FM EDF of the
    overlapping Allan variance (SP 1065 Table 10 / Greenhall & Riley 2004), which the table
    lacks: at m = 1 TOTDEV *is* the overlapping ADEV, whose exact white-FM EDF is
    2 (N - 1) / 3, and the table's 1.5 N gave an interval 2.25x too narrow in EDF (68 %
    intervals covered 0.50 over 400 records; 1.31x and 0.62 at m = 2). The factor gives the
    exact 2 (N - 1) / 3 and 4 N / 7 there and is within 1 % of the table from m = 12 on.
    """
    if alpha >= 1:
        return edf_greenhall(alpha, 2, m, n_phase - 2 * m, modified=False, overlapping=True)
    b, c = _TOTDEV_BC[max(alpha, -2)]
    return (b * n_phase / m - c) * 4.0 * m * m / (4.0 * m * m + 5.0)


# ----------------------------------------------------------------------------- noise type


class Lag1:
    """Running sums for the lag-1 autocorrelation of a long series fed in blocks.

    ``r1 = sum_{i<n-1} e_i e_{i+1} / sum_i e_i^2`` (Riley & Greenhall 2004 eq. 2), ``e`` the
    series less its least-squares polynomial trend (:func:`r1_of_state`), for the series
    (``d = 0``) and its differences up to order ``dmax`` at once, formed on the fly in one pass
    (a numba kernel: no differenced copies, no threaded BLAS). Values are shifted by the first
    one before summing, so a large offset does not cost digits.

    ``detrend``: degree of the trend removed from the series itself (1 for frequency data: a
    frequency drift; 2 for phase data); each difference lowers it by one.
    """

    def __init__(self, dmax: int = 0, detrend: int = 0) -> None:
        from inertest.noise import kernels  # numba: loaded on first use

        self.state = np.zeros((dmax + 1, kernels.LAG1_FIELDS))
        self.detrend = detrend

    def add(self, block: NDArray) -> None:
        """Append the next values of the series."""
        from inertest.noise import kernels  # numba: loaded on first use

        kernels.lag1_update(np.asarray(block, dtype=np.float64), self.state)

    def r1(self, d: int = 0) -> float:
        """Lag-1 autocorrelation of the d-th difference (0 for a constant series)."""
        return r1_of_state(self.state[d], max(0, self.detrend - d))


def r1_of_state(row: NDArray, degree: int = 0) -> float:
    """Lag-1 autocorrelation from one row of running sums (see ``kernels.lag1_update``).

    ``degree``: the least-squares polynomial of that degree in the index (0: the mean) is
    removed first (:func:`r1_detrended`).
    """
    return float(r1_detrended(np.asarray(row, dtype=np.float64)[None, :],
                              np.array([degree]))[0])


def r1_detrended(rows: NDArray, degree: NDArray) -> NDArray:
    """Lag-1 autocorrelations of many series, each less its polynomial trend, from their sums.

    ``rows`` (K, LAG1_FIELDS) as ``kernels.lag1_update`` leaves them: count n, shift, sum v,
    sum v^2, sum v_i v_{i+1}, first v, last v, last raw value, sum i v_i, sum i^2 v_i.
    ``degree[k]`` (0, 1 or 2) is the degree of the least-squares trend removed: with
    ``e_i = v_i - f(i)``, ``r1 = sum_{i<n-1} e_i e_{i+1} / sum_i e_i^2``. Riley & Greenhall
    (2004) and allantools remove a quadratic from the decimated phase (frequency offset and
    drift; a linear trend from frequency data) before the lag-1 autocorrelation: without it a
    rate ramp makes the identified noise type jump between taus and the EDF wrong by an order
    of magnitude. The trend is fitted in the orthogonal basis 1, u, u^2 - U2/n (``u = i -
    (n-1)/2``, ``U2 = sum u^2``), all from the running sums, so the record is read once.
    Degree 0 is the mean, by the same expressions as before. 0 where the series is constant
    or empty.
    """
    from inertest.noise import kernels  # numba: loaded on first use

    rows = np.ascontiguousarray(rows, dtype=np.float64)
    deg = np.ascontiguousarray(np.broadcast_to(np.asarray(degree, dtype=np.int64),
                                               rows.shape[:1]))
    return kernels.r1_detrended(rows, deg)


def alpha_from_lag1(r1_by_d: list[float], *, phase: bool, alpha_min: int) -> int:
    """Riley & Greenhall's decision from the lag-1 autocorrelations of the d-th differences.

    ``r1_by_d[d]`` is r1 of the series differenced d times (d = 0 .. dmax). The first d with
    ``delta = r1/(1 + r1) < 0.25`` (or the last) gives ``alpha = round(-2 delta) - 2 d``, plus 2
    for phase data; clipped to ``alpha_min .. 2``.
    """
    dmax = len(r1_by_d) - 1
    for d, r1 in enumerate(r1_by_d):
        delta = r1 / (1.0 + r1) if r1 > -1.0 else -1.0
        if delta < 0.25 or d >= dmax:
            alpha = int(round(-2.0 * delta)) - 2 * d + (2 if phase else 0)
            return int(min(2, max(alpha_min, alpha)))
    raise AssertionError("unreachable")


def lag1_alpha(y: NDArray, *, dmax: int = 2, alpha_min: int = -2) -> int | None:
    """Noise type alpha of frequency averages ``y`` by the lag-1 autocorrelation method.

    Riley & Greenhall (2004), SP 1065 5.6.4: difference ``y`` until the lag-1 autocorrelation
    ``r1`` gives ``delta = r1/(1+r1) < 0.25``; then ``alpha = -2 (delta + d)`` rounded. Returns
    None when fewer than :data:`MIN_ACF_AVERAGES` values are given.
    """
    z = np.asarray(y, dtype=float)
    if z.size < MIN_ACF_AVERAGES:
        return None
    acc = Lag1(dmax, detrend=1)
    acc.add(z)
    r1s = [acc.r1(d) for d in range(dmax + 1)]
    return alpha_from_lag1(r1s, phase=False, alpha_min=alpha_min)


def b1_theory(n: int, mu: int) -> float:
    """Expected B1 ratio (standard over Allan variance) of ``n`` averages for exponent mu.

    Barnes (1969) bias function, as used by SP 1065 5.6.2 (Howe, Allan & Barnes 1981 Table 3):
    ``B1 = n (1 - n^mu) / (2 (n - 1)(1 - 2^mu))``, limit ``n ln n / (2 (n - 1) ln 2)`` at
    mu = 0. ``mu`` is the exponent of the Allan variance, ``sigma^2 ~ tau^mu``: mu = -2 for
    white and flicker PM, -1 white FM, 0 flicker FM, 1 random-walk FM, 2, 3 for alpha -3, -4.
    """
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1) * math.log(2.0))
    return n * (1.0 - float(n) ** mu) / (2.0 * (n - 1) * (1.0 - 2.0**mu))


def _mu_of_alpha(alpha: int) -> int:
    return -2 if alpha >= 1 else -1 - alpha


def rn_theory(m: int, alpha: int) -> float:
    """Expected R(n) = MVAR/AVAR at averaging factor m: white PM (2), flicker PM (1), white FM (0).

    White PM: 1/m (SP 1065 5.6.3). Flicker PM: ratio of the IEEE 1139 MVAR and AVAR
    coefficients with the measurement bandwidth f_h = 1/(2 tau0):
    ``3 ln(256/27) / (8 pi^2)`` over ``(1.038 + 3 ln(2 pi f_h tau)) / (4 pi^2)``. White FM: 1/2
    (MVAR = h0/(4 tau), AVAR = h0/(2 tau)).
    """
    if alpha == 2:
        return 1.0 / m
    if alpha == 1:
        avar = (1.038 + 3.0 * math.log(math.pi * m)) / (4.0 * math.pi**2)
        mvar = 3.0 * math.log(256.0 / 27.0) / (8.0 * math.pi**2)
        return mvar / avar
    return 0.5


def b1_alpha(ybar: NDArray, *, alpha_min: int = -2, rn: float | None = None,
             m: int = 1) -> int | None:
    """Noise type from the B1 ratio of the frequency averages ``ybar`` (short series).

    SP 1065 5.6.2: ``B1 = s^2 / AVAR``, the sample variance of the N averages over their
    (non-overlapping) Allan variance, compared with :func:`b1_theory`; the boundaries are the
    geometric means of neighbouring theoretical values. B1 cannot tell white from flicker
    phase noise (both mu = -2): then the measured ``rn`` = MVAR/AVAR at ``m`` (SP 1065 5.6.3)
    decides between white PM, flicker PM and white FM against the geometric means of
    :func:`rn_theory`. R(n) averages many overlapping terms and is far better determined than
    B1 on a few averages, so a phase-noise verdict of B1 stands only when R(n) agrees (on
    PHASE.DAT this reproduces Stable32's types). Without ``rn``, flicker PM is returned.
    None with fewer than 3 averages (B1 is then 1 for every noise type).
    """
    y = np.asarray(ybar, dtype=float)
    n = y.size
    if n < 3:
        return None
    avar = float(np.sum(np.diff(y) ** 2)) / (2.0 * (n - 1))
    return b1_decide(float(np.var(y, ddof=1)), avar, n, alpha_min=alpha_min, rn=rn, m=m)


@functools.lru_cache(maxsize=256)
def _b1_bounds(n: int, alpha_min: int) -> tuple[list[int], list[float]]:
    """Exponents mu and the geometric-mean boundaries between their B1 values (n averages)."""
    mus = list(range(-2, _mu_of_alpha(alpha_min) + 1))
    theory = [b1_theory(n, mu) for mu in mus]
    return mus, [math.sqrt(theory[i] * theory[i + 1]) for i in range(len(mus) - 1)]


def b1_decide(var: float, avar: float, n: int, *, alpha_min: int = -2,
              rn: float | None = None, m: int = 1) -> int:
    """The decision of :func:`b1_alpha` from the sample variance and Allan variance of n averages.

    ``var`` (ddof 1) and ``avar`` (non-overlapping) of the ``n >= 3`` frequency averages, in
    any common unit; ``rn`` and ``m`` as in :func:`b1_alpha`.
    """
    if not avar > 0:
        return 0
    b1 = var / avar
    mus, bounds = _b1_bounds(n, alpha_min)
    mu = mus[-1]
    for i, bound in enumerate(bounds):
        if b1 < bound:
            mu = mus[i]
            break
    if mu != -2:
        return -1 - mu
    if rn is None:
        return 1
    r2, r1, r0 = (rn_theory(m, a) for a in (2, 1, 0))
    if rn < math.sqrt(r2 * r1):
        return 2
    return 1 if rn < math.sqrt(r1 * r0) else 0


def rn_decide(rn: float, m: int) -> int:
    """Noise type from the measured R(n) = MVAR/AVAR at averaging factor ``m`` alone.

    2 (white PM), 1 (flicker PM) or 0 (frequency noise, of which R(n) cannot tell the kind
    reliably), against the geometric means of :func:`rn_theory` (SP 1065 5.6.3), as
    :func:`b1_decide` uses them.
    """
    r2, r1, r0 = (rn_theory(m, a) for a in (2, 1, 0))
    if rn < math.sqrt(r2 * r1):
        return 2
    return 1 if rn < math.sqrt(r1 * r0) else 0


def chi2_interval(var: NDArray, edf: NDArray, confidence: float) -> tuple[NDArray, NDArray]:
    """Two-sided chi-squared interval of variances ``var`` with ``edf`` degrees of freedom."""
    lo_q = _chi2_ppf(0.5 + confidence / 2.0, edf)
    hi_q = _chi2_ppf(0.5 - confidence / 2.0, edf)
    return var * edf / lo_q, var * edf / hi_q


def _chi2_ppf(p: float, edf: NDArray) -> NDArray:
    """``scipy.stats.chi2.ppf(p, edf)`` for ``0 < p < 1``: ``2 gammaincinv(edf/2, p)``.

    The expression scipy.stats evaluates (the same digits), without its per-call argument
    handling and without importing scipy.stats (about 1 s); NaN where ``edf <= 0``.
    """
    from scipy.special import gammaincinv

    e = np.asarray(edf, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        q = 2.0 * gammaincinv(e / 2.0, p)
    return np.where(e > 0, q, np.nan)
