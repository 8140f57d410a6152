"""The identification front: noise models, model checks, honest uncertainty (Monte Carlo)."""

import json
import warnings

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import InertestWarning, InputError, PlanError
from inertest.estimation import identify as idf
from inertest.estimation import selection
from inertest.plan import Instrument, Plan
from inertest.procedures import accelerometer_multipoint as amp
from inertest.procedures import gyro_rate_table as grt
from inertest.procedures import local_level_tumble as ll
from inertest.procedures import polar_tumble as pt
from inertest.procedures.accelerometer_multipoint import AccelerometerMultipointSpec as AMSpec
from inertest.procedures.gyro_rate_table import GyroRateTableSpec as GRTSpec
from inertest.procedures.local_level_tumble import LocalLevelTumbleSpec as LLSpec
from noise_generators import noise as noise_for


def _balanced(rng, G=20, m=8, sb=1.0, sw=1.0):
    x = np.linspace(-1, 1, G)
    A_unit = np.column_stack([np.ones(G), x, x**2])
    A = np.repeat(A_unit, m, axis=0)
    y = A @ [1.0, 2.0, -0.5] + np.repeat(rng.normal(0, sb, G), m) + rng.normal(0, sw, G * m)
    groups = np.repeat([f"p{i:02d}" for i in range(G)], m)
    return A, y, groups, A_unit


def test_searle_balanced_random_effects_equal_ols_on_position_means():
    """Balanced one-way random effects (Searle, Casella & McCulloch 1992, ch. 3): GLS over the
    position means is OLS over them, with covariance s_m^2 (X'X)^-1 where s_m^2 is the residual
    variance of the means (REML = ANOVA when the between component is positive)."""
    A, y, groups, Xu = _balanced(np.random.default_rng(3))
    fit, noise = idf.solve(A, y, groups=groups, noise_model="position-offsets")
    ybar = y.reshape(20, 8).mean(axis=1)
    x_ref, *_ = np.linalg.lstsq(Xu, ybar, rcond=None)
    r = ybar - Xu @ x_ref
    s_m2 = r @ r / (20 - 3)
    np.testing.assert_allclose(fit.x, x_ref, rtol=1e-9)
    np.testing.assert_allclose(fit.covariance, s_m2 * np.linalg.inv(Xu.T @ Xu), rtol=2e-3,
                               atol=1e-12)
    sw2 = np.sum((y - np.repeat(ybar, 8)) ** 2) / (160 - 20)
    assert noise.components["white"] == pytest.approx(np.sqrt(sw2), rel=1e-12)
    assert noise.components["position offset"] == pytest.approx(np.sqrt(s_m2 - sw2 / 8), rel=2e-3)
    assert noise.model == "position-offsets" and noise.checks.unit == "position"


def test_white_model_is_the_classical_least_squares():
    rng = np.random.default_rng(4)
    A, y, groups, _ = _balanced(rng, sb=0.0)
    fit, noise = idf.solve(A, y, groups=groups, noise_model="white")
    x_ref, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ x_ref
    np.testing.assert_allclose(fit.x, x_ref, rtol=1e-10)
    np.testing.assert_allclose(fit.covariance, r @ r / (160 - 3) * np.linalg.inv(A.T @ A),
                               rtol=1e-9, atol=1e-15)
    assert noise.checks.verdict == "consistent" and noise.checks.p_value is not None


