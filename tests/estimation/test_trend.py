import numpy as np
import pytest
from scipy import optimize, stats

from inertest.errors import InputError
from inertest.estimation.trend import summarize


def _line(t, a, b):
    return a + b * t


def _curve_fit(t, x, s, absolute):
    """Slope and its std from scipy's curve_fit (a peer GLS implementation)."""
    p, cov = optimize.curve_fit(_line, t, x, p0=[np.mean(x), 0.0], sigma=s,
                                absolute_sigma=absolute,
                                jac=lambda t, a, b: np.column_stack([np.ones_like(t), t]))
    return p[1], np.sqrt(cov[1, 1])


def test_equal_stds_reduce_to_the_ordinary_statistics():
    """Equal stds, scatter as stated: mean, sample std and the least-squares slope (scipy
    linregress), the slope std from the stated std: s / sqrt(sum (t - tbar)^2)."""
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 400, 12))
    x = 0.85 + 1e-4 * t + rng.normal(0, 0.002, 12)
    h = summarize("DI", "deg/h/g", t, x, np.full(12, 0.002))
    assert h.weighted and h.trend_test.consistent
    # the trend (0.04 over the span) is scatter about the mean far beyond the stds
    assert not h.scatter.consistent
    assert h.mean == pytest.approx(np.mean(x))
    chi2 = np.sum((x - x.mean()) ** 2) / 0.002**2
    assert h.mean_std == pytest.approx(np.sqrt(chi2 / 11) * 0.002 / np.sqrt(12))
    assert h.repeatability == pytest.approx(np.std(x, ddof=1))
    ref = stats.linregress(t, x)
    assert h.trend_per_day == pytest.approx(ref.slope, rel=1e-10)
    assert h.trend_std_per_day == pytest.approx(0.002 / np.sqrt(np.sum((t - t.mean()) ** 2)))
    assert h.trend_inflation == 1.0
    assert not h.flagged.any()


def test_gls_trend_and_weighted_mean_against_scipy_with_unequal_stds():
    rng = np.random.default_rng(6)
    t = np.array([0.0, 31.0, 59.0, 90.0, 120.0, 151.0, 181.0])
    s = np.array([0.002, 0.004, 0.001, 0.003, 0.002, 0.006, 0.0015])
    x = 0.4 + 5e-6 * t + rng.normal(0, s)
    h = summarize("DF", "deg/h", t, x, s)
    slope, slope_std = _curve_fit(t, x, s, absolute=True)
    assert h.trend_test.consistent and h.trend_inflation == 1.0 and h.scatter.consistent
    assert h.trend_per_day == pytest.approx(slope, rel=1e-8)
    assert h.trend_std_per_day == pytest.approx(slope_std, rel=1e-8)
    w = 1 / s**2
    assert h.mean == pytest.approx(np.average(x, weights=w))
    assert h.mean_std == pytest.approx(1 / np.sqrt(w.sum()))
    # scatter test about the weighted mean: chi2 with n - 1 dof
    chi2 = np.sum(w * (x - np.average(x, weights=w)) ** 2)
    assert h.scatter.chi2 == pytest.approx(chi2) and h.scatter.dof == 6
    assert h.scatter.p == pytest.approx(stats.chi2.sf(chi2, 6))
    d = h.to_dict()
    assert d["trend_test"]["dof"] == 5 and d["scatter_test"]["verdict"].startswith("consistent")


def test_issue15_three_runs_of_a_stable_gyro_give_no_spurious_trend():
    """Three runs that happen to lie almost on a line: the unweighted fit took its std from the
    (tiny) residual and printed a trend of ~100 sigma; the run stds give the honest std."""
    t = np.array([0.0, 30.0, 60.0])
    s = np.full(3, 0.0015)
    x = np.array([0.0110, 0.0112, 0.011400004])
    ols = stats.linregress(t, x)
    assert abs(ols.slope / ols.stderr) > 100  # what the unweighted fit claimed
    h = summarize("DF", "deg/h", t, x, s)
    slope, slope_std = _curve_fit(t, x, s, absolute=True)
    assert h.trend_std_per_day == pytest.approx(slope_std, rel=1e-8)
    assert h.trend_std_per_day * 30 == pytest.approx(0.0015 / np.sqrt(2), rel=1e-8)
    assert abs(h.trend_per_day / h.trend_std_per_day) < 0.5
    assert h.scatter.consistent and h.trend_inflation == 1.0


