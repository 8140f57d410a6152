"""Pendulous accelerometer model (IEEE Std 1293-2018 eq. (1), seed 000 ch. 3)."""

import numpy as np
import pytest

from inertest.errors import InputError
from inertest.models import pendulous_accelerometer as model

TRUTH = {"K1": 2.5, "K0": 150.0, "K2": 12.0, "K3": -3.5, "KIP": 20.0, "KIO": -15.0,
         "KPO": 5.0, "KPP": 8.0, "KOO": -6.0, "dO": 45.0, "dP": -30.0}


def test_ieee1293_model_written_out_term_by_term():
    rng = np.random.default_rng(0)
    a = rng.uniform(-1, 1, size=(20, 3))
    u = 1e-6
    c = {k: v * u for k, v in TRUTH.items() if k != "K1"}
    i, p, o = a.T
    expected = TRUTH["K1"] * (
        c["K0"] + i + c["K2"] * i**2 + c["K3"] * i**3 + c["KIP"] * i * p + c["KIO"] * i * o
        + c["KPO"] * p * o + c["KPP"] * p**2 + c["KOO"] * o**2 + c["dO"] * p - c["dP"] * o)
    np.testing.assert_allclose(model.output(a, TRUTH), expected, rtol=1e-14, atol=1e-15)


def test_regressor_columns_follow_coefficient_order():
    A = model.regressors([[0.5, 0.25, 0.125]])
    assert A.shape == (1, len(model.COEFFICIENTS))
    np.testing.assert_allclose(A[0, model.COEFFICIENTS.index("K3")], 0.125)
    np.testing.assert_allclose(A[0, model.COEFFICIENTS.index("KPO")], 0.25 * 0.125)
    np.testing.assert_allclose(A[0, model.COEFFICIENTS.index("dP")], -0.125)


def test_needs_k1_and_known_names():
    with pytest.raises(InputError, match="K1"):
        model.theta_from_coefficients({"K0": 1.0})
    with pytest.raises(InputError, match="unknown accelerometer coefficient.*KXX"):
        model.theta_from_coefficients({"K1": 1.0, "KXX": 1.0})
    with pytest.raises(InputError, match=r"shape \(n, 3\)"):
        model.regressors([1.0, 0.0])
