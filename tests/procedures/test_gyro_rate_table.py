"""Gyro rate-table test: IEEE Std 952 definitions, closed forms, identifiability, Monte Carlo."""

import numpy as np
import pytest

import inertest
from inertest.earth import OMEGA_IE, Site
from inertest.errors import DataError, IdentifiabilityError, InertestWarning, PlanError
from inertest.plan import Instrument, Plan
from inertest.procedures import gyro_rate_table as grt

LAT_DEG = 34.246
W_UP = OMEGA_IE * np.sin(np.radians(LAT_DEG))  # Earth rate on a vertical table axis [rad/s]
DEG_H = np.pi / 180 / 3600


def make_plan(rates, *, spr=1, fit_k2=False, unit="count", axis="U", kind="rate-gyro"):
    spec = grt.GyroRateTableSpec.from_mapping({"rates_deg_s": list(rates), "samples_per_rate": spr,
                                  "fit_k2": fit_k2, "table_axis": axis})
    return Plan(Site.at(LAT_DEG), Instrument(kind=kind, output_unit=unit), spec)


def test_closed_form_pair_of_opposite_rates():
    """K = (E+ - E-)/(2w) and B = (E+ + E-)/(2K) - Earth rate, from the readings themselves."""
    plan = make_plan([-50.0, 50.0])
    data = inertest.simulate(plan, {"K": 7200.0, "B": 0.4})
    e_neg, e_pos = data["output"]
    w = np.radians(50.0)
    K = (e_pos - e_neg) / (2 * w)  # count/s per rad/s
    B = (e_pos + e_neg) / (2 * K) - W_UP
    res = inertest.fit(plan, data, sigma=0.1)
    assert res.coefficients["K"].value == pytest.approx(K * np.pi / 180, rel=1e-13)
    assert res.coefficients["B"].value == pytest.approx(B / DEG_H, abs=1e-9)
    assert res.coefficients["B"].value == pytest.approx(0.4, abs=1e-9)
    assert "asymmetry" not in res.coefficients
    assert any("second rate of each sign or a zero-rate reading" in s
               for s in res.identification.not_separable)
    assert any("nonlinearity" in s for s in res.identification.not_separable)
    assert res.pairs[0]["K"] == pytest.approx(7200.0, rel=1e-13)


def test_exact_recovery_with_asymmetry_and_k2():
    plan = make_plan([-200, -100, -20, -1, 0, 1, 20, 100, 200], fit_k2=True)
    truth = {"K": 7200.0, "B": -0.7, "asymmetry": 35.0, "K2": 0.12}
    res = inertest.fit(plan, inertest.simulate(plan, truth), sigma=0.01)
    for name, value in truth.items():
        assert res.coefficients[name].value == pytest.approx(value, rel=1e-9, abs=1e-9)
    # IEEE 952 asymmetry: (K+ - K-)/mean, with K+- = K (1 +- a/2).
    assert res.coefficients["K_pos"].value == pytest.approx(7200.0 * (1 + 17.5e-6), rel=1e-12)
    assert res.coefficients["K_neg"].value == pytest.approx(7200.0 * (1 - 17.5e-6), rel=1e-12)
    derived = grt.GyroRateTable().truth_quantities(truth)
    for name in ("K_pos", "K_neg"):
        assert derived[name] == pytest.approx(res.coefficients[name].value, rel=1e-12)


def test_nonlinearity_closed_form_for_a_quadratic_error():
    """Symmetric rates, error K K2 w^2: the straight line keeps K and moves the offset to the
    mean of w^2, so each rate deviates by K K2 (w^2 - mean w^2)."""
    rates = np.array([-100.0, -30.0, -5.0, 5.0, 30.0, 100.0])
    plan = make_plan(rates)
    k2 = 0.5e-6 / np.radians(1.0)  # 0.5 ppm per deg/s, in 1/(rad/s)
    # The model without K2 does not fit these readings, and the checks say so.
    with pytest.warns(InertestWarning, match="does not fit the data"):
        res = inertest.fit(plan, inertest.simulate(plan, {"K": 7200.0, "K2": 0.5}), sigma=0.01)
    assert res.identification.checks.verdict == "model does not fit"
    w = np.radians(rates)
    dev = 7200.0 / np.radians(1.0) * k2 * (w**2 - np.mean(w**2))
    fs = 7200.0 / np.radians(1.0) * np.radians(100.0)
    assert res.nonlinearity_ppm == pytest.approx(np.max(np.abs(dev)) / fs * 1e6, rel=1e-9)
    assert res.coefficients["K"].value == pytest.approx(7200.0, rel=1e-13)