def test_bias_time_scale_widens_the_constant_term_not_the_slope_and_is_stated():
    """Under flicker a longer bias time scale raises the std of the constant term (the bias
    wanders over the longer time), barely that of a slope; the JSON says which time scale."""
    rng = np.random.default_rng(11)
    G, m = 24, 5
    t = np.repeat(np.linspace(-1, 1, G), m)
    A = np.column_stack([np.ones(G * m), np.cos(np.pi * t)])
    y = A @ [1.0, 0.5] + 0.01 * rng.normal(size=G * m) + 0.01 * np.cumsum(rng.normal(size=G * m))
    groups = np.repeat(np.arange(G), m).astype(str)
    kw = dict(names=("b", "k"), units=dict.fromkeys("bk", "V"),
              si_per_unit=dict.fromkeys("bk", 1.0), noise_unit="V", si_per_noise_unit=1.0,
              groups=groups, noise_model="flicker")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)
        _, short = idf.identify(A, y, **kw)
        _, long = idf.identify(A, y, bias_time_scale=64.0, **kw)
        _, white = idf.identify(A, y, **{**kw, "noise_model": "white"})
    assert long.coefficients["b"].std > 1.3 * short.coefficients["b"].std
    assert long.coefficients["k"].std < 1.1 * short.coefficients["k"].std
    assert short.bias_time_scale == 2.0
    stated = json.loads(json.dumps(long.to_dict()))["noise"]["bias_time_scale"]
    assert stated["value"] == 64.0 and stated["unit"] == "test durations"
    assert "bias instability" in stated["meaning"]
    assert "bias_time_scale" not in white.to_dict()["noise"]


@pytest.mark.parametrize("bad", [0.5, float("nan"), True, "8"])
def test_bias_time_scale_is_checked(bad):
    with pytest.raises(PlanError, match="bias_time_scale"):
        idf.solve(np.ones((10, 1)), np.zeros(10), bias_time_scale=bad)


def test_given_sigma_is_reported_and_serialises_without_nan():
    rng = np.random.default_rng(5)
    A, y, groups, _ = _balanced(rng, sb=0.0)
    _, ident = idf.identify(A, y, names=("a", "b", "c"), units=dict.fromkeys("abc", "V"),
                            si_per_unit=dict.fromkeys("abc", 1.0), noise_unit="V",
                            si_per_noise_unit=1.0, sigma_si=1.0, groups=groups,
                            noise_model="auto")
    d = ident.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["noise"] == {"sigma": 1.0, "unit": "V", "source": "given", "model": "white",
                          "components": {"white": 1.0}}
    assert d["checks"]["verdict"] == "consistent"
    assert d["checks"]["goodness_of_fit"]["dof"] == 20 - 3


def test_outlying_position_is_named_and_warned():
    rng = np.random.default_rng(6)
    A, y, groups, _ = _balanced(rng, sb=0.0)
    y[groups == "p07"] += 3.0  # 8.5 sigma of a position mean
    with pytest.warns(InertestWarning, match="p07"):
        _, noise = idf.solve(A, y, groups=groups, noise_model="white", sigma_si=1.0)
    assert [o.label for o in noise.checks.outliers] == ["p07"]
    assert noise.checks.verdict == "model does not fit"


def test_bad_noise_model():
    with pytest.raises(InputError, match="unknown noise model"):
        idf.solve(np.ones((5, 1)), np.ones(5), noise_model="pink")
    with pytest.raises(PlanError, match="noise_model = \"pink\" is not one of auto"):
        pt.PolarTumbleSpec.from_mapping({"noise_model": "pink"})


# --- Monte Carlo: reported std against the scatter over repeated tests ----------------------
# Noise from tests/noise_generators.py (not the library): white; white + an offset per position
# as large as the sample noise; white + a random walk that wanders ~3 sigma over the test;
# flicker (1/f) noise by FFT shaping of white noise (power 1/f from 1/(2n) up).


SITE = Site.at(34.246)
SETUPS = {
    "polar-tumble": (pt, lambda nm: Plan(SITE, Instrument(output_unit="deg/h"),
                     pt.PolarTumbleSpec.from_mapping({"positions": 8, "samples_per_position": 6,
                                           "noise_model": nm})),
                     dict(DF=1.2, DI=0.85, DO=-0.62, DS=0.31, DIO=0.12), 6, 0.01),
    "local-level-tumble": (ll, lambda nm: Plan(SITE, Instrument(output_unit="deg/h"),
                           LLSpec.from_mapping({"samples_per_position": 6, "noise_model": nm})),
                           dict(DF=1.2, DI=0.85, DO=-0.62, DS=0.31), 6, 0.01),
    "accelerometer-multipoint": (amp, lambda nm: Plan(
        SITE, Instrument(kind="accelerometer", output_unit="mA"),
        AMSpec.from_mapping({"positions": 12, "samples_per_position": 6, "noise_model": nm})),
        dict(K1=1.3, K0=50.0, K2=20.0, dO=30.0), 6, 1e-5),
    "gyro-rate-table": (grt, lambda nm: Plan(
        SITE, Instrument(kind="rate-gyro", output_unit="count"),
        GRTSpec.from_mapping({"rates_deg_s": [-300.0, -100, -30, -10, -3, -1, 1, 3, 10, 30,
                                               100, 300], "samples_per_rate": 6,
                               "noise_model": nm})),
        dict(K=7200.0, B=0.4, asymmetry=50.0), 6, 0.5),
}


