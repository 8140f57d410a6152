import numpy as np
import pytest

from inertest.errors import InputError
from inertest.models.triad import ImuCalibration, TriadCalibration


def test_apply_inverts_the_output_model():
    rng = np.random.default_rng(0)
    M = np.array([[0, 1e-3, -2e-3], [5e-4, 0, 1e-3], [-1e-3, 2e-3, 0]])
    cal = TriadCalibration.from_model([100.0, 101.0, 99.0], M, [3.0, -2.0, 1.0], unit="m/s^2")
    u = rng.normal(size=(20, 3))
    raw = u @ (np.diag([100.0, 101.0, 99.0]) @ (np.eye(3) + M)).T + [3.0, -2.0, 1.0]
    np.testing.assert_allclose(cal.simulate(u), raw, rtol=1e-13)
    np.testing.assert_allclose(cal.apply(raw), u, atol=1e-13)


def test_gyro_g_sensitivity_and_json_round_trip():
    G = np.full((3, 3), 0.01)
    gyr = TriadCalibration.from_model([50.0] * 3, np.zeros((3, 3)), [1, 2, 3], unit="rad/s",
                                      g_sensitivity=G)
    acc = np.array([[0.0, 0.0, 9.81]])
    w = np.array([[0.1, -0.2, 0.3]])
    raw = gyr.simulate(w, acc)
    np.testing.assert_allclose(gyr.apply(raw, acc), w, atol=1e-14)
    with pytest.raises(InputError, match="calibrated acceleration"):
        gyr.apply(raw)
    imu = ImuCalibration(gyroscope=gyr)
    back = ImuCalibration.from_dict(imu.to_dict())
    np.testing.assert_array_equal(back.gyroscope.matrix, gyr.matrix)
    with pytest.raises(InputError, match='lacks "offset"'):
        TriadCalibration.from_dict({"matrix": np.eye(3).tolist(), "unit": "m/s^2"})