def test_rate_output_gives_a_dimensionless_scale_factor():
    plan = make_plan([-10, -1, 1, 10], unit="deg/s", axis="N")
    res = inertest.fit(plan, inertest.simulate(plan, {"K": 1.0002, "B": 2.0}), sigma=1e-6)
    assert res.coefficients["K"].unit == "1"
    assert res.coefficients["K"].value == pytest.approx(1.0002, rel=1e-13)
    assert res.coefficients["B"].value == pytest.approx(2.0, abs=1e-8)
    assert res.earth_rate_deg_h == pytest.approx(OMEGA_IE * np.cos(np.radians(LAT_DEG)) / DEG_H)


@pytest.mark.parametrize("rates, msg", [
    ([1, 10, 100], "asymmetry needs both directions: add negative rates"),
    ([-1, -10], "asymmetry needs both directions: add positive rates"),
    ([0, 0], "scale factor cannot be found"),
])
def test_rates_that_cannot_give_the_scale_factor_or_asymmetry(rates, msg):
    plan = make_plan(rates)
    data = {"rate_deg_s": np.array(rates, float), "output": np.ones(len(rates))}
    with pytest.raises(IdentifiabilityError, match=msg):
        inertest.fit(plan, data, sigma=1.0)


def test_k2_needs_three_rates():
    plan = make_plan([-10, 10], fit_k2=True)
    with pytest.raises(IdentifiabilityError, match="K2 needs at least three distinct table rates"):
        inertest.fit(plan, inertest.simulate(plan, {"K": 7200.0}), sigma=1.0)


def test_bad_plans_and_data():
    with pytest.raises(PlanError, match='unknown key.*rates .*did you mean "rates_deg_s"'):
        grt.GyroRateTableSpec.from_mapping({"rates": [1, 2]})
    with pytest.raises(PlanError, match="tests a gyro"):
        inertest.fit(make_plan([-1, 1], kind="accelerometer", unit="g"), {})
    with pytest.raises(DataError, match="lacks column"):
        inertest.fit(make_plan([-1, 1]), {"rate_deg_s": np.array([1.0, -1.0])})
    with pytest.raises(PlanError, match="needs the scale factor K in count/deg"):
        inertest.simulate(make_plan([-1, 1]), {"B": 1.0})
    with pytest.raises(IdentifiabilityError, match="no degree of freedom"):
        plan = make_plan([-1, 1])
        inertest.fit(plan, inertest.simulate(plan, {"K": 10.0}))


@pytest.mark.parametrize(("params", "msg"), [
    ({"fit_k2": 1}, "fit_k2 must be true or false"),
    ({"samples_per_rate": True}, "samples_per_rate must be a whole number"),
    ({"rates_deg_s": [1.0, True]}, r"rates_deg_s must be a number \[deg/s\], got True"),
    ({"rates_deg_s": []}, "rates_deg_s must be a non-empty list"),
    ({"samples_per_rate": 0}, "samples_per_rate must be positive"),
    ({"noise_model": "whte"}, 'noise_model = "whte" is not one of .*did you mean "white"'),
    ({"fit_K2": True}, 'unknown key.*fit_K2 .*did you mean "fit_k2"'),
])
def test_plan_fields_refuse_wrong_types_and_misspelt_keys(params, msg):
    """A boolean where a number belongs, a number where a boolean belongs, a misspelt key."""
    with pytest.raises(PlanError, match=msg):
        grt.GyroRateTableSpec.from_mapping(params)


@pytest.mark.slow
def test_monte_carlo_stated_uncertainties():
    plan = make_plan([-200, -50, -5, 0, 5, 50, 200], spr=4, fit_k2=True)
    truth = {"K": 7200.0, "B": 0.3, "asymmetry": 20.0, "K2": 0.05}
    rng = np.random.default_rng(11)
    names = ["K", "B", "K2", "asymmetry"]
    est, std = {n: [] for n in names}, {n: [] for n in names}
    for _ in range(400):
        res = inertest.fit(plan, inertest.simulate(plan, truth, noise=2.0, rng=rng))
        for n in names:
            est[n].append(res.coefficients[n].value)
            std[n].append(res.coefficients[n].std)
    for n in names:
        scatter = np.std(est[n], ddof=1)
        assert np.mean(std[n]) / scatter == pytest.approx(1.0, abs=0.2), n
        assert abs(np.mean(est[n]) - truth[n]) < 4 * scatter / np.sqrt(400), n
