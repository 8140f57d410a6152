"""Turn-on to turn-on bias repeatability: the standards' definitions, and a Monte Carlo.

The runs are made by the independent generator of ``tests/static_noise.py`` (white + flicker +
rate random walk, each run from its own power-on), never by the library's ``simulate``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import IdentifiabilityError, InputError, PlanError
from inertest.plan import Instrument, Plan
from inertest.procedures import turn_on_repeatability as tor
from inertest.procedures.static_record import c4
from static_noise import DEG_H, DEG_H_SQRT_H, DEG_SQRT_H, at_rest

LAT = 34.25
W_UP = 7.2921151467e-5 * np.sin(np.radians(LAT)) / DEG_H   # Earth rate on a vertical axis


def plan_for(*, kind="rate-gyro", unit="deg/h", rate=1.0, axis="U", **extra):
    spec = tor.TurnOnRepeatabilitySpec.from_mapping(
        {"sample_rate_hz": rate, "input_axis": axis, **extra})
    return Plan(Site.at(LAT), Instrument(kind=kind, serial="U1", output_unit=unit), spec)


def columns(records: np.ndarray) -> dict[str, np.ndarray]:
    """``run`` and ``output`` columns of records (R, n)."""
    R, n = records.shape
    return {"run": np.repeat([f"r{k}" for k in range(R)], n), "output": records.ravel()}


def test_ieee952_turn_on_repeatability_is_the_std_of_the_run_biases():
    """IEEE Std 952-1997 / 528: bias repeatability = 1 sigma of the biases of N turn-ons, each
    the run's mean output minus the Earth rate along the input axis."""
    rng = np.random.default_rng(1)
    offsets = np.array([0.31, 0.18, 0.44, 0.27, 0.36])
    n = 600
    rec = offsets[:, None] + W_UP + 1e-3 * rng.normal(size=(5, n))
    res = inertest.fit(plan_for(), columns(rec))
    biases = rec.mean(axis=1) - W_UP
    assert res.coefficients["turn_on_repeatability"].value == pytest.approx(
        np.std(biases, ddof=1), rel=1e-12)
    got = [r["bias"]["value"] for r in res.runs]
    np.testing.assert_allclose(got, biases, rtol=0, atol=1e-12)
    # equal runs: the weighted mean is the mean, its std s / sqrt(R) (Hartung-Knapp)
    assert res.coefficients["B"].value == pytest.approx(biases.mean(), abs=1e-12)
    assert res.coefficients["B"].std == pytest.approx(np.std(biases, ddof=1) / np.sqrt(5),
                                                      rel=1e-6)
    lo, hi = res.repeatability["interval_95"]
    s = np.std(biases, ddof=1)
    from scipy.stats import chi2
    assert lo == pytest.approx(s * np.sqrt(4 / chi2.ppf(0.975, 4)), rel=1e-10)
    assert hi == pytest.approx(s * np.sqrt(4 / chi2.ppf(0.025, 4)), rel=1e-10)
    assert res.f_test["p_value"] < 1e-6       # offsets far above the in-run noise


def test_ieee1293_accelerometer_bias_repeatability_with_gravity_removed():
    """IEEE Std 1293-2018: an accelerometer's bias at turn-on, input axis up: output - g."""
    plan = plan_for(kind="accelerometer", unit="m/s^2", axis="U")
    g = plan.site.gravity_m_s2
    offsets_ug = np.array([120.0, 95.0, 140.0, 110.0])
    rng = np.random.default_rng(2)
    rec = g + offsets_ug[:, None] * 9.80665e-6 + 2e-6 * rng.normal(size=(4, 400))
    res = inertest.fit(plan, columns(rec))
    biases_ug = (rec.mean(axis=1) - g) / 9.80665e-6
    assert res.coefficients["B"].unit == "ug"
    assert res.coefficients["turn_on_repeatability"].value == pytest.approx(
        np.std(biases_ug, ddof=1), rel=1e-9)
    assert res.at_rest["value"] == pytest.approx(g / 9.80665e-6)


def test_settling_readings_are_left_out_of_each_run():
    rec = np.zeros((3, 200)) + np.array([[0.1], [0.2], [0.3]]) + W_UP
    rec[:, :20] += 50.0                          # a warm-up transient in the first 20 s
    rec += 1e-3 * np.random.default_rng(3).normal(size=rec.shape)
    res = inertest.fit(plan_for(settle_s=20.0), columns(rec))
    assert res.coefficients["B"].value == pytest.approx(0.2, abs=1e-3)