def mc_ratio(procedure, noise_kind, noise_model, reps=200, seed=11):
    """RMS reported std / scatter of the estimates, per identifiable quantity."""
    mod, make, truth, spp, s = SETUPS[procedure]
    plan = make(noise_model)
    clean = inertest.simulate(plan, truth)
    n = clean["output"].size
    noise = noise_for(noise_kind, np.random.default_rng(seed), reps, np.arange(n) // spp, s)
    vals, stds = [], []
    for k in range(reps):
        data = dict(clean, output=clean["output"] + noise[k])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertestWarning)  # rare false alarms at alpha
            res = inertest.fit(plan, data)
        est = [*res.coefficients.values(), *res.combinations]
        vals.append([e.value for e in est])
        stds.append([e.std for e in est])
    vals, stds = np.array(vals), np.array(stds)
    return np.sqrt(np.mean(stds**2, axis=0)) / vals.std(axis=0, ddof=1)


KINDS = ("white", "position-offsets", "random-walk", "flicker")


@pytest.mark.slow
@pytest.mark.parametrize("procedure", list(SETUPS))
@pytest.mark.parametrize("kind", KINDS)
def test_monte_carlo_reported_std_matches_scatter_under_each_noise(procedure, kind):
    """With the instrument's noise model named in the plan, reported std / MC scatter is within
    0.8-1.25 for every identifiable quantity."""
    ratio = mc_ratio(procedure, kind, kind)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


AUTO_SETUPS = ("polar-tumble", "local-level-tumble", "accelerometer-multipoint", "gyro-rate-table")