def test_excess_scatter_inflates_by_the_birge_ratio_and_says_so():
    """Scatter far beyond the stated stds: the trend std becomes the one curve_fit gives with
    relative sigmas (covariance scaled by chi2 / dof, i.e. the Birge ratio squared)."""
    rng = np.random.default_rng(9)
    t = np.linspace(0, 300, 8)
    s = np.array([1.0, 2.0, 1.0, 1.5, 1.0, 2.0, 1.0, 1.2]) * 1e-3
    x = 1.0 + rng.normal(0, 10 * s)
    h = summarize("DI", "deg/h/g", t, x, s)
    assert not h.scatter.consistent and not h.trend_test.consistent
    _, inflated = _curve_fit(t, x, s, absolute=False)
    _, stated = _curve_fit(t, x, s, absolute=True)
    assert h.trend_std_per_day == pytest.approx(inflated, rel=1e-8)
    assert h.trend_inflation == pytest.approx(inflated / stated, rel=1e-8)
    assert h.trend_inflation == pytest.approx(np.sqrt(h.trend_test.chi2 / 6))
    w = 1 / s**2
    assert h.mean_std == pytest.approx(h.scatter.birge_ratio / np.sqrt(w.sum()))
    assert any("trend std inflated by the Birge ratio" in m for m in h.messages)
    assert any("scatter exceeds the run stds" in m for m in h.messages)
    assert h.to_dict()["trend_std_inflation"] == h.trend_inflation


def test_a_run_without_std_falls_back_to_unweighted_and_says_so():
    t = np.array([0.0, 10.0, 20.0, 30.0])
    x = np.array([1.0, 1.2, 1.1, 1.4])
    h = summarize("DF", "deg/h", t, x, [0.1, 0.0, 0.1, 0.1])
    ref = stats.linregress(t, x)
    assert not h.weighted and h.scatter is None and h.trend_test is None
    assert h.trend_per_day == pytest.approx(ref.slope) and h.trend_std_per_day == pytest.approx(
        ref.stderr)
    assert h.repeatability == pytest.approx(np.std(x, ddof=1))
    assert any("cannot be weighted" in m for m in h.messages)


def test_outlier_flagged_and_too_few_runs_say_so():
    x = np.array([1.00, 1.01, 0.99, 1.00, 1.30])
    h = summarize("DF", "deg/h", np.arange(5.0), x, np.full(5, 0.01))
    assert h.flagged.tolist() == [False, False, False, False, True]
    one = summarize("DF", "deg/h", [0.0], [1.0], [0.01])
    assert one.repeatability is None and one.trend_per_day is None and one.scatter is None
    assert "repeatability needs at least 2 runs" in one.messages
    two = summarize("DF", "deg/h", [0.0, 1.0], [1.0, 1.05], [0.01, 0.01])
    # with one other run: z = (x - x_o) / (sqrt(2) s)
    assert two.z[1] == pytest.approx(0.05 / (np.sqrt(2) * 0.01))
    assert two.trend_per_day is None and two.scatter.dof == 1
    with pytest.raises(InputError, match="NaN"):
        summarize("DF", "deg/h", [0.0, 1.0], [1.0, np.nan], [0.1, 0.1])
    with pytest.raises(InputError, match="negative std"):
        summarize("DF", "deg/h", [0.0, 1.0], [1.0, 1.0], [0.1, -0.1])
    with pytest.raises(InputError, match="alpha"):
        summarize("DF", "deg/h", [0.0, 1.0], [1.0, 1.0], [0.1, 0.1], alpha=1.5)


