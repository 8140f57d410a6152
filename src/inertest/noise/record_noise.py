"""The noise of static records from their Allan variance, and what it does to averages of them.

An instrument at rest (a gyro's bias, an accelerometer's output in a fixed attitude) records its
own noise: white noise (angle / velocity random walk ``N``), flicker (bias instability ``B``) and
a random walk of the rate (``K``), the terms of IEEE Std 952-1997 Annex C. Every acceptance test
on such records (the bias of a power-on run, the bias averaged over 100 s windows, the settling
of the bias after power-on) needs the covariance of *averages* of the record, which white noise
alone gets wrong by a large factor once flicker or a random walk is present. Here, written once:

1. :func:`pooled_oadev`: the overlapping Allan variance of one or several records of the same
   instrument (power-on runs) at octave averaging times, pooled over the records (each record's
   variance weighted by its number of terms, its equivalent degrees of freedom summed), with the
   chi-squared intervals of NIST SP 1065.
2. :func:`fit_record_noise`: the IEEE 952 terms fitted to it by
   :func:`inertest.noise.identification.identify_noise` (generalised least squares with the
   covariance of the Allan variances across averaging times), kept as the squares
   ``p = [Q^2, N^2, B^2, K^2]`` and their covariance: a :class:`RecordNoise`.
3. :meth:`RecordNoise.unit_covariance`: the covariance of means over parts of a record (windows,
   bins, the whole record: :class:`~inertest.estimation.units.Units`), each term through the
   noise models of :mod:`inertest.estimation.noise_models` with the level the Allan fit gives:

   - white: ``N^2 / tau0`` per reading (a reading is the mean over its interval ``tau0``);
   - flicker: one-sided PSD ``h / f`` with ``h = B^2 / pi`` (IEEE 952 Annex C: ``sigma_A^2 =
     (2 ln 2 / pi) B^2 = 2 ln 2 h``), band-limited from ``f_lo = 1 / (2 s T)`` for a record of
     duration ``T`` (``s`` the bias time scale, :data:`~inertest.estimation.noise_models.
     BIAS_TIME_SCALE_DEFAULT` = 2) to the Nyquist frequency: per reading ``h ln(s n)``, shaped
     by :func:`~inertest.estimation.noise_models.flicker_unit_kernel`;
   - rate random walk: ``Var W(t) = K^2 t`` from the record's first reading (the power-on: a
     random walk has no stationary level), a step of variance ``K^2 tau0`` per reading
     (:func:`~inertest.estimation.noise_models.random_walk_unit_kernel`);
   - quantization ``Q`` adds ``2 Q^2 / T^2`` to a mean over ``T``: below the white term's
     ``N^2 / T`` by ``2 Q^2 / (N^2 T)``, left out (the Allan fit still includes it, so it does
     not leak into ``N``).

   The covariance is linear in ``p``, so the uncertainty of the noise fit propagates to any
   variance computed from it (:meth:`RecordNoise.variance_std`), which gives the effective
   degrees of freedom of a variance estimated from the record (Satterthwaite).

Limits, stated: a rate random walk enters these variances only when the record's Allan fit
determines it (:data:`RANDOM_WALK_CHI2`, :data:`RANDOM_WALK_Z`). Within one record its share of
the record's mean (``K^2 T / 3``) is 3.5 times its share of the Allan variance at the longest
averaging time a record of octave taus has (about ``T / 3.5``), where flicker looks nearly the
same: a gyro with ``K = 0.05 deg/h/sqrt(h)`` and ``B = 0.03 deg/h`` recorded for 2 h has a
random walk as large as its flicker there, which the fit does not resolve, yet 90 % of the
variance of the record's mean; that std then comes out 3 times too small. Window statistics
over times well inside the record (a 100 s bias stability) are not affected.

What counts as the bias *of a record* under flicker: flicker slower than ``1 / (2 s T)`` is a
constant over the record, indistinguishable from the bias itself (and, between power-on runs,
from a turn-on offset); the stated variances are those of the record's mean about the bias
averaged over ``s`` record lengths around it (the convention of every procedure's flicker model,
:func:`~inertest.estimation.noise_models.flicker_unit_kernel`).
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError
from inertest.estimation.noise_models import (
    BIAS_TIME_SCALE_DEFAULT,
    check_bias_time_scale,
    flicker_unit_kernel,
    random_walk_unit_kernel,
)
from inertest.estimation.units import Units
from inertest.noise.confidence import ONE_SIGMA, chi2_interval
from inertest.noise.deviations import DeviationResult, oadev

#: Terms of the IEEE 952 model kept by :class:`RecordNoise` (squares), in this order.
TERMS = ("Q", "N", "B", "K")
#: Chi-square improvement of the Allan fit for which the rate random walk ``K^2`` is kept in
#: the noise behind a variance: 9.55, the 0.1 % point of the chi-bar-square of one variance
#: component on its boundary (``0.5 chi2_0 + 0.5 chi2_1``; Self & Liang, JASA 82, 1987,
#: doi:10.1080/01621459.1987.10478472). Within a record of duration ``T`` the random walk's
#: share of a mean over ``T`` (``K^2 T / 3``) is an extrapolation to the longest averaging
#: times, where the record has fewest degrees of freedom: fitted freely, it made the variance
#: of a record's mean uncertain by 2-4 times itself (white + flicker + 12 % random walk, 8
#: records). Kept whenever it is significant at 5 % or 1 %, a weak random walk was kept in a
#: few per cent of the records, each time estimated far too large (kept *because* its
#: estimate came out large), and the RMS reported std of a 2-hour record's mean was 1.42
#: times its scatter (at 0.1 %: 0.94; tests/procedures/test_in_run_stability.py). A random
#: walk weaker than this can detect is left out, and the variance is short by its share.
RANDOM_WALK_CHI2 = 9.55
#: ... and for which its fitted square is this many of its standard deviations above zero (a
#: random walk that the fit cannot tell from zero is not extrapolated into a record's mean:
#: in a 2-hour record of flicker whose slowest part happened to rise like a random walk, the
#: chi-square gain was 18 but ``K^2`` only 1.8 standard deviations above zero, and taken as
#: is it made the reported std of the record's mean 8 times its scatter).
RANDOM_WALK_Z = 3.0
#: Fewest readings in a record for its Allan variance (at least two octaves).
MIN_RECORD_READINGS = 16


@dataclass(frozen=True)
class RecordNoise:
    """The IEEE 952 noise terms of a static record and the covariance of its averages.

    Attributes
    ----------
    p : ndarray, shape (4,)
        Fitted squares ``[Q^2, N^2, B^2, K^2]`` in SI (u: rad/s or m/s^2): Q^2 [u^2 s^2], N^2
        [u^2 s], B^2 [u^2], K^2 [u^2 / s]; a square fitted below zero is 0 here.
    cov : ndarray, shape (4, 4)
        Covariance of the fitted squares (zero rows for ``K^2`` when it is not fitted).
    random_walk_gain : float
        Chi-square improvement from fitting ``K^2`` (kept from :data:`RANDOM_WALK_CHI2` on).
    rate_hz : float
        Sample rate of the records [Hz].
    bias_time_scale : float
        ``s``: flicker from ``1 / (2 s T)`` for a record of duration ``T`` (see module).
    fits : bool
        Whether the five-term model describes the pooled Allan variance (its test at 1 %).
    verdict : str
        The Allan fit's verdict in words.
    terms : dict
        The Allan fit's terms as JSON (:meth:`inertest.noise.identification.NoiseTerm.to_dict`):
        value and std when resolved, else an upper bound.
    records : int
        Records pooled.
    allan : DeviationResult
        The pooled overlapping Allan deviation.
    """

    p: NDArray[np.float64]
    cov: NDArray[np.float64]
    random_walk_gain: float
    rate_hz: float
    bias_time_scale: float
    fits: bool
    verdict: str
    terms: dict[str, dict[str, object]]
    records: int
    allan: DeviationResult = field(repr=False)

    @property
    def tau0(self) -> float:
        """Sample interval [s]."""
        return 1.0 / self.rate_hz

    def unit_kernels(self, u: Units) -> NDArray[np.float64]:
        """Covariance of the unit means per unit of each square of ``p``, shape (4, G, G).

        ``sum_i p_i K_i`` is the covariance of the means (:meth:`unit_covariance`); rows in time
        order, the record starting at its first row (the random walk's origin).
        """
        G, n = u.size, u.n_rows
        out = np.zeros((4, G, G))
        out[1] = np.diag(1.0 / (self.tau0 * u.counts))             # white: N^2 / tau0 per row
        c0 = math.log(self.bias_time_scale * max(n, 1))           # flicker per row / h
        out[2] = (c0 / math.pi) * flicker_unit_kernel(u, self.bias_time_scale)
        out[3] = self.tau0 * random_walk_unit_kernel(u)            # rw: K^2 tau0 per row
        return out

    def unit_covariance(self, u: Units) -> NDArray[np.float64]:
        """Covariance (G, G) of the means of the units ``u`` of one record [u^2]."""
        return np.einsum("i,ijk->jk", self.p, self.unit_kernels(u))

    def mean_kernel(self, n_rows: int) -> NDArray[np.float64]:
        """``g`` with ``Var(mean of an n-row record) = g . p`` (its sensitivity to each square)."""
        return self.unit_kernels(whole_record(n_rows))[:, 0, 0]

    def mean_variance(self, n_rows: int) -> float:
        """Variance of the mean of a whole record of ``n_rows`` readings [u^2]."""
        return float(self.mean_kernel(n_rows) @ self.p)

    def variance_std(self, g: ArrayLike) -> float:
        """Standard uncertainty of a variance ``g . p`` from the fit's covariance [u^2]."""
        gg = np.asarray(g, dtype=float)
        return float(math.sqrt(max(float(gg @ self.cov @ gg), 0.0)))

    def variance_dof(self, g: ArrayLike) -> float:
        """Effective degrees of freedom of the variance ``g . p``: ``2 v^2 / Var(v)``.

        Satterthwaite's approximation (a variance estimate as ``v chi2_nu / nu``); ``inf`` when
        the fit gives it no uncertainty (every term it rests on held at a bound).
        """
        gg = np.asarray(g, dtype=float)
        v = float(gg @ self.p)
        s = self.variance_std(gg)
        return math.inf if s <= 0.0 else max(2.0 * v * v / (s * s), 1.0)


def whole_record(n_rows: int) -> Units:
    """The units of a record taken whole: one unit of ``n_rows`` readings."""
    return windows(n_rows, np.array([0, n_rows]))


def windows(n_rows: int, edges: ArrayLike) -> Units:
    """Contiguous units of a record: rows ``edges[k]`` to ``edges[k + 1] - 1`` form unit ``k``.

    Rows before ``edges[0]`` or from ``edges[-1]`` on belong to no unit (they still count in the
    record's length, which sets the flicker's lowest frequency and the random walk's origin).
    """
    e = np.asarray(edges, dtype=np.intp)
    if e.ndim != 1 or e.size < 2 or np.any(np.diff(e) <= 0) or e[0] < 0 or e[-1] > n_rows:
        raise DataError(f"windows need increasing row edges within 0..{n_rows}, got {e}")
    counts = np.diff(e).astype(float)
    G = counts.size
    index = np.repeat(np.arange(G, dtype=np.intp), np.diff(e))
    return Units(index=index, labels=tuple(f"window {k + 1}" for k in range(G)), counts=counts,
                 first=e[:-1].copy(), last=e[1:] - 1, y=np.zeros(G), A=np.ones((G, 1)),
                 n_rows=int(n_rows))


def pooled_oadev(records: Sequence[NDArray[np.float64]], rate_hz: float) -> DeviationResult:
    """Overlapping Allan deviation at octave taus pooled over records of one instrument.

    Parameters
    ----------
    records : sequence of ndarray
        Rate readings of each record [u], in time order, same sample rate.
    rate_hz : float
        Sample rate [Hz].

    Returns
    -------
    DeviationResult
        At the octave taus the shortest record has: variance ``sum n_r var_r / sum n_r`` (each
        record's variance weighted by its number of terms), ``n = sum n_r``, EDF ``sum EDF_r``
        (the records are independent), 1-sigma chi-squared intervals (NIST SP 1065 5.3).

    Raises
    ------
    DataError
        A record shorter than :data:`MIN_RECORD_READINGS` readings.
    """
    short = [k for k, r in enumerate(records) if np.asarray(r).size < MIN_RECORD_READINGS]
    if not records or short:
        raise DataError(
            f"record {short[0] + 1 if short else 1} has fewer than {MIN_RECORD_READINGS} "
            "readings: too short for an Allan variance; record longer runs")
    res = [oadev(np.asarray(r, dtype=float), rate_hz) for r in records]
    k = min(r.taus.size for r in res)
    if len(res) == 1:
        return res[0]
    n = np.sum([r.n[:k] for r in res], axis=0)
    var = np.sum([r.n[:k] * r.var[:k] for r in res], axis=0) / n
    edf = np.sum([r.edf[:k] for r in res], axis=0)
    lo, hi = chi2_interval(var, edf, ONE_SIGMA)
    first = res[0]
    return DeviationResult(
        statistic="oadev", taus=first.taus[:k], dev=np.sqrt(var), n=n, edf=edf,
        alpha=first.alpha[:k], dev_lo=np.sqrt(lo), dev_hi=np.sqrt(hi), confidence=ONE_SIGMA,
        rate_hz=rate_hz, data_type="rate", name=f"{first.name}, pooled over {len(res)} records",
        n_samples=int(sum(r.n_samples for r in res)), alpha_rule=first.alpha_rule[:k])


def fit_record_noise(
    records: Sequence[NDArray[np.float64]], rate_hz: float, *, instrument: str | None = "gyro",
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT,
) -> RecordNoise:
    """The IEEE 952 terms of static records (pooled) as a :class:`RecordNoise`.

    Parameters
    ----------
    records : sequence of ndarray
        Rate readings of each record in SI (rad/s, m/s^2), each with its deterministic part
        removed (its mean, or a fitted transient).
    rate_hz : float
        Sample rate [Hz].
    instrument : {"gyro", "accelerometer", None}
        Engineering units of the terms in :attr:`RecordNoise.terms`.
    bias_time_scale : float
        ``s`` of the flicker's lowest frequency ``1 / (2 s T)`` (module docstring).

    Notes
    -----
    Two fits of the same pooled Allan variances. The squares ``p`` behind every variance
    computed here are the generalised least squares of ``Q^2, N^2, B^2`` (and ``K^2`` when it
    improves the fit's chi-square by :data:`RANDOM_WALK_CHI2`), unconstrained so that a
    variance ``g . p`` is a linear estimate, with the covariance of the Allan variances across
    averaging times for the fitted noise (:func:`inertest.noise.identification.
    allan_covariance_basis`, per record, pooled as ``sum (n_r / n)^2 Cov_r``; three
    reweighting passes); a square below zero is then taken as 0. The reported terms
    (:attr:`RecordNoise.terms`: resolved value and std, or an upper bound) and the model check
    are :func:`inertest.noise.identification.identify_noise`'s, whose dropping of terms it
    cannot tell from zero is right for a datasheet but would bias such a variance low: records
    of white, flicker and random-walk noise gave a median 0.37 of the true variance of a
    record's mean that way (tests/noise/test_record_noise.py). A five-term model that does not
    fit is reported in :attr:`RecordNoise.verdict`, not warned: the procedures turn it into a
    model check.
    """
    from inertest.noise.identification import NoiseFitWarning, identify_noise

    s = check_bias_time_scale(bias_time_scale)
    pooled = pooled_oadev(records, rate_hz)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoiseFitWarning)
        model = identify_noise(pooled, instrument=instrument)
    lengths = [int(np.asarray(r).size) for r in records]
    resolved_k = bool(model.terms["K"].resolved)
    p, cov, gain = _linear_terms(pooled, lengths, float(rate_hz), s, resolved_k)
    return RecordNoise(p=np.maximum(p, 0.0), cov=cov, random_walk_gain=gain,
                       rate_hz=float(rate_hz), bias_time_scale=s,
                       fits=bool(model.fits), verdict=str(model.verdict),
                       terms={k: t.to_dict() for k, t in model.terms.items()},
                       records=len(records), allan=pooled)


