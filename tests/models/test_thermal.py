"""Exported thermal models: polynomial in (T - T_ref) with covariance, the BP network as arrays.

References: the network's own scikit-learn forward pass (the arrays must reproduce it), JSON
round trips, closed-form polynomials, and a Monte Carlo of the correction's uncertainty with an
independent simulation written here.
"""

import json

import numpy as np
import pytest

from inertest.errors import InputError
from inertest.models.thermal import (
    PolynomialThermalModel,
    model_from_dict,
    poly_exponents,
)
from inertest.procedures import thermal_compensation as th


def cycles(n, *, noise_ppm, rng, sample_s=120.0):
    """``n`` sinusoidal cycles -40..60 degC (200 min each) of a scale factor cubic in T."""
    gen = np.random.default_rng(rng)
    t = np.arange(int(n * 12000.0 / sample_s)) * sample_s
    temp = 10.0 - 50.0 * np.cos(2 * np.pi * t / 12000.0)
    ppm = truth_ppm(temp) + gen.normal(0.0, noise_ppm, t.size)
    return {"cycle": (t // 12000.0).astype(int) + 1, "time_s": t, "temperature_c": temp,
            "scale_factor": 2.5 * (1 + 1e-6 * ppm)}


def truth_ppm(temp):
    d = temp - 20.0
    return 10.0 * d + 0.05 * d**2 - 0.002 * d**3


def test_network_arrays_reproduce_sklearn_and_round_trip_json():
    """The numpy forward pass of the exported arrays equals scikit-learn's predict, and the
    model rebuilt from its JSON text gives the same outputs, both to 1e-12 (relative)."""
    data = th.simulate_thermal(cycles=3, rng=4)
    r = th.fit_thermal(data, serial="FOG-1")
    net = r.model("neural-network")
    X = np.column_stack([r.temperature_c, r.rate_c_per_min])
    sk = r.network.estimator.predict(X)
    mine = net.predict(r.temperature_c, r.rate_c_per_min)
    scale = np.max(np.abs(sk))
    assert np.max(np.abs(mine - sk)) <= 1e-12 * scale
    back = model_from_dict(json.loads(json.dumps(net.to_dict())))
    np.testing.assert_allclose(back.predict(r.temperature_c, r.rate_c_per_min), mine,
                               rtol=0, atol=1e-12 * scale)
    doc = net.to_dict()
    assert doc["activation"] == "tanh" and doc["serial"] == "FOG-1"
    assert np.shape(doc["weights"][0]) == (2, 10) and np.shape(doc["weights"][1]) == (10, 1)
    assert doc["valid_range"]["temperature_rate_c_per_min"][1] > 0.5
    # and the envelope of the fit carries both models
    models = r.to_dict()["result"]["models"]
    assert set(models) == {"polynomial", "neural-network"}


def test_polynomial_recovers_closed_form_coefficients_in_t_minus_t_ref():
    """Noise-free cubic: the coefficients of (T - 20)^k are the law's 0, 10, 0.05, -0.002
    ppm/degC^k (relative to the training mean, so c0 absorbs the mean and c1.. scale by
    1/(1 + mean 1e-6))."""
    r = th.fit_thermal(cycles(4, noise_ppm=0.0, rng=0), use_rate=False, t_ref_c=20.0)
    m = r.model("polynomial")
    assert isinstance(m, PolynomialThermalModel) and m.exponents == ((0, 0), (1, 0), (2, 0),
                                                                     (3, 0))
    f = 2.5 / r.reference
    np.testing.assert_allclose(m.coefficients[1:] / f, [10.0, 0.05, -0.002], rtol=1e-9)
    assert m.t_ref_c == 20.0
    assert m.equation() == ("scale factor deviation [ppm] = c0 + c1 (T - T_ref) + c2 (T - "
                            "T_ref)^2 + c3 (T - T_ref)^3; T [degC], T_ref = 20 degC")
    assert m.term_units() == ["ppm", "ppm/degC", "ppm/degC^2", "ppm/degC^3"]
    # compensation: the scale factor divided by scale(T) is 1 (closed form)
    d = cycles(1, noise_ppm=0.0, rng=0)
    out, std = m.compensate(d["scale_factor"], d["temperature_c"])
    np.testing.assert_allclose(out, 1.0, atol=1e-12)
    assert std is not None and np.all(std < 1e-9)


def test_exponents_and_rate_requirement():
    assert poly_exponents(2, True) == ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    r = th.fit_thermal(th.simulate_thermal(cycles=3, rng=1), max_degree=2)
    m = r.model("polynomial")
    with pytest.raises(InputError, match="uses the temperature rate"):
        m.predict([20.0])
    with pytest.raises(InputError, match="unknown"):
        r.model("spline")
    doc = m.to_dict()
    doc["model_type"] = "pickle"
    with pytest.raises(InputError, match="model_type 'pickle' unknown"):
        model_from_dict(doc)


@pytest.mark.slow
def test_polynomial_correction_uncertainty_matches_monte_carlo():
    """Stated std of the correction, sqrt(phi^T C phi), against the scatter of the fitted
    correction over 200 independent noise draws at -35, 10 and 55 degC: ratio within
    0.8-1.25."""
    temps = np.array([-35.0, 10.0, 55.0])
    errs, stds = [], []
    for k in range(200):
        r = th.fit_thermal(cycles(3, noise_ppm=5.0, rng=1000 + k), use_rate=False,
                           max_degree=3, validation_cycles=1, hidden=2, max_iter=5)
        m = r.model("polynomial")
        assert m.exponents[-1] == (3, 0)
        # truth in the model's reference: ppm relative to the training mean
        truth = ((1 + 1e-6 * truth_ppm(temps)) * 2.5 / r.reference - 1) * 1e6
        errs.append(m.predict(temps) - truth)
        stds.append(m.predict_std(temps))
    ratio = np.sqrt(np.mean(np.square(stds), axis=0)) / np.std(errs, axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def test_review19_rate_polynomial_is_identifiable_and_training_subsets_agree():
    """Review 19, th_rank.py: thermal simulate's rate takes only 0, +-0.5, +-1 degC/min (zero
    only in the dwells at -40 and 60 degC), so a full degree-5 polynomial in (T, dT/dt) had
    rank 16 of 21 and a singular covariance. Only the identifiable terms are fitted now: the
    covariance is non-singular, two independent training sets agree within 3 stated sigma at
    points inside the observed (T, rate) support, and 10 degC at rate 0 is outside it."""
    fits = [th.fit_thermal(th.simulate_thermal(cycles=3, rng=seed), quantity="bias",
                           max_degree=5, hidden=2, max_iter=5) for seed in (11, 12)]
    models = [f.model("polynomial") for f in fits]
    for f, m in zip(fits, models, strict=True):
        assert len(m.exponents) < len(poly_exponents(5, True))
        assert any("do not determine" in msg for msg in f.messages)
        d = np.sqrt(np.diag(m.covariance))
        assert np.linalg.eigvalsh(m.covariance / np.outer(d, d))[0] > 1e-8
        doc = model_from_dict(json.loads(json.dumps(m.to_dict())))
        np.testing.assert_array_equal(doc.support, m.support)
    temps = np.array([-40.0, 60.0, 10.0, 30.0, -20.0])
    rates = np.array([0.0, 0.0, 1.0, -1.0, 1.0])
    assert not np.any(models[0].outside_support(temps, rates))
    assert np.all(models[0].outside_support([10.0, 30.0], [0.0, 0.0]))
    p = [m.predict(temps, rates) for m in models]
    s = [m.predict_std(temps, rates) for m in models]
    assert np.all(np.abs(p[0] - p[1]) <= 3.0 * np.hypot(s[0], s[1])), (p, s)


def test_review19_range_check_has_a_relative_tolerance():
    """A rate 2.66e-15 degC/min beyond the training range is rounding, not extrapolation."""
    m = th.fit_thermal(th.simulate_thermal(cycles=3, rng=1), max_degree=2).model("polynomial")
    lo, hi = m.rate_range_c_per_min
    dt, dr = m.out_of_range([10.0, 10.0], [hi + 2.66e-15, hi + 1e-3])
    assert dt.tolist() == [0.0, 0.0] and dr[0] == 0.0 and dr[1] == pytest.approx(1e-3)


def test_review19_rate_is_not_differenced_across_a_time_gap():
    """A 1220 s gap in a 20 s record: one-sided differences on each side of it."""
    t = np.r_[np.arange(0, 200, 20.0), np.arange(1400, 1600, 20.0)]
    temp = np.where(t < 1000, 0.01 * t, 50.0)  # ramp at 0.6 degC/min, then constant
    r = th.temperature_rate(np.ones(t.size, dtype=int), t, temp)
    np.testing.assert_allclose(r[t < 1000], 0.6, atol=1e-12)
    np.testing.assert_allclose(r[t > 1000], 0.0, atol=1e-12)
