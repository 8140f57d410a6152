import numpy as np
import pytest

from inertest.errors import InputError
from inertest.models import sdf_gyro
from inertest.units import DEG_PER_H_TO_RAD_PER_S


def test_regressors_match_the_written_model():
    rng = np.random.default_rng(0)
    f = rng.normal(size=(50, 3))
    c = rng.normal(size=10)
    fi, fo, fs = f.T
    DF, DI, DO, DS, DIO, DOS, DSI, DII, DOO, DSS = c
    expected = (DF + DI * fi + DO * fo + DS * fs + DIO * fi * fo + DOS * fo * fs + DSI * fs * fi
                + DII * fi**2 + DOO * fo**2 + DSS * fs**2)
    np.testing.assert_allclose(sdf_gyro.drift(f, c), expected, rtol=1e-14)


def test_coefficients_from_deg_h_converts_and_rejects_typos():
    c = sdf_gyro.coefficients_from_deg_h({"DF": 2.0, "DSS": -1.0})
    assert c[0] == pytest.approx(2.0 * DEG_PER_H_TO_RAD_PER_S)
    assert c[9] == pytest.approx(-DEG_PER_H_TO_RAD_PER_S)
    assert np.count_nonzero(c) == 2
    with pytest.raises(InputError, match="unknown drift coefficient"):
        sdf_gyro.coefficients_from_deg_h({"DFF": 1.0})


def test_engineering_units():
    assert sdf_gyro.ENGINEERING_UNIT["DF"] == "deg/h"
    assert sdf_gyro.ENGINEERING_UNIT["DO"] == "deg/h/g"
    assert sdf_gyro.ENGINEERING_UNIT["DSI"] == "deg/h/g^2"


def test_regressor_matrix_and_its_weighted_sum_from_moments_match_the_written_model():
    rng = np.random.default_rng(1)
    f = rng.normal(size=(40, 3))
    w = rng.uniform(0.0, 1.0, 40)
    fi, fo, fs = f.T
    written = np.column_stack([np.ones(40), fi, fo, fs, fi * fo, fo * fs, fs * fi, fi**2,
                               fo**2, fs**2])
    np.testing.assert_array_equal(sdf_gyro.drift_regressors(f), written)
    got = sdf_gyro.regressors_from_moments(w.sum(), w @ f, (f * w[:, None]).T @ f)
    np.testing.assert_allclose(got, w @ written, rtol=1e-14)
    with pytest.raises(InputError, match=r"shapes \(3,\) and \(3, 3\)"):
        sdf_gyro.regressors_from_moments(1.0, np.zeros(2), np.zeros((3, 3)))
    with pytest.raises(InputError, match=r"shape \(n, 3\)"):
        sdf_gyro.drift(np.zeros((4, 2)), np.zeros(10))
    with pytest.raises(InputError, match="expected 10 coefficients"):
        sdf_gyro.drift(np.zeros((4, 3)), np.zeros(9))
