"""Exported thermal models: polynomial in (T - T_ref) with covariance, the BP network as arrays.

References: the network's own scikit-learn forward pass (the arrays must reproduce it), JSON
round trips, closed-form polynomials, and a Monte Carlo of the correction's uncertainty with an
independent simulation written here.
"""

import json

import numpy as np
import pytest

from inertest.errors import InputError
from inertest.procedures import thermal_compensation as th
from inertest.procedures.thermal_model import (
    PolynomialThermalModel,
    model_from_dict,
    poly_exponents,
)


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