@pytest.mark.slow
@pytest.mark.parametrize("procedure", AUTO_SETUPS)
@pytest.mark.parametrize("kind", KINDS)
def test_monte_carlo_auto_noise_model_is_honest_under_each_noise(procedure, kind):
    """``noise_model = "auto"``: reported std / MC scatter within 0.8-1.25 whichever the true
    noise, also under white noise (not made too conservative by the model uncertainty).

    Before (the AIC-best model alone, 200 reps): flicker 0.75 (polar tumble), 0.70 (local-level
    tumble), 0.73 (accelerometer), random walk 0.80-0.82. The largest covariance among the
    models within 2 AIC: 0.69 (local-level, flicker) and 1.54 (accelerometer, offsets). After
    (best model plus the Akaike-weighted spread of the close models' estimates): 0.83-1.23.
    The gyro rate table's bias B under white noise was 1.27 with the choice by AIC (a richer
    model on 24 of 200 white records, a random walk's variance of B including the walk's
    level); white unless the likelihood-ratio test rejects it (identify.common_noise_model):
    1.10, the other cells 0.84-1.24.
    """
    ratio = mc_ratio(procedure, kind, "auto")
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def test_auto_reports_the_candidates_and_their_weights():
    """Flicker on a short local-level tumble: the models are hard to tell apart; the result
    names the chosen model, gives every candidate's Akaike weight and serialises them."""
    mod, make, truth, spp, s = SETUPS["local-level-tumble"]
    plan = make("auto")
    clean = inertest.simulate(plan, truth)
    n = clean["output"].size
    noise = noise_for("flicker", np.random.default_rng(2), 1, np.arange(n) // spp, s)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)
        ident = inertest.fit(plan, dict(clean, output=clean["output"] + noise)).identification
    w = ident.noise_model_weights
    assert set(w) == {"white", "position-offsets", "random-walk", "flicker"}
    assert sum(w.values()) == pytest.approx(1.0)
    assert ident.noise_model == max(w, key=w.get)
    sel = json.loads(json.dumps(ident.to_dict(), allow_nan=False))["noise"]["selection"]
    assert sel["weights"] == pytest.approx(w) and "Akaike" in sel["rule"]
    assert ident.noise_model in sel["close"]
    assert set(sel["close"]) == {m for m in w if w[m] >= w[ident.noise_model] * np.exp(-1)}
    assert len(sel["close"]) > 1  # this record cannot tell them apart


def test_common_noise_model_pools_the_aic_of_the_outputs():
    """Several outputs, one model: the criterion summed over them (not the model picked most
    often), a correlated model's 2 k of AIC replaced by the critical value of its likelihood-
    ratio test against white, weights exp(-delta / 2), the models within 2 per output of the
    best."""
    aic = [{"white": 10.0, "position-offsets": 9.0, "random-walk": 12.0, "flicker": 30.0},
           {"white": 10.0, "position-offsets": 12.0, "random-walk": 9.5, "flicker": 30.0},
           {"white": 10.0, "position-offsets": 9.8, "random-walk": 9.9, "flicker": 30.0}]
    model, w, near = selection.common_noise_model(aic)
    assert model == "white"  # each output alone would pick offsets or random walk by AIC
    assert near == ["white", "position-offsets", "random-walk"]
    pen = selection.component_penalty(3, 3)
    d = np.array([0.0, 0.8 - 6 + pen, 1.4 - 6 + pen, 60.0 - 6 + pen])
    np.testing.assert_allclose([w[m] for m in aic[0]], np.exp(-d / 2) / np.exp(-d / 2).sum())


@pytest.mark.parametrize("lr, model", [(3.0, "white"), (5.0, "random-walk")])
def test_auto_keeps_white_unless_the_likelihood_ratio_test_rejects_it(lr, model):
    """One output: a correlated model 2 nll lower than white by 3 has the smaller AIC but does
    not pass the test (critical value 4.53 for three candidates at 5 %); by 5 it does."""
    aic = {"white": 10.0, "position-offsets": 12.0, "random-walk": 10.0 - lr + 2,
           "flicker": 12.0}
    assert selection.common_noise_model([aic])[0] == model


@pytest.mark.parametrize("k, J", [(1, 1), (1, 3), (2, 3), (3, 3)])
def test_component_penalty_is_the_chi_bar_square_critical_value(k, J):
    """Upper alpha / J point of sum_j C(k, j) 2^-k chi2_j (Self & Liang 1987), by
    scipy.stats for one output and by simulation of k boundary components for several."""
    import scipy.stats

    c = selection.component_penalty(k, J)
    if k == 1:
        assert c == pytest.approx(scipy.stats.chi2.isf(2 * 0.05 / J, 1), rel=1e-9)
    z = np.random.default_rng(3).normal(size=(400_000, k))
    t = np.sum(np.clip(z, 0, None) ** 2, axis=1)  # k boundary components, each max(z, 0)^2
    assert np.mean(t > c) == pytest.approx(0.05 / J, rel=0.05)


def test_solve_outputs_of_one_output_is_solve():
    """With one output the common rule is solve's own: same model, estimate and covariance."""
    rng = np.random.default_rng(8)
    A, y, groups, _ = _balanced(rng, G=12, m=4, sb=0.6)
    fit, noise = idf.solve(A, y, groups=groups, noise_model="auto")
    [(fit1, noise1)] = idf.solve_outputs(A, y[:, None], groups=groups, noise_model="auto")
    assert noise1.model == noise.model and noise1.weights == pytest.approx(noise.weights)
    assert len([m for m, a in noise.aic.items() if a <= noise.aic[noise.model] + 2]) > 1
    np.testing.assert_allclose(fit1.x, fit.x, rtol=1e-12)
    np.testing.assert_allclose(fit1.covariance, fit.covariance, rtol=1e-9)