@functools.lru_cache(maxsize=16)
def _basis_of(ms: tuple[int, ...], ns: tuple[int, ...], tau0: float) -> NDArray[np.float64]:
    """``G[t, u, i, j]`` of :func:`allan_covariance_basis` for the four noise terms (cached)."""
    from inertest.noise.identification import allan_covariance_basis

    g, _ = allan_covariance_basis(np.asarray(ms), np.asarray(ns), tau0)
    g.flags.writeable = False
    return g


def flicker_allan(a: ArrayLike) -> NDArray[np.float64]:
    """Allan variance of band-limited flicker per unit ``h``: ``2 ln 2`` less the missing band.

    For one-sided PSD ``h / f`` from ``f_lo`` up, ``sigma_A^2(tau) = h int_a^inf 2 sin^4(pi x)
    / (pi^2 x^3) dx`` with ``a = f_lo tau`` (the Allan transfer function, IEEE Std 952-1997
    Annex C), in closed form by ``sin^4 = (4 (1 - cos 2 pi x) - (1 - cos 4 pi x)) / 8`` and
    ``int_a^inf (1 - cos b x) / x^3 dx = (1 - cos ab) / (2 a^2) + b (sin(ab) / a - b Ci(ab)) / 2``.
    It is ``2 ln 2`` as ``a -> 0`` (unlimited flicker), 1.27 at ``a = 0.11`` (tau = T / 2.3 of a
    record with the default bias time scale): fitting the unlimited value put ``B^2`` low.
    """
    from scipy.special import sici

    x = np.maximum(np.asarray(a, dtype=float), 1e-12)

    def f(b: float) -> NDArray[np.float64]:
        ab = b * x
        return (1.0 - np.cos(ab)) / (2 * x * x) + 0.5 * b * (np.sin(ab) / x - b * sici(ab)[1])

    two_pi = 2.0 * math.pi
    return (2.0 / math.pi**2) * (4.0 * f(two_pi) - f(2.0 * two_pi)) / 8.0