def test_short_and_degenerate_inputs_are_refused_clearly():
    plan = plan_for()
    two = columns(np.zeros((2, 100)))
    with pytest.raises(IdentifiabilityError, match="at least 3 power-on runs"):
        inertest.fit(plan, two)
    short = columns(np.zeros((4, 10)))
    with pytest.raises(InputError, match="at least 16 are needed"):
        inertest.fit(plan, short)
    bad = columns(np.zeros((3, 100)))
    bad["run"] = np.tile(["a", "b", "c"], 100)
    with pytest.raises(InputError, match="not together"):
        inertest.fit(plan, bad)
    with pytest.raises(InputError, match="run column"):
        inertest.fit(plan, {"output": np.zeros(300)})
    with pytest.raises(PlanError, match="calibrated rate"):
        plan_for(unit="count").procedure  # noqa: B018 - the plan is fine ...
        inertest.fit(plan_for(unit="count"), columns(np.zeros((3, 100))))


def _monte_carlo(reps, *, tau_deg_h, rng, R=6, n=1200):
    """Fits of ``reps`` turn-on tests: (per-rep numbers, the true in-run variance)."""
    N, B, K = 0.005 * DEG_SQRT_H, 0.02 * DEG_H, 0.005 * DEG_H_SQRT_H
    noise = at_rest(rng, (reps, R, n), 1.0, N=N, B=B, K=K) / DEG_H     # deg/h
    offsets = rng.normal(0.0, tau_deg_h, (reps, R))
    plan = plan_for(alpha=0.05)
    out = {k: [] for k in ("B", "B_std", "s", "s_std", "run_std", "run_err", "p")}
    for r in range(reps):
        rec = 0.3 + W_UP + offsets[r][:, None] + noise[r]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = inertest.fit(plan, columns(rec))
        c = res.coefficients
        out["B"].append(c["B"].value)
        out["B_std"].append(c["B"].std)
        out["s"].append(c["turn_on_repeatability"].value)
        out["s_std"].append(c["turn_on_repeatability"].std)
        out["run_std"] += [x["bias"]["std"] for x in res.runs]
        out["run_err"] += list(np.array([x["bias"]["value"] for x in res.runs])
                               - 0.3 - offsets[r])
        out["p"].append(res.f_test["p_value"])
    v_true = float(np.var(noise.mean(axis=2)))      # in-run variance of a run mean, measured
    return {k: np.array(v) for k, v in out.items()}, v_true


@pytest.mark.slow
def test_monte_carlo_turn_on_std_recovery_and_ratios():
    """White + flicker + rate random walk in-run, a turn-on offset of 0.05 deg/h (1 sigma):
    the per-run bias std (Allan-based, not white) and the std of B and of the repeatability
    match their Monte Carlo scatter within 0.8-1.25; estimates are centred on the truth."""
    mc, v = _monte_carlo(120, tau_deg_h=0.05, rng=np.random.default_rng(11))
    sigma_r = np.sqrt(0.05**2 + v)                  # population std of the run biases
    ratio_run = np.sqrt(np.mean(mc["run_std"] ** 2)) / np.std(mc["run_err"])
    ratio_B = np.sqrt(np.mean(mc["B_std"] ** 2)) / np.std(mc["B"] - 0.3)
    ratio_s = np.sqrt(np.mean(mc["s_std"] ** 2)) / np.std(mc["s"])
    print(f"turn-on MC: run bias {ratio_run:.3f}, B {ratio_B:.3f}, repeatability {ratio_s:.3f}")
    for ratio in (ratio_run, ratio_B, ratio_s):
        assert 0.8 <= ratio <= 1.25
    # white noise alone (N / sqrt(T)) would claim a run bias std 1.4x too small here
    white = 0.005 * 60 / np.sqrt(1200)
    assert np.sqrt(v) > 1.3 * white
    # recovery: the mean error within 3 standard errors of the Monte Carlo mean
    assert abs(np.mean(mc["B"]) - 0.3) < 3 * np.std(mc["B"]) / np.sqrt(mc["B"].size)
    # E[s] = c4 sigma_R for the sample std of R normal values
    assert abs(np.mean(mc["s"]) - c4(6) * sigma_r) < 3 * np.std(mc["s"]) / np.sqrt(mc["s"].size)


@pytest.mark.slow
def test_monte_carlo_f_test_false_alarm_rate_at_its_level():
    """No turn-on offset: the within-run vs between-run F test rejects at about its 5 % level
    (in-run white + flicker + a rate random walk of 3 % of a run mean's variance)."""
    mc, _ = _monte_carlo(300, tau_deg_h=0.0, rng=np.random.default_rng(12))
    rate = float(np.mean(mc["p"] < 0.05))
    print(f"turn-on F test: false-alarm rate {rate:.3f} at 0.05 (300 runs of the test)")
    assert abs(rate - 0.05) <= 3 * np.sqrt(0.05 * 0.95 / 300)
