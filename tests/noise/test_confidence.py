"""EDF and intervals against allantools' Greenhall algorithm, chi-squared law and Monte Carlo."""

from __future__ import annotations

import allantools
import numpy as np
import pytest
from scipy import stats

from inertest.noise.confidence import ONE_SIGMA, chi2_interval, edf_difference, lag1_alpha
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
@pytest.mark.parametrize("m", [2, 10, 100, 400])
def test_totdev_edf_matches_allantools(alpha, m):
    from inertest.noise.confidence import edf_totdev

    ref = allantools.edf_totdev(N=1001, m=m, alpha=alpha)  # SP 1065 Table 11 (Howe)
    assert edf_totdev(alpha, m, 1000) == pytest.approx(ref, rel=0.01)
