"""Shared triad result: engineering estimates and propagated uncertainty."""

import numpy as np
import pytest

from inertest.procedures import triad_common as tc
from inertest.units import ARCSEC_TO_RAD, DEG_PER_H_TO_RAD_PER_S, G0

S = np.diag([1.0002, 0.9995, 1.0]) + np.array([[0, 2e-4, -1e-4], [5e-5, 0, 3e-4],
                                                [-2e-4, 1e-4, 0]])
B = np.array([1e-3, -2e-3, 5e-4])


def test_values_follow_the_definitions():
    su = tc.scale_unit("m/s^2", "accelerometer")
    v = tc.engineering(tc.stack_parameters(S, S @ B), "accelerometer", su)
    names = tc.parameter_names()
    d = dict(zip(names, v, strict=True))
    assert d["K_y"] == pytest.approx(0.9995, rel=1e-15)
    assert d["M_xy"] == pytest.approx(2e-4 / 1.0002 * 1e6, rel=1e-12)
    assert d["M_zx"] == pytest.approx(-2e-4 / 1.0 * 1e6, rel=1e-12)
    assert d["B_y"] == pytest.approx(-2e-3 / (1e-3 * G0), rel=1e-12)


def test_jacobian_propagation_against_finite_differences_and_sampling():
    su = tc.scale_unit("count", "gyroscope")
    G = np.arange(9).reshape(3, 3) * 1e-5
    p = tc.stack_parameters(S * 1000, S @ B * 1000, G)
    rng = np.random.default_rng(0)
    L = rng.normal(size=(21, 21)) * 1e-7 * np.abs(p).max()
    C = L @ L.T
    value, cov = tc.propagate(p, C, "gyroscope", su)
    samples = rng.multivariate_normal(p, C, size=20000)
    vals = np.array([tc.engineering(s, "gyroscope", su) for s in samples])
    np.testing.assert_allclose(vals.mean(axis=0), value, atol=0.05 * np.sqrt(np.diag(cov)).max())
    np.testing.assert_allclose(np.std(vals, axis=0), np.sqrt(np.diag(cov)), rtol=0.03)
    assert len(tc.parameter_names(True)) == value.size == 21


def test_estimates_units_and_calibration_roundtrip():
    su = tc.scale_unit("deg/s", "gyroscope")
    assert su.unit == "1" and su.nominal == 1.0
    p = tc.stack_parameters(S, S @ B)
    est = tc.TriadEstimates.from_parameters(p, np.eye(12) * 1e-14, sensor="gyroscope", scale=su)
    assert est.bias["B_x"].unit == "deg/h"
    assert est.bias["B_x"].value == pytest.approx(1e-3 / DEG_PER_H_TO_RAD_PER_S, rel=1e-3)
    d = est.to_dict()
    assert d["misalignment_arcsec"]["M_xy"]["value"] == pytest.approx(
        est.misalignment["M_xy"].value * 1e-6 / ARCSEC_TO_RAD)
    assert d["scale_factor_ppm"]["K_x"]["value"] == pytest.approx(200.0, abs=1e-6)
    cal = tc.calibration_from_parameters(p, sensor="gyroscope", scale=su, raw_unit="deg/s")
    w = np.array([[0.1, -0.2, 0.3]])  # rad/s
    raw_deg_s = (w @ S.T + S @ B) / su.raw_si_per_raw
    np.testing.assert_allclose(cal.apply(raw_deg_s), w, atol=1e-15)