def _linear_terms(pooled: DeviationResult, lengths: Sequence[int], rate_hz: float,
                  bias_time_scale: float, random_walk: bool = True
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """GLS of ``[Q^2, N^2, B^2]``, and ``K^2`` when the data ask for it, on pooled variances.

    The flicker column is that of flicker from ``1 / (2 s T_r)`` in each record
    (:func:`flicker_allan`), averaged with the records' weights. Returns the squares (a term
    not fitted is 0), their covariance and the chi-square improvement of adding ``K^2``
    (:data:`RANDOM_WALK_CHI2`).
    """
    from inertest.noise.identification import basis

    tau0 = 1.0 / rate_hz
    taus, a = pooled.taus, pooled.var
    ms = tuple(int(m) for m in np.rint(taus / tau0).astype(np.int64))
    A_all = basis(taus)[:, :4]
    # each record's number of terms at each tau (octave OADEV: n_x - 2 m, n_x = N + 1)
    per = [tuple(max(n + 1 - 2 * m, 1) for m in ms) for n in lengths]
    total = np.sum(np.asarray(per, dtype=float), axis=0)
    A_all[:, 2] = sum(np.asarray(ns, dtype=float) / total * flicker_allan(
        taus / (2.0 * bias_time_scale * n * tau0)) for ns, n in zip(per, lengths, strict=True)
    ) / math.pi

    def cov_of(q: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros((taus.size, taus.size))
        for ns in per:
            w = np.asarray(ns, dtype=float) / total
            out += np.outer(w, w) * np.einsum("t,u,tuij->ij", q, q, _basis_of(ms, ns, tau0))
        out += np.diag(np.maximum(np.diag(out), 1e-300) * 1e-9)
        return out

    def gls(cols: list[int]) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        A = A_all[:, cols]
        W = np.sqrt(pooled.edf) / (np.sqrt(2.0) * np.maximum(a, 1e-300))
        x = np.linalg.lstsq(A * W[:, None], a * W, rcond=None)[0]
        cov, chi2 = np.zeros((len(cols), len(cols))), math.inf
        for _ in range(3):  # reweight with the covariance of the fitted (non-negative) noise
            q = np.zeros(4)
            q[cols] = np.maximum(x, 0.0)
            if not np.any(q > 0):
                q[1] = float(np.max(a * taus))
            L = np.linalg.cholesky(cov_of(q))
            Aw, aw = np.linalg.solve(L, A), np.linalg.solve(L, a)
            Qm, Rm = np.linalg.qr(Aw)
            x = np.linalg.solve(Rm, Qm.T @ aw)
            Ri = np.linalg.inv(Rm)
            cov = Ri @ Ri.T
            r = aw - Aw @ x
            chi2 = float(r @ r)
        full, cf = np.zeros(4), np.zeros((4, 4))
        full[cols] = x
        cf[np.ix_(cols, cols)] = cov
        return full, cf, chi2

    base = [0, 1, 2] if taus.size >= 4 else [1, 2][: max(taus.size - 1, 1)]
    p, cov, chi2 = gls(base)
    gain = 0.0
    if taus.size >= len(base) + 2:
        p_k, cov_k, chi2_k = gls([*base, 3])
        gain = chi2 - chi2_k
        z = p_k[3] / math.sqrt(cov_k[3, 3]) if cov_k[3, 3] > 0 else 0.0
        if random_walk and gain >= RANDOM_WALK_CHI2 and z >= RANDOM_WALK_Z:
            p, cov = p_k, cov_k
    return p, cov, float(gain)