@pytest.mark.slow
def test_stable_instrument_trend_z_is_standard_normal_monte_carlo():
    """Stable instrument, five runs with known, unequal stds: the trend z-scores are N(0, 1)
    (std within 0.8-1.25), |z| > 3 about as often as the normal law says (0.27 %), and the
    scatter test rejects at its level alpha = 1 %."""
    rng = np.random.default_rng(11)
    t = np.array([0.0, 20.0, 45.0, 90.0, 130.0])
    trials = 8000
    z = np.empty(trials)
    rejected = 0
    for i in range(trials):
        s = rng.uniform(0.5, 2.0, t.size) * 1e-3
        h = summarize("DF", "deg/h", t, 0.01 + rng.normal(0, s), s)
        z[i] = h.trend_per_day / h.trend_std_per_day
        rejected += int(not h.scatter.consistent)
    assert 0.8 < np.std(z) < 1.25
    assert abs(np.std(z) - 1) < 0.05  # in fact
    false_rate = np.mean(np.abs(z) > 3)
    assert 0.0012 < false_rate < 0.0050  # 2 * norm.sf(3) = 0.0027
    assert 0.005 < rejected / trials < 0.016


@pytest.mark.slow
def test_false_flag_rate_matches_the_prediction_interval():
    """Runs from a stable instrument: |z| > 3 about as often as Student-t predicts."""
    rng = np.random.default_rng(8)
    n, trials, flags = 8, 2000, 0
    for _ in range(trials):
        x = rng.normal(0, 1.0, n)
        h = summarize("DI", "u", np.arange(n, dtype=float), x, np.full(n, 0.1), k=3.0)
        flags += int(h.flagged[0])
    expected = 2 * stats.t.sf(3.0, df=n - 2)
    assert flags / trials == pytest.approx(expected, abs=0.01)


def test_trend_line_and_its_std_against_scipy_curve_fit_prediction():
    """The trend line at any time (here 60 days past the last run) and its standard uncertainty
    equal scipy's curve_fit line a + b t with the standard error of a + b t from its covariance
    (absolute sigma: the run stds are known)."""
    t = np.array([0.0, 12.0, 40.0, 75.0, 101.0])
    s = np.array([1.0, 2.0, 1.5, 0.7, 1.2]) * 1e-3
    x = 0.02 + 3e-5 * t + np.array([0.4, -1.1, 0.6, 0.2, -0.5]) * 1e-3
    h = summarize("DF", "deg/h", t, x, s)
    p, cov = optimize.curve_fit(_line, t, x, p0=[0.0, 0.0], sigma=s, absolute_sigma=True)
    tq = np.array([0.0, 50.0, 161.0])
    g = np.column_stack([np.ones_like(tq), tq])
    line, std = h.trend_line(tq)
    np.testing.assert_allclose(line, _line(tq, *p), rtol=1e-9)
    np.testing.assert_allclose(std, np.sqrt(np.einsum("ij,jk,ik->i", g, cov, g)), rtol=1e-6)


def test_no_trend_line_from_two_runs():
    h = summarize("DF", "deg/h", [0.0, 5.0], [1.0, 1.1], [0.1, 0.1])
    with pytest.raises(InputError, match="at least 3 runs"):
        h.trend_line([1.0])


@pytest.mark.slow
def test_trend_line_std_covers_the_true_line_monte_carlo():
    """A drifting instrument, four runs: (line - truth) / std at an extrapolated time is
    N(0, 1) over 4000 records (std within 5 %)."""
    rng = np.random.default_rng(29)
    t = np.array([0.0, 30.0, 61.0, 95.0])
    s = np.array([2.0, 1.0, 1.5, 1.0]) * 1e-3
    z = []
    for _ in range(4000):
        x = 0.05 + 2e-5 * t + rng.normal(0.0, s)
        line, std = summarize("DF", "deg/h", t, x, s, alpha=1e-9).trend_line([150.0])
        z.append((line[0] - (0.05 + 2e-5 * 150.0)) / std[0])
    assert abs(np.std(z) - 1.0) < 0.05
    assert abs(np.mean(z)) < 0.05
