"""One-way random effects of run values: closed forms of the balanced case, the F test's level."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from inertest.errors import InputError
from inertest.estimation.random_effects import random_effects


def test_balanced_runs_match_the_closed_forms():
    """Equal in-run variances: REML tau^2 = max(0, s^2 - v) (the ANOVA estimator), mu the
    mean with std s / sqrt(R) (Hartung-Knapp), F = s^2 / v with (R - 1, inf) dof."""
    x = np.array([1.0, 1.4, 0.7, 1.2, 0.9, 1.6])
    v = np.full(6, 0.02)
    re = random_effects(x, v)
    s2 = np.var(x, ddof=1)
    assert re.tau2 == pytest.approx(s2 - 0.02, rel=1e-6)
    assert re.mu == pytest.approx(x.mean(), abs=1e-14)
    assert re.mu_std == pytest.approx(np.sqrt(s2 / 6), rel=1e-6)
    assert re.F == pytest.approx(s2 / 0.02, rel=1e-12)
    assert re.p_value == pytest.approx(stats.chi2.sf(5 * s2 / 0.02, 5), rel=1e-9)
    lo, hi = re.tau2_interval
    # Q-profile with equal v: Q(t) = 5 s^2 / (t + v), so t = 5 s^2 / chi2_q - v
    assert lo == pytest.approx(5 * s2 / stats.chi2.ppf(0.975, 5) - 0.02, rel=1e-8)
    assert hi == pytest.approx(5 * s2 / stats.chi2.ppf(0.025, 5) - 0.02, rel=1e-8)
    small = random_effects(np.array([1.0, 1.01, 0.99]), np.full(3, 1.0))
    assert small.tau2 == 0.0 and small.tau2_interval == (0.0, 0.0)


def test_the_f_test_rejects_at_its_level_without_a_run_to_run_variation():
    rng = np.random.default_rng(1)
    v = np.array([0.5, 1.0, 2.0, 1.0, 0.7])
    p = np.array([random_effects(rng.normal(0.0, np.sqrt(v)), v).p_value for _ in range(800)])
    assert abs(np.mean(p < 0.05) - 0.05) < 3 * np.sqrt(0.05 * 0.95 / 800)


def test_degenerate_inputs_are_refused():
    with pytest.raises(InputError):
        random_effects([1.0], [1.0])
    with pytest.raises(InputError):
        random_effects([1.0, 2.0], [1.0, 0.0])
