"""The one triad model: forward/inverse, conventions by hand-written formulas, Jacobian."""

import numpy as np
import pytest

from inertest.errors import InputError
from inertest.models import triad
from inertest.models.imu import ImuCalibration
from inertest.models.triad import TriadCalibration
from inertest.units import DEG_PER_H_TO_RAD_PER_S, G0


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


# --- the one triad model: conventions written by hand (numpy, not the model's functions) -------


S = np.diag([1.0002, 0.9995, 1.0]) + np.array([[0, 2e-4, -1e-4], [5e-5, 0, 3e-4],
                                                [-2e-4, 1e-4, 0]])
B = np.array([1e-3, -2e-3, 5e-4])


def test_misalignment_index_order_sensor_first_reference_axis_second():
    """M_xy = sensitivity of sensor x to input along/about reference y: S[0, 1] / S[0, 0]."""
    S_hand = np.array([[2.0, 2.0 * 7e-6, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 4.0]])
    v = dict(zip(triad.parameter_names(), triad.engineering(
        np.r_[S_hand.ravel(), 0, 0, 0], "gyroscope", triad.scale_unit("rad/s", "gyroscope")),
        strict=True))
    assert v["M_xy"] == pytest.approx(7.0, rel=1e-12)  # urad
    assert v["M_yx"] == 0.0
    M = triad.misalignment_matrix([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    np.testing.assert_array_equal(M, [[0, 1, 2], [3, 0, 4], [5, 6, 0]])
    assert triad.MISALIGNMENT_NAMES == ("M_xy", "M_xz", "M_yx", "M_yz", "M_zx", "M_zy")


def test_values_follow_the_definitions():
    su = triad.scale_unit("m/s^2", "accelerometer")
    v = triad.engineering(triad.stack_parameters(S, S @ B), "accelerometer", su)
    d = dict(zip(triad.parameter_names(), v, strict=True))
    assert d["K_y"] == pytest.approx(0.9995, rel=1e-15)
    assert d["M_xy"] == pytest.approx(2e-4 / 1.0002 * 1e6, rel=1e-12)
    assert d["M_zx"] == pytest.approx(-2e-4 / 1.0 * 1e6, rel=1e-12)
    assert d["B_y"] == pytest.approx(-2e-3 / (1e-3 * G0), rel=1e-12)


def test_bias_adds_to_the_output_and_is_input_referred():
    """raw = S u + b: a positive raw bias b_x on an otherwise perfect gyro (K in count/(deg/s))
    is B_x = b_x / K_x, positive, in deg/h."""
    k = 16.4 * 180 / np.pi  # count/(rad/s)
    S_hand = np.diag([k, k, k])
    b = np.array([0.01, 0.0, 0.0])  # count
    su = triad.scale_unit("count", "gyroscope")
    v = dict(zip(triad.parameter_names(), triad.engineering(np.r_[S_hand.ravel(), b],
                                                            "gyroscope", su), strict=True))
    assert v["B_x"] == pytest.approx(0.01 / k / (np.pi / 180 / 3600), rel=1e-12)
    assert v["B_x"] > 0 and v["B_y"] == 0.0


@pytest.mark.parametrize("raw_unit, unit, k_per_rad_s", [
    ("count", "count/(deg/s)", 16.4 * 180 / np.pi),  # MEMS LSB per sample
    ("count/s", "count/deg", 7200.0 * 180 / np.pi),  # pulse output read as a pulse rate
    ("V", "V/(deg/s)", 0.02 * 180 / np.pi),
])
def test_gyro_scale_factor_is_raw_rate_reading_per_deg_s(raw_unit, unit, k_per_rad_s):
    su = triad.scale_unit(raw_unit, "gyroscope")
    assert su.unit == unit
    v = triad.engineering(np.r_[(np.eye(3) * k_per_rad_s).ravel(), 0, 0, 0], "gyroscope", su)
    assert v[0] == pytest.approx(k_per_rad_s * np.pi / 180, rel=1e-14)
    assert triad.scale_unit("count", "accelerometer").unit == "count/(m/s^2)"
    assert triad.scale_unit("g", "accelerometer").unit == "1"


def test_jacobian_propagation_against_finite_differences_and_sampling():
    su = triad.scale_unit("count/s", "gyroscope")
    G = np.arange(9).reshape(3, 3) * 1e-5
    p = triad.stack_parameters(S * 1000, S @ B * 1000, G)
    rng = np.random.default_rng(0)
    L = rng.normal(size=(21, 21)) * 1e-7 * np.abs(p).max()
    C = L @ L.T
    value, cov = triad.propagate(p, C, "gyroscope", su)
    samples = rng.multivariate_normal(p, C, size=20000)
    vals = np.array([triad.engineering(s, "gyroscope", su) for s in samples])
    np.testing.assert_allclose(vals.mean(axis=0), value, atol=0.05 * np.sqrt(np.diag(cov)).max())
    np.testing.assert_allclose(np.std(vals, axis=0), np.sqrt(np.diag(cov)), rtol=0.03)
    _, J = triad.engineering_jacobian(p, "gyroscope", su)
    h = 1e-6 * np.abs(p).max()
    k = 4  # S_xy: finite difference of one column
    dp = np.zeros(21)
    dp[k] = h
    fd = (triad.engineering(p + dp, "gyroscope", su)
          - triad.engineering(p - dp, "gyroscope", su)) / (2 * h)
    np.testing.assert_allclose(J[:, k], fd, rtol=1e-6, atol=1e-9 * np.abs(fd).max())
    assert len(triad.parameter_names(True)) == value.size == 21


def test_engineering_round_trip_and_calibration():
    su = triad.scale_unit("deg/s", "gyroscope")
    assert su.unit == "1" and su.nominal == 1.0
    truth = {"K_x": 1.0002, "M_xy": 150.0, "M_zx": -40.0, "B_x": 3.6, "G_yz": 2.0}
    p = triad.parameters_from_engineering(truth, "gyroscope", su)
    v = dict(zip(triad.parameter_names(True), triad.engineering(p, "gyroscope", su),
                 strict=True))
    for k, x in truth.items():
        assert v[k] == pytest.approx(x, rel=1e-12), k
    assert v["K_y"] == pytest.approx(1.0, rel=1e-15)
    assert p[9] == pytest.approx(1.0002 * 3.6 * DEG_PER_H_TO_RAD_PER_S, rel=1e-3)
    cal = triad.calibration_from_parameters(p, sensor="gyroscope", scale=su, raw_unit="deg/s")
    w = np.array([[0.1, -0.2, 0.3]])  # rad/s
    a = np.array([[0.0, 0.0, 9.8]])
    Sm = p[:9].reshape(3, 3)
    raw_deg_s = (w @ Sm.T + p[9:12] + a @ p[12:].reshape(3, 3).T) / su.raw_si_per_raw
    np.testing.assert_allclose(cal.apply(raw_deg_s, a), w, atol=1e-15)


def test_triad_errors_and_reversed_axes():
    e = triad.TriadErrors.from_engineering("gyroscope", scale_ppm=[10, 0, 0],
                                           misalignment_urad=[5, 0, 0, 0, 0, 0], bias=[1, 0, 0])
    np.testing.assert_allclose(e.matrix, [[10e-6, 5e-6, 0], [0, 0, 0], [0, 0, 0]], rtol=1e-15)
    assert e.bias[0] == pytest.approx(DEG_PER_H_TO_RAD_PER_S)
    with pytest.raises(InputError, match="zero diagonal"):
        triad.TriadErrors(misalignment=np.eye(3))
    p = triad.stack_parameters(np.diag([-2.0, 1.0, 1.0]), np.zeros(3))
    assert triad.reversed_axes(p) == (0,)
    assert "gyr_x" in triad.reversed_axes_message(p, "gyroscope", "gyr_{}")
    assert triad.reversed_axes_message(np.r_[np.eye(3).ravel(), 0, 0, 0], "g", "{}") is None
