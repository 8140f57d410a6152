"""Temperature compensation (seed 003): polynomial with cross-validated degree, BP network,
cycle-wise split, hysteresis, bad input."""

import warnings

import numpy as np
import pytest

from inertest.errors import DataError, IdentifiabilityError
from inertest.procedures import thermal_compensation as th


def cubic_data(cycles=4, noise=0.0, rng=0):
    """Scale factor exactly cubic in temperature (no lag): SF = 1 + (c1 d + c2 d^2 + c3 d^3)."""
    d = th.simulate_thermal(cycles=cycles, noise_ppm=0.0, noise_deg_h=0.0, rng=rng)
    dt = d["temperature_c"] - 20.0
    ppm = 10.0 * dt + 0.05 * dt**2 - 0.002 * dt**3
    ppm = ppm + np.random.default_rng(rng).normal(0.0, noise, ppm.size)
    return dict(d, scale_factor=1.0 + 1e-6 * ppm), ppm


def test_exact_polynomial_is_recovered_with_its_degree():
    """Noise-free cubic data: cross-validation picks degree 3 (the lowest that fits) and the
    residual vanishes to rounding on the held-out cycle (ppm of the training mean)."""
    data, ppm = cubic_data()
    r = th.fit_thermal(data, use_rate=False)
    assert r.polynomial.description.startswith("degree 3")
    assert r.polynomial.validation_rms < 1e-6
    # the values are relative to the training mean of the scale factor (closed form)
    train = r.train
    ref = np.mean(data["scale_factor"][np.argsort(data["time_s"])][train])
    assert r.reference == pytest.approx(ref, rel=1e-15)
    np.testing.assert_allclose(r.value, (data["scale_factor"] / ref - 1) * 1e6, atol=1e-7)


def test_cross_validation_prefers_low_degree_for_a_line_in_noise():
    data = th.simulate_thermal(cycles=4, noise_ppm=0.0, rng=1)
    dt = data["temperature_c"]
    ppm = 8.0 * dt + np.random.default_rng(1).normal(0, 5.0, dt.size)
    r = th.fit_thermal(dict(data, scale_factor=1 + 1e-6 * ppm), use_rate=False)
    assert r.polynomial.description.startswith("degree 1")
    assert r.polynomial.validation_rms == pytest.approx(5.0, rel=0.15)


def test_hysteresis_needs_the_temperature_rate():
    """Coil lagging the sensor by 10 min at 1 degC/min: temperature alone leaves the
    heating/cooling split (~100 ppm); with the rate both models get within ~5x the 3 ppm noise
    and reduce the validation residual more than 20-fold."""
    data = th.simulate_thermal(rng=2)
    only_t = th.fit_thermal(data, use_rate=False)
    both = th.fit_thermal(data)
    assert only_t.polynomial.validation_rms > 50.0
    for fit in (both.polynomial, both.network):
        assert fit.validation_rms < 20.0
        assert fit.validation_rms < both.before_validation_rms / 20
        assert fit.converged
    assert both.network.validation_rms < 1.5 * both.polynomial.validation_rms


def test_bias_with_shupe_term():
    data = th.simulate_thermal(rng=3)
    r = th.fit_thermal(data, quantity="bias")
    assert r.unit == "deg/h" and r.reference == 0.0
    assert r.before_validation_rms > 0.2
    assert r.polynomial.validation_rms < 0.08 and r.network.validation_rms < 0.08


def test_network_is_reproducible_and_non_convergence_is_reported_not_warned():
    data = th.simulate_thermal(cycles=3, rng=4)
    a = th.fit_thermal(data)
    b = th.fit_thermal(data)
    assert a.network.validation_rms == b.network.validation_rms
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        short = th.fit_thermal(data, max_iter=2)
    assert not short.network.converged
    assert any("did not converge" in m for m in short.messages)
    assert short.to_dict()["result"]["neural_network"]["converged"] is False


def test_split_is_by_cycle():
    data = th.simulate_thermal(cycles=5, rng=5)
    r = th.fit_thermal(data, validation_cycles=2)
    d = r.to_dict()["result"]
    assert d["train_cycles"] == [1, 2, 3] and d["validation_cycles"] == [4, 5]


def test_bad_input_names_the_problem_and_the_fix():
    data = th.simulate_thermal(cycles=2, rng=6)
    with pytest.raises(IdentifiabilityError, match="record at least 3 cycles"):
        th.fit_thermal(data)
    data = th.simulate_thermal(cycles=3, rng=6)
    with pytest.raises(DataError, match="lacks column.*bias_deg_h"):
        th.fit_thermal({k: v for k, v in data.items() if k != "bias_deg_h"}, quantity="bias")
    flat = dict(data, temperature_c=np.full(data["time_s"].size, 25.0)
                + 0.001 * np.arange(data["time_s"].size) % 1)
    with pytest.raises(IdentifiabilityError, match="spans only"):
        th.fit_thermal(flat)


@pytest.mark.slow
def test_validation_rms_predicts_the_error_on_new_cycles():
    """The stated uncertainty of the compensation (validation RMS on one held-out cycle) agrees
    within 20 % with the RMS error on 6 fresh cycles of the same gyro with new noise."""
    model = th.fit_thermal(th.simulate_thermal(rng=10))
    new = th.simulate_thermal(cycles=6, rng=11)
    cyc = new["cycle"]
    rate = th.temperature_rate(cyc, new["time_s"], new["temperature_c"])
    y = (new["scale_factor"] / model.reference - 1) * 1e6
    for fit in (model.polynomial, model.network):
        err = y - fit.predict(new["temperature_c"], rate)
        rms = np.sqrt(np.mean(err**2))
        assert 0.8 < fit.validation_rms / rms < 1.2, (fit.name, fit.validation_rms, rms)
