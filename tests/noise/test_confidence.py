"""EDF and intervals against allantools' Greenhall algorithm, chi-squared law and Monte Carlo."""

from __future__ import annotations

import allantools
import numpy as np
import pytest
from scipy import stats

from inertest.noise.confidence import (
    ONE_SIGMA,
    chi2_interval,
    edf_difference,
    edf_greenhall,
    lag1_alpha,
)
from inertest.noise.deviations import deviations

N_PHASE = 1001


def _terms(d, m, modified, overlapping):
    if modified:
        return N_PHASE - 3 * m + 1
    if overlapping:
        return N_PHASE - d * m
    return (N_PHASE - 1) // m - d + 1


@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
@pytest.mark.parametrize(
    ("d", "modified", "overlapping"),
    [(2, False, True), (2, False, False), (2, True, True), (3, False, True), (3, False, False)],
)
@pytest.mark.parametrize("m", [1, 4, 16, 64])
def test_edf_matches_allantools_greenhall(alpha, d, modified, overlapping, m):
    ref = allantools.edf_greenhall(alpha=alpha, d=d, m=m, N=N_PHASE, overlapping=overlapping,
                                   modified=modified)
    ours = edf_difference(alpha, d, m, _terms(d, m, modified, overlapping), modified=modified,
                          overlapping=overlapping)
    # Greenhall's algorithm replaces long sums by fitted tables; ours sums them: within 2 %.
    assert ours == pytest.approx(ref, rel=0.02)


def test_chi2_interval_is_the_chi2_quantiles():
    lo, hi = chi2_interval(np.array([4.0]), np.array([10.0]), 0.9)
    assert lo[0] == pytest.approx(4.0 * 10 / stats.chi2.ppf(0.95, 10))
    assert hi[0] == pytest.approx(4.0 * 10 / stats.chi2.ppf(0.05, 10))


@pytest.mark.parametrize(("alpha", "make"), [
    (2, lambda g, n: np.diff(g.standard_normal(n + 1))),  # white phase
    (0, lambda g, n: g.standard_normal(n)),  # white frequency
    (-2, lambda g, n: np.cumsum(g.standard_normal(n))),  # random walk frequency
])
def test_lag1_noise_identification(alpha, make):
    g = np.random.default_rng(4)
    assert lag1_alpha(make(g, 5000)) == alpha
    assert lag1_alpha(make(g, 20)) is None


@pytest.mark.slow
def test_interval_coverage_monte_carlo():
    """The 68.3 % interval of OADEV holds the true white-FM value in ~68 % of records."""
    g = np.random.default_rng(12)
    hits, widths, runs = [], [], 300
    for _ in range(runs):
        r = deviations(g.standard_normal(2000), 1.0, ["oadev"], [1, 16, 128, 512])["oadev"]
        truth = 1.0 / np.sqrt(r.taus)
        hits.append((r.dev_lo <= truth) & (truth <= r.dev_hi))
        widths.append(r.edf)
    cover = np.mean(hits, axis=0)
    assert np.all(np.abs(cover - ONE_SIGMA) < 0.09), cover


@pytest.mark.parametrize("alpha", [0, -1, -2])
@pytest.mark.parametrize("m", [12, 100, 400])
def test_totdev_edf_matches_allantools(alpha, m):
    from inertest.noise.confidence import edf_totdev

    ref = allantools.edf_totdev(N=1001, m=m, alpha=alpha)  # SP 1065 Table 11 (Howe)
    assert edf_totdev(alpha, m, 1000) == pytest.approx(ref, rel=0.01)


@pytest.mark.parametrize("n", [1000, 20000])
def test_totdev_edf_at_one_and_two_is_the_exact_white_fm_one(n):
    """At m = 1 TOTDEV is the overlapping ADEV; white FM's exact EDF there is 2 (N - 1) / 3.

    At m = 2 it is 4 (N - 1) / 7 (N frequency points; the squared overlapping differences
    of white noise at lag 1 and 2 correlate -1/2 and 0 at m = 1, and -1/4 ... at m = 2:
    Var = sum of the squared autocorrelations). The table's 1.5 N / m, used as is by
    Stable32 and allantools, is 2.25x and 1.31x too large (SP 1065 Table 11).
    """
    from inertest.noise.confidence import edf_totdev

    y = np.arange(n)  # only the count matters
    for m, exact in ((1, _exact_white_fm_oadev_edf(y.size, 1)),
                     (2, _exact_white_fm_oadev_edf(y.size, 2))):
        assert edf_totdev(0, m, n + 1) == pytest.approx(exact, rel=0.005)
    assert _exact_white_fm_oadev_edf(20000, 1) == pytest.approx(2 * 19999 / 3, rel=1e-4)


