import numpy as np
import pytest
from scipy import stats

from inertest.errors import InputError
from inertest.estimation.trend import summarize


def test_mean_repeatability_trend_against_scipy():
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 400, 12))
    x = 0.85 + 1e-4 * t + rng.normal(0, 0.003, 12)
    h = summarize("DI", "deg/h/g", t, x, np.full(12, 0.002))
    assert h.mean == pytest.approx(np.mean(x))
    assert h.repeatability == pytest.approx(np.std(x, ddof=1))
    ref = stats.linregress(t, x)
    assert h.trend_per_day == pytest.approx(ref.slope, rel=1e-10)
    assert h.trend_std_per_day == pytest.approx(ref.stderr, rel=1e-10)
    assert not h.flagged.any()


def test_outlier_flagged_and_too_few_runs_say_so():
    x = np.array([1.00, 1.01, 0.99, 1.00, 1.30])
    h = summarize("DF", "deg/h", np.arange(5.0), x, np.full(5, 0.01))
    assert h.flagged.tolist() == [False, False, False, False, True]
    one = summarize("DF", "deg/h", [0.0], [1.0], [0.01])
    assert one.repeatability is None and one.trend_per_day is None
    assert "repeatability needs at least 2 runs" in one.messages
    two = summarize("DF", "deg/h", [0.0, 1.0], [1.0, 1.05], [0.01, 0.01])
    # with one other run: z = (x - x_o) / (sqrt(2) s)
    assert two.z[1] == pytest.approx(0.05 / (np.sqrt(2) * 0.01))
    assert two.trend_per_day is None
    with pytest.raises(InputError, match="NaN"):
        summarize("DF", "deg/h", [0.0, 1.0], [1.0, np.nan], [0.1, 0.1])


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
