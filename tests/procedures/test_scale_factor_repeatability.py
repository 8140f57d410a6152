"""Scale-factor repeatability over rate-table runs: the standard's definitions, Monte Carlo.

The runs are generated here (a gyro of known K, asymmetry and bias per run on a vertical
rate table, Earth rate included), not by the library's ``simulate``.
"""

from __future__ import annotations

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import IdentifiabilityError, InputError
from inertest.plan import Instrument, Plan
from inertest.procedures import scale_factor_repeatability as sfr
from inertest.procedures.static_record import c4

LAT = 34.25
W_UP = 7.2921151467e-5 * np.sin(np.radians(LAT))        # rad/s on a vertical table axis
RATES = np.array([-200.0, -50.0, -10.0, 10.0, 50.0, 200.0])


def plan_for(**params):
    spec = sfr.ScaleFactorRepeatabilitySpec.from_mapping(
        {"rates_deg_s": RATES.tolist(), "noise_model": "white", **params})
    return Plan(Site.at(LAT), Instrument(kind="rate-gyro", serial="U1", output_unit="count"),
                spec)


def runs(K, B_deg_h, asym_ppm, *, spr=4, noise=0.0, rng=None):
    """Columns of len(K) runs: output = K (1 +- a/2) w + K (W_up + B), count/s."""
    w = np.repeat(np.radians(RATES), spr)
    out = {"run": [], "rate_deg_s": [], "output": []}
    for r, (k, b) in enumerate(zip(K, B_deg_h, strict=True)):
        k_si = k * 180 / np.pi                         # count/s per rad/s
        y = k_si * (1 + np.sign(w) * asym_ppm * 1e-6 / 2) * w + k_si * (
            W_UP + b * np.pi / 180 / 3600)
        if noise:
            y = y + noise * rng.normal(size=y.size)
        out["run"] += [f"day {r + 1}"] * y.size
        out["rate_deg_s"] += list(np.repeat(RATES, spr))
        out["output"] += list(y)
    return {k: np.array(v) for k, v in out.items()}


def test_ieee952_scale_factor_repeatability_is_the_relative_std_of_the_runs_k():
    """IEEE Std 952-1997 / 528: scale-factor repeatability = 1 sigma of the scale factors of
    repeated runs over their mean [ppm]; each run's K = (K+ + K-) / 2 of its rate test."""
    K = np.array([7200.10, 7199.85, 7200.40, 7199.95])
    res = inertest.fit(plan_for(), runs(K, [0.3, 0.32, 0.28, 0.31], 25.0), sigma=1e-6)
    want = np.std(K, ddof=1) / np.mean(K) * 1e6
    assert res.coefficients["K_repeatability"].value == pytest.approx(want, rel=1e-6)
    assert res.coefficients["K"].value == pytest.approx(np.mean(K), rel=1e-9)
    assert res.coefficients["asymmetry"].value == pytest.approx(25.0, abs=1e-3)
    assert res.coefficients["B"].value == pytest.approx(0.3025, abs=1e-6)
    assert [r["K"]["value"] for r in res.runs] == pytest.approx(K, rel=1e-9)
    # a straight gyro without asymmetry: no deviation from each run's line
    straight = inertest.fit(plan_for(), runs(K, [0.3] * 4, 0.0), sigma=1e-6)
    assert straight.linearity["nonlinearity"] == pytest.approx(0.0, abs=1e-6)


def test_ieee952_nonlinearity_of_a_quadratic_error_from_the_runs_line():
    """A quadratic error K K2 w^2 with symmetric rates: each rate deviates from the straight
    line by K K2 (w^2 - mean w^2) (closed form), in ppm of the full-scale output K w_max."""
    k2 = 0.1e-6 / np.radians(1.0)                    # 0.1 ppm/(deg/s) in 1/(rad/s)
    data = runs([7200.0] * 3, [0.3] * 3, 0.0, spr=1)
    w = np.radians(data["rate_deg_s"])
    data["output"] = data["output"] + 7200.0 * 180 / np.pi * k2 * w**2
    res = inertest.fit(plan_for(), data, sigma=1e-6)
    wr = np.radians(RATES)
    want = k2 * (wr**2 - np.mean(wr**2)) / (np.radians(200.0)) * 1e6
    np.testing.assert_allclose(res.linearity["deviation"], want, rtol=1e-6, atol=1e-9)


def test_too_few_runs_or_one_direction_are_refused():
    with pytest.raises(IdentifiabilityError, match="at least 3 runs"):
        inertest.fit(plan_for(), runs([7200.0, 7200.1], [0.3, 0.3], 0.0, noise=0.1,
                                      rng=np.random.default_rng(1)))
    one_way = runs([7200.0] * 3, [0.3] * 3, 0.0, noise=0.1, rng=np.random.default_rng(1))
    keep = one_way["rate_deg_s"] > 0
    with pytest.raises(IdentifiabilityError, match="both directions"):
        inertest.fit(plan_for(), {k: v[keep] for k, v in one_way.items()})
    with pytest.raises(InputError, match="run column"):
        inertest.fit(plan_for(), {k: v for k, v in one_way.items() if k != "run"})


@pytest.mark.slow
def test_monte_carlo_reported_std_matches_scatter_and_f_test_level():
    """Five days, K varying 20 ppm (1 sigma) from day to day, white noise per reading: K, the
    repeatability, the asymmetry and B recover the truth within their std, whose RMS matches
    the scatter within 0.8-1.25; without day-to-day variation the F test rejects at its 5 %."""
    rng = np.random.default_rng(31)
    plan = plan_for()
    got, stds, pvals = [], [], []
    for _ in range(100):
        K = 7200.0 * (1 + 20e-6 * rng.normal(size=5))
        res = inertest.fit(plan, runs(K, 0.3 + 0.02 * rng.normal(size=5), 15.0, noise=1.0,
                                      rng=rng))
        got.append([res.coefficients[n].value for n in ("K", "K_repeatability", "asymmetry",
                                                        "B")])
        stds.append([res.coefficients[n].std for n in ("K", "K_repeatability", "asymmetry",
                                                       "B")])
        null = inertest.fit(plan, runs(np.full(5, 7200.0), np.full(5, 0.3), 15.0, noise=1.0,
                                       rng=rng))
        pvals.append(null.between_runs["K"]["f_test"]["p_value"])
    got, stds = np.array(got), np.array(stds)
    ratio = np.sqrt(np.mean(stds**2, axis=0)) / got.std(axis=0)
    print("scale-factor repeatability MC ratios (K, K_rep, asym, B):", np.round(ratio, 3),
          "F false alarms", np.mean(np.array(pvals) < 0.05))
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    assert abs(got[:, 0].mean() - 7200.0) < 3 * got[:, 0].std() / np.sqrt(100)
    assert abs(got[:, 2].mean() - 15.0) < 3 * got[:, 2].std() / np.sqrt(100)
    # E[s] = c4 sigma with sigma^2 = 20^2 + the in-run part of a day's K (small here)
    assert abs(got[:, 1].mean() - c4(5) * 20.0) < 3 * got[:, 1].std() / np.sqrt(100) + 1.0
    rate = np.mean(np.array(pvals) < 0.05)
    assert abs(rate - 0.05) <= 3 * np.sqrt(0.05 * 0.95 / 100)