def _exact_white_fm_oadev_edf(n: int, m: int) -> float:
    """EDF = 2 (sum of the terms' means)^2 / Var(sum) for the overlapping Allan terms of
    white FM (n frequency points): each term is (mean of the next m - mean of these m)^2; the
    terms are Gaussian squares, so Cov(z_i^2, z_j^2) = 2 Cov(z_i, z_j)^2."""
    k = n - 2 * m + 1  # terms
    # Cov(z_i, z_{i+l}) for the second difference of m-averages of unit white noise
    w = np.r_[-np.ones(m), np.ones(m)] / m
    ac = np.correlate(w, w, mode="full")[2 * m - 1:]  # lags 0 .. 2m-1
    lags = np.arange(ac.size)
    var_sum = k * ac[0] ** 2 + 2.0 * np.sum((k - lags[1:]) * ac[1:] ** 2)
    return float(2.0 * (k * ac[0]) ** 2 / (2.0 * var_sum))


def _white_pm_edf_closed_form(d, m, terms, overlapping):
    """Exact EDF of an unmodified d-th difference variance of white phase noise.

    Only lags that are whole multiples of tau correlate; their correlation is the
    autocorrelation of the binomial difference filter (computed here by convolution).
    """
    c = np.array([1.0])
    for _ in range(d):
        c = np.convolve(c, [1.0, -1.0])
    acf = np.correlate(c, c, mode="full")[c.size - 1:]
    rho = acf / acf[0]
    step = m if overlapping else 1  # lag between neighbouring terms, in terms
    s = sum((1.0 - k * step / terms) * rho[k] ** 2 for k in range(1, d + 1) if k * step < terms)
    return terms / (1.0 + 2.0 * s)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("m", [1, 7, 100, 1000, 30_000, 300_000])
@pytest.mark.parametrize("overlapping", [True, False])
def test_white_pm_edf_closed_form_every_m(d, m, overlapping):
    """White PM: the long-m EDF was up to 2x off when a coarse lag grid missed the spikes."""
    n_phase = 1_000_001
    terms = n_phase - d * m if overlapping else (n_phase - 1) // m - d + 1
    ours = edf_greenhall(2, d, m, terms, modified=False, overlapping=overlapping)
    assert ours == pytest.approx(_white_pm_edf_closed_form(d, m, terms, overlapping), rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize(("stat", "d"), [("oadev", 2), ("ohdev", 3)])
def test_white_pm_edf_monte_carlo_large_m(stat, d):
    """Scatter of the variance over records: edf = 2 mean^2 / var (chi-squared law)."""
    g = np.random.default_rng(31)
    m, n = 400, 12_000
    est = []
    for _ in range(400):
        x = g.standard_normal(n + 1)  # white phase
        est.append(deviations(x, 1.0, [stat], [m], "angle")[stat].var[0])
    est = np.asarray(est)
    edf_mc = 2.0 * est.mean() ** 2 / est.var(ddof=1)
    edf = edf_greenhall(2, d, m, n + 1 - d * m, modified=False, overlapping=True)
    # 400 replicates know the edf to about +-7 % (1 sigma)
    assert edf_mc == pytest.approx(edf, rel=0.25)


@pytest.mark.slow
def test_few_averages_edf_not_carried_from_phase_noise():
    """White PM at short tau, random-walk FM at long tau (crossover ~12000 s), 200 records.

    An earlier version carried the type of the last tau with 30 or more averages (here phase
    noise) to every longer tau and reported EDFs of 1e2 .. 6e4 where a few are right. Now
    R(n) says where phase noise ends. The reference is the scatter of the variances over the
    records themselves (EDF = 2 mean^2 / var, the chi-squared law): at most 3 % of the records
    may use an EDF above twice it at any tau of fewer than 30 averages (seed 3: at most 2 %;
    the EDFs there are 222, 11 and 2.6: phase noise still dominates at 8192 s).
    """
    g = np.random.default_rng(3)
    n, reps = 1 << 17, 200
    k = np.sqrt(9.0 / 12000.0**3)  # RWFM with AVAR = 3/tau^2 (white PM, sigma_x = 1) at 12000
    ys = (np.diff(g.standard_normal((reps, n + 1)), axis=1)
          + np.cumsum(k * g.standard_normal((reps, n)), axis=1))
    taus = [4096.0, 8192.0, 16384.0, 32768.0]  # 32, 16, 8, 4 averages
    rs = [deviations(y, 1.0, ["oadev"], taus)["oadev"] for y in ys]
    var = np.array([r.var for r in rs])
    edf = np.array([r.edf for r in rs])
    scatter_edf = 2.0 * var.mean(axis=0) ** 2 / var.var(axis=0, ddof=1)
    too_large = np.mean(edf > 2.0 * scatter_edf, axis=0)
    assert np.all(too_large[1:] <= 0.03), (too_large, scatter_edf)
    r = deviations(ys[0], 1.0, ["oadev"])["oadev"]
    assert r.alpha[0] == 2  # white PM where it dominates, from the whole record
