"""The linear INS error model against an independent nonlinear strapdown navigator.

The reference (``strapdown_reference.py`` beside this file, written for the tests) integrates
the full nonlinear strapdown equations with sensor errors injected as *output* errors and
subtracts the error-free run. The linear model (``inertest.ins`` and the rotating-IMU study)
must reproduce it within 1.5 % of each state's range over 24 h static (the seed 002 scenario:
L = 39 deg, gyro drift 0.01 deg/h per axis, accelerometer bias 50-100 ug) and 3 h on a
single-axis mount turning at 6 deg/s. A gyro output error entering ``phi'`` with ``+`` (the
platform-drift sign) is off by ~100-200 %: that is checked too, so the test has the power to
see the sign.
"""

import math

import numpy as np
import pytest
from strapdown_reference import SensorErrors, navigate

from inertest.ins.error_model import InsSite
from inertest.ins.propagation import propagate
from inertest.studies import rotation_modulation as rm

DEG_H = math.pi / 180 / 3600
UG = 9.80665e-6
ARCSEC = math.pi / 180 / 3600
SITE = InsSite(math.radians(39.0))
TOL = 0.015  # of each state's range


def _reference(errors, *, hours, dt_s, rate_deg_s=0.0, heading_deg=0.0):
    return navigate(errors, latitude_rad=SITE.latitude_rad, radius_m=SITE.radius_m,
                    gravity_m_s2=SITE.gravity_m_s2, earth_rate_rad_s=SITE.earth_rate_rad_s,
                    duration_s=hours * 3600, dt_s=dt_s,
                    mount_rate_rad_s=math.radians(rate_deg_s),
                    heading_rad=math.radians(heading_deg), every=int(round(60 / dt_s)))


def _misfit(linear, reference):
    """max |linear - reference| over the run, per state, relative to the state's range."""
    rng = np.abs(reference).max(axis=0)
    return np.abs(linear - reference).max(axis=0) / rng


def _flipped(imu):
    """The same IMU with every gyro error negated: the old ``+`` sign of ``phi'``."""
    return rm.ImuErrors(gyro_drift=-imu.gyro_drift, accel_bias=imu.accel_bias,
                        gyro_scale_factor=-imu.gyro_scale_factor,
                        gyro_misalignment=-imu.gyro_misalignment)


@pytest.mark.slow
def test_seed002_static_24h_linear_model_matches_nonlinear_strapdown():
    drift = np.full(3, 0.01 * DEG_H)
    bias = np.array([50.0, 100.0, 50.0]) * UG
    heading = 30.0  # body x 30 deg from east, so body and ENU components differ
    cases = [SensorErrors(gyro_drift=drift, accel_bias=bias), SensorErrors(gyro_drift=drift)]
    t, ref = _reference(cases, hours=24, dt_s=5.0, heading_deg=heading)
    scheme = rm.make_scheme("none", t[-1], heading_rad=math.radians(heading))
    for imu, x_ref in ((rm.ImuErrors(gyro_drift=drift, accel_bias=bias), ref[0]),
                       (rm.ImuErrors(gyro_drift=drift), ref[1])):
        lin = rm.propagate_rotating(SITE, scheme, imu, t)
        assert np.all(_misfit(lin, x_ref) < TOL), _misfit(lin, x_ref)
        assert np.all(_misfit(rm.propagate_rotating(SITE, scheme, _flipped(imu), t),
                              x_ref)[[0, 1, 4, 5, 6]] > 0.5)
    # the static-base propagation of ``ins-errors``: the same errors resolved in ENU
    c = scheme.attitude([0.0])[0]
    u = np.r_[(c @ bias)[:2], c @ drift]
    lin = propagate(SITE, t, u=u)
    assert np.all(_misfit(lin, ref[0]) < TOL), _misfit(lin, ref[0])
    # the tool's old answer (dVE -0.49, dVN +0.72 m/s at 24 h for body = ENU, 50 ug) was the
    # wrong sign of the gyro part: the reference's velocity errors are far from it
    assert np.all(np.abs(propagate(SITE, t, u=u * [1, 1, -1, -1, -1])[-1, :2] - ref[0][-1, :2])
                  > 0.3)


@pytest.mark.slow
def test_single_axis_6deg_s_3h_linear_model_matches_nonlinear_strapdown():
    drift = np.array([0.01, -0.02, 0.01]) * DEG_H
    bias = np.array([50.0, -80.0, 50.0]) * UG
    scale = np.array([3.0, -2.0, 0.5]) * 1e-6
    mis = np.zeros((3, 3))
    mis[[0, 0, 1, 1, 2, 2], [1, 2, 0, 2, 0, 1]] = np.array([2.0, -3, 1, 4, -2, 1.5]) * ARCSEC
    imus = [rm.ImuErrors(gyro_drift=drift, accel_bias=bias),
            rm.ImuErrors(gyro_drift=drift),
            rm.ImuErrors(gyro_scale_factor=scale, gyro_misalignment=mis)]
    cases = [SensorErrors(gyro_drift=drift, accel_bias=bias), SensorErrors(gyro_drift=drift),
             SensorErrors(gyro_matrix=np.diag(scale) + mis)]
    t, ref = _reference(cases, hours=3, dt_s=1.0, rate_deg_s=6.0)
    scheme = rm.make_scheme("single-axis", t[-1], rate_rad_s=math.radians(6.0))
    for imu, x_ref in zip(imus, ref, strict=True):
        lin = rm.propagate_rotating(SITE, scheme, imu, t)
        assert np.all(_misfit(lin, x_ref) < TOL), _misfit(lin, x_ref)
        # with the platform-drift sign the rotating histories are far off (sign reversed)
        assert np.max(_misfit(rm.propagate_rotating(SITE, scheme, _flipped(imu), t), x_ref)) > 0.9


@pytest.mark.slow
def test_the_linear_models_stated_validity_against_the_nonlinear_navigator():
    """Issue 28: a 20 ppm z scale factor under single-axis rotation at 6 deg/s turns the heading
    1.6 deg in 24 h and the linear histories are then up to 13 % off the nonlinear navigator's.
    The result says so (a warning, and the expected misfit at least the one found); at 2 ppm
    (0.16 deg) the histories agree to 2 % and nothing is said."""
    scale = [np.array([0.0, 0.0, ppm * 1e-6]) for ppm in (20.0, 2.0)]
    t, ref = _reference([SensorErrors(gyro_matrix=np.diag(s)) for s in scale], hours=24,
                        dt_s=2.0, rate_deg_s=6.0)
    scheme = rm.make_scheme("single-axis", t[-1], rate_rad_s=math.radians(6.0))
    site = 39.0
    for s, x_ref, warned in zip(scale, ref, (True, False), strict=True):
        imu = rm.ImuErrors(gyro_scale_factor=s)
        run = rm.run_scheme(SITE, scheme, imu, t)
        misfit = float(np.max(_misfit(run.x, x_ref)))
        study = rm.SystemStudy(site, imu, (run,))
        assert bool(study.messages) is warned and run.linear_model.valid is not warned
        if warned:
            assert misfit > 0.05 and "linear error model" in study.to_dict()["messages"][0]
            assert misfit <= run.linear_model.expected_misfit < 2 * misfit
        else:  # the navigators' common 1-2 % (TOL above) is not the second-order terms
            assert misfit < 0.02
