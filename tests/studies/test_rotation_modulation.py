"""System-level rotation modulation against closed forms, the static INS and solve_ivp."""

import math

import numpy as np
import pytest
from scipy.integrate import quad_vec, solve_ivp

from inertest.errors import InputError
from inertest.ins.error_model import InsSite, input_matrix, system_matrix
from inertest.ins.propagation import propagate
from inertest.studies import rotation_modulation as rm
from inertest.studies.stator_modulation import ramp_residual

DEG_H = math.radians(1) / 3600  # rad/s per deg/h
UG = 9.80665e-6  # m/s^2 per ug
W10 = math.radians(10)  # 10 deg/s
SITE = InsSite(math.radians(45))


def full_imu(ramp=True):
    """Every kind of error at once (drift, trend, bias, scale factors, misalignment)."""
    return rm.ImuErrors(
        gyro_drift=np.array([0.01, -0.02, 0.015]) * DEG_H,
        gyro_drift_rate=np.array([0.004, 0.003, -0.002]) * DEG_H / 3600 * ramp,
        accel_bias=np.array([50.0, -30.0, 80.0]) * UG,
        gyro_scale_factor=np.array([20e-6, -10e-6, 30e-6]),
        gyro_misalignment=np.array([[0, 5e-6, -8e-6], [4e-6, 0, 6e-6], [-3e-6, 7e-6, 0]]),
        accel_scale_factor=np.array([40e-6, -20e-6, 60e-6]),
    )


def rel_err(a, b):
    """Largest error per state, relative to that state's largest magnitude."""
    return np.max(np.abs(a - b) / np.max(np.abs(b), axis=0))


# ----------------------------------------------------------------------------- rotation off


def test_rotation_off_is_the_static_ins_result():
    # heading 30 deg: body != nav, but constant; the static propagator gets u = C_b^n u_b
    t = np.arange(0.0, 86400.0 + 1, 60.0)
    imu = full_imu(ramp=False)
    s = rm.make_scheme("none", t[-1], heading_rad=math.radians(30))
    u = rm.navigation_inputs(SITE, s, imu, [0.0])[0]
    c = s.attitude([0.0])[0]
    # the inputs follow the module equations (independent evaluation here)
    w_ie = np.array([0, SITE.earth_rate_rad_s * math.cos(SITE.latitude_rad),
                     SITE.earth_rate_rad_s * math.sin(SITE.latitude_rad)])
    dw = c @ (imu.gyro_drift + imu.gyro_matrix @ c.T @ w_ie)
    df = c @ (imu.accel_bias + imu.accel_scale_factor * (c.T @ [0, 0, SITE.gravity_m_s2]))
    np.testing.assert_allclose(u, np.r_[df[:2], dw], rtol=1e-14, atol=1e-22)
    x = rm.propagate_rotating(SITE, s, imu, t)
    assert rel_err(x, propagate(SITE, t, u=u)) < 1e-9


def test_vertical_rotation_leaves_vertical_drift_as_static():
    # drift along the rotation axis is not modulated: C_b^n e_z = e_z
    t = np.arange(0.0, 86400.0 + 1, 60.0)
    imu = rm.ImuErrors(gyro_drift=np.array([0, 0, 0.01]) * DEG_H)
    s = rm.make_scheme("single-axis", t[-1], rate_rad_s=math.radians(6))
    x = rm.propagate_rotating(SITE, s, imu, t)
    assert rel_err(x, propagate(SITE, t, u=[0, 0, 0, 0, 0.01 * DEG_H])) < 1e-9


def test_scale_factor_times_rotation_rate_is_a_vertical_drift_unless_alternating():
    # M = diag(0, 0, dK): C M C^T w_ie + C M w_nb^b = dK (W sinL + Omega) e_z, constant
    dk, om = 50e-6, math.radians(6)
    t = np.arange(0.0, 86400.0 + 1, 60.0)
    imu = rm.ImuErrors(gyro_scale_factor=np.array([0, 0, dk]))
    one_way = rm.propagate_rotating(SITE, rm.make_scheme("single-axis", t[-1], rate_rad_s=om),
                                    imu, t)
    w_up = SITE.earth_rate_rad_s * math.sin(SITE.latitude_rad)
    assert rel_err(one_way, propagate(SITE, t, u=[0, 0, 0, 0, dk * (w_up + om)])) < 1e-9
    alt = rm.propagate_rotating(
        SITE, rm.make_scheme("single-axis", t[-1], rate_rad_s=om, alternate=True), imu, t)
    # alternating: a sawtooth of amplitude dK 2 pi per turn plus the Earth-rate part dK W sinL
    earth_part = propagate(SITE, t, u=[0, 0, 0, 0, dk * w_up])[:, 6]
    assert np.max(np.abs(alt[:, 6])) < dk * 2 * np.pi + 1.2 * np.max(np.abs(earth_part))
    assert np.max(np.abs(alt[:, 6])) < np.max(np.abs(one_way[:, 6])) / 100


def static_and(scheme, imu, **kw):
    t = np.arange(0.0, 86400.0 + 1, 60.0)
    r0 = rm.run_scheme(SITE, rm.make_scheme("none", t[-1]), imu, t)
    r1 = rm.run_scheme(SITE, rm.make_scheme(scheme, t[-1], **kw), imu, t)
    return r0.summary(), r1.summary()


@pytest.mark.parametrize("scheme,kw", [
    ("single-axis", {"rate_rad_s": math.radians(6)}),
    ("four-position", {"rate_rad_s": W10, "dwell_s": 60.0}),
    ("sixteen-position", {"rate_rad_s": W10, "dwell_s": 60.0}),
])
def test_horizontal_drift_and_bias_are_averaged_out(scheme, kw):
    imu = rm.ImuErrors(gyro_drift=np.array([0.01, 0.01, 0]) * DEG_H,
                       accel_bias=np.array([100.0, 100.0, 0]) * UG)
    s0, s1 = static_and(scheme, imu, **kw)
    # static: ~0.01 deg/h drifts give ~ km after 24 h; rotating: bounded, 50 x smaller
    assert s1["max_horizontal_position_m"] < s0["max_horizontal_position_m"] / 50
    for k in ("max_phiE_rad", "max_phiN_rad", "max_phiU_rad"):
        assert s1[k] < s0[k] / 10


def test_sixteen_position_also_cancels_the_vertical_drift():
    imu = rm.ImuErrors(gyro_drift=np.array([0, 0, 0.01]) * DEG_H)
    s0, s16 = static_and("sixteen-position", imu, rate_rad_s=W10, dwell_s=60.0)
    _, s1 = static_and("single-axis", imu, rate_rad_s=W10)
    assert s1["max_horizontal_position_m"] == pytest.approx(s0["max_horizontal_position_m"],
                                                            rel=1e-9)
    assert s16["max_horizontal_position_m"] < s0["max_horizontal_position_m"] / 50


# ----------------------------------------------------------------------------- closed forms


@pytest.mark.parametrize("alternate", [False, True])
def test_mean_attitude_over_whole_periods_single_axis(alternate):
    s = rm.make_scheme("single-axis", 1000.0, rate_rad_s=-math.radians(7), alternate=alternate)
    for k in (1, 2, 5):
        m = rm.mean_attitude(s, 0.0, k * s.cycle_s)
        np.testing.assert_allclose(m, np.diag([0.0, 0.0, 1.0]), atol=1e-14)
    # a window not holding whole periods does not cancel
    assert np.abs(rm.mean_attitude(s, 0.0, 0.25 * s.cycle_s)[:2, :2]).max() > 0.1


def test_mean_attitude_indexing_cycles():
    s4 = rm.make_scheme("four-position", 3000.0, rate_rad_s=W10, dwell_s=60.0)
    np.testing.assert_allclose(rm.mean_attitude(s4, 0, s4.cycle_s), np.diag([0, 0, 1.0]),
                               atol=1e-14)
    s16 = rm.make_scheme("sixteen-position", 3000.0, rate_rad_s=W10, dwell_s=60.0)
    np.testing.assert_allclose(rm.mean_attitude(s16, 0, s16.cycle_s), np.zeros((3, 3)),
                               atol=1e-14)


def test_classic_four_position_half_cycle_leaves_the_transition_residual():
    # orders 1-4 (0 -> 180 -> 270 -> 90 -> 0): dwells cancel, turns sweep arcs whose
    # integral of exp(i theta) |d theta| is -2 + 2i, so the body x axis averages to
    # (-2, 2) / (W T_half) in (E, N)
    s = rm.make_scheme("four-position", 3000.0, rate_rad_s=W10, dwell_s=60.0)
    half = s.cycle_s / 2
    m = rm.mean_attitude(s, 0.0, half)
    np.testing.assert_allclose(m[:2, 0], np.array([-2.0, 2.0]) / (W10 * half), rtol=1e-12)


def test_mean_attitude_matches_quadrature_of_the_attitude():
    s = rm.make_scheme("sixteen-position", 3000.0, rate_rad_s=W10, dwell_s=60.0)
    a, b = 37.0, 801.5
    pts = np.r_[a, s.start_s[(s.start_s > a) & (s.start_s < b)], b]
    tot = sum(quad_vec(lambda t: s.attitude([t])[0], p, q, epsabs=1e-13)[0]
              for p, q in zip(pts[:-1], pts[1:], strict=True))
    np.testing.assert_allclose(rm.mean_attitude(s, a, b), tot / (b - a), atol=1e-11)


def test_ramp_drift_leaves_the_first_order_residual():
    # decoupled site (negligible g, 1/R, Earth rate): phi = -integral of u exactly (the gyro
    # output error turns the computed frame backwards: phi' = -C_b^n dw^b).
    # int_0^{kT} R(W s) s ds eps1_h = k T J eps1_h / W;  phiU = -eps1_z (kT)^2 / 2
    site = InsSite(0.3, radius_m=1e15, gravity_m_s2=1e-12, earth_rate_rad_s=0.0)
    om = math.radians(6)
    eps1 = np.array([3e-10, -2e-10, 1e-10])
    s = rm.make_scheme("single-axis", 600.0, rate_rad_s=om)
    t = np.arange(0, 601, 60.0)  # whole periods (T = 60 s)
    x = rm.propagate_rotating(site, s, rm.ImuErrors(gyro_drift_rate=eps1), t)
    expected_h = np.outer(t, ramp_residual(eps1[:2], om))
    np.testing.assert_allclose(x[:, 4:6], -expected_h, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(x[:, 6], -eps1[2] * t**2 / 2, rtol=1e-9, atol=1e-15)
    # magnitude |eps1_h| / W of the equivalent drift, vs eps1 t^2 / 2 without rotation
    assert np.linalg.norm(x[-1, 4:6]) / t[-1] == pytest.approx(np.linalg.norm(eps1[:2]) / om)
    x0 = rm.propagate_rotating(site, rm.make_scheme("none", 600.0), rm.ImuErrors(
        gyro_drift_rate=eps1), t)
    np.testing.assert_allclose(x0[:, 4:6], -np.outer(t**2 / 2, eps1[:2]), rtol=1e-9,
                               atol=1e-15)


# ----------------------------------------------------------------------------- vs solve_ivp


def segment_rhs(site, imu, a, b, t_start, c0, axis, frame, rate):
    """x' = A x + B u(t) on one segment, u from Rodrigues' formula and the module equations."""
    kx = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    lat, w_e, g = site.latitude_rad, site.earth_rate_rad_s, site.gravity_m_s2
    w_ie = np.array([0, w_e * math.cos(lat), w_e * math.sin(lat)])
    m_g = np.diag(imu.gyro_scale_factor) + imu.gyro_misalignment

    def f(t, x):
        th = rate * (t - t_start)
        r = np.eye(3) + math.sin(th) * kx + (1 - math.cos(th)) * kx @ kx
        c = r @ c0 if frame == 0 else c0 @ r
        w_nb_b = c.T @ axis * rate if frame == 0 else axis * rate
        eps = imu.gyro_drift + imu.gyro_drift_rate * t
        dw = c @ (eps + m_g @ (c.T @ w_ie + w_nb_b))
        df = c @ (imu.accel_bias + imu.accel_scale_factor * (c.T @ [0, 0, g]))
        return a @ x + b @ np.r_[df[:2], dw]

    return f


@pytest.mark.parametrize("scheme,kw", [
    ("single-axis", {"rate_rad_s": math.radians(6), "alternate": True}),
    ("four-position", {"rate_rad_s": math.radians(20), "dwell_s": 20.0}),
    ("sixteen-position", {"rate_rad_s": math.radians(30), "dwell_s": 5.0}),
])
def test_exact_propagation_matches_solve_ivp(scheme, kw):
    # 10 min: long enough for the Schuler loop to matter (x0 includes tilt and velocity)
    span = 600.0
    site = InsSite(math.radians(30))
    imu = full_imu()
    s = rm.make_scheme(scheme, span, **kw)
    x0 = np.array([0.01, -0.02, 1e-7, -2e-7, 2e-5, -1e-5, 3e-4])
    t = np.linspace(0.0, span, 97)
    x = rm.propagate_rotating(site, s, imu, t, x0=x0)
    a, b = system_matrix(site), input_matrix()
    edges = np.r_[s.start_s, span]
    y, ref = x0, np.empty_like(x)
    for k, (p, q) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        f = segment_rhs(site, imu, a, b, p, s.c0[k], s.axis[k], s.frame[k], s.rate_rad_s[k])
        sel = (t >= p) & ((t < q) | (q == span))
        sol = solve_ivp(f, (p, q), y, method="DOP853", rtol=1e-12, atol=1e-16,
                        dense_output=True)
        ref[sel] = sol.sol(t[sel]).T if sel.any() else ref[sel]
        y = sol.y[:, -1]
    assert rel_err(x, ref) < 1e-8


# ----------------------------------------------------------------------------- bad input


def test_bad_input_is_refused_with_the_fix():
    with pytest.raises(InputError, match="non-zero rate"):
        rm.make_scheme("single-axis", 3600.0, rate_rad_s=0.0)
    with pytest.raises(InputError, match="non-zero rate"):
        rm.make_scheme("sixteen-position", 3600.0, rate_rad_s=0.0, dwell_s=60.0)
    with pytest.raises(InputError, match="longer than the simulated span"):
        rm.make_scheme("single-axis", 30.0, rate_rad_s=math.radians(6))
    with pytest.raises(InputError, match="longer than the simulated span"):
        rm.make_scheme("sixteen-position", 1000.0, rate_rad_s=W10, dwell_s=60.0)
    with pytest.raises(InputError, match="dwell"):
        rm.make_scheme("four-position", 3600.0, rate_rad_s=W10, dwell_s=0.0)
    with pytest.raises(InputError, match="unknown rotation scheme"):
        rm.make_scheme("tumble", 3600.0, rate_rad_s=W10)
    s = rm.make_scheme("none", 100.0)
    with pytest.raises(InputError, match="beyond the scheme's span"):
        rm.propagate_rotating(SITE, s, rm.ImuErrors(), [0.0, 200.0])
    with pytest.raises(InputError, match="shape"):
        rm.ImuErrors(gyro_drift=np.zeros(2))


# ----------------------------------------------------------------------------- Monte Carlo


@pytest.mark.slow  # a Monte Carlo loop: run by CI, skipped by -m 'not slow'
def test_isotropic_white_noise_keeps_the_static_covariance_under_rotation():
    # white noise, isotropic in the body: C_b^n w has the same covariance for any rotation
    t = np.arange(0.0, 3601.0, 1.0)
    gyro_psd = np.full(3, (0.005 * math.radians(1) / 60) ** 2)  # ARW 0.005 deg/sqrt(h)
    accel_psd = np.full(3, (50e-6) ** 2)  # VRW 50 um/s/sqrt(s)
    p = rm.static_noise_covariance(SITE, t, gyro_psd=gyro_psd, accel_psd=accel_psd)[-1]
    s = rm.make_scheme("sixteen-position", t[-1], rate_rad_s=W10, dwell_s=60.0)
    x = rm.monte_carlo_noise(SITE, s, t, gyro_psd=gyro_psd, accel_psd=accel_psd, runs=600,
                             rng=7)
    ratio = x.std(axis=0) / np.sqrt(np.diag(p))
    np.testing.assert_allclose(ratio, 1.0, atol=0.12)


def test_scale_factor_times_earth_rate_leaves_a_mean_drift():
    # C M C^T w_ie with C = R_z(W t), M = diag(kx, ky, kz): over a whole period the mean is
    # ((kx + ky) / 2) W cosL north and kz W sinL up (the 2 W t terms average out)
    kx, ky, kz = 40e-6, -10e-6, 25e-6
    imu = rm.ImuErrors(gyro_scale_factor=np.array([kx, ky, kz]))
    om = math.radians(6)
    s = rm.make_scheme("single-axis", 120.0, rate_rad_s=-om, alternate=True)
    mean = quad_vec(lambda t: rm.navigation_inputs(SITE, s, imu, [t])[0], 0.0, s.cycle_s,
                    epsabs=1e-20, epsrel=1e-12)[0] / s.cycle_s
    w, lat = SITE.earth_rate_rad_s, SITE.latitude_rad
    np.testing.assert_allclose(mean[2:], [0.0, (kx + ky) / 2 * w * math.cos(lat),
                                          kz * w * math.sin(lat)], atol=1e-18)


def test_misalignment_with_rotation_cancels_over_a_cycle():
    # gyro i sensing the mount rate about axis j: a body-fixed horizontal drift M[:2, 2] W,
    # modulated away over whole turns; the sixteen-position cycle cancels every term
    imu = rm.ImuErrors(gyro_misalignment=np.array([[0, 2e-5, 3e-5], [-1e-5, 0, 4e-5],
                                                   [2e-5, 1e-5, 0]]))
    site = InsSite(0.7, earth_rate_rad_s=0.0)
    for name, kw in (("single-axis", {"rate_rad_s": W10}),
                     ("sixteen-position", {"rate_rad_s": W10, "dwell_s": 10.0})):
        s = rm.make_scheme(name, 2000.0, **kw)
        edges = np.r_[s.start_s[s.start_s < s.cycle_s], s.cycle_s]
        tot = sum(quad_vec(lambda t, s=s: rm.navigation_inputs(site, s, imu, [t])[0], p, q,
                           epsabs=1e-20, epsrel=1e-12)[0]
                  for p, q in zip(edges[:-1], edges[1:], strict=True))
        np.testing.assert_allclose(tot / s.cycle_s, 0.0, atol=1e-18)


@pytest.mark.slow  # a Monte Carlo loop: run by CI, skipped by -m 'not slow'
def test_anisotropic_white_noise_is_averaged_over_the_horizontal_axes():
    # gyro noise on body x only, rotating about z at 10 deg/s: the navigation frame sees
    # half the density on E and on N (period 36 s << Schuler period), none on U
    t = np.arange(0.0, 3601.0, 1.0)
    q = (0.01 * math.radians(1) / 60) ** 2
    s = rm.make_scheme("single-axis", t[-1], rate_rad_s=W10)
    x = rm.monte_carlo_noise(SITE, s, t, gyro_psd=[q, 0, 0], accel_psd=np.zeros(3), runs=600,
                             rng=11)
    p = rm.static_noise_covariance(SITE, t, gyro_psd=[q / 2, q / 2, 0],
                                   accel_psd=np.zeros(3))[-1]
    ratio = x.std(axis=0) / np.sqrt(np.diag(p))
    np.testing.assert_allclose(ratio, 1.0, atol=0.12)


def test_cycle_mean_inputs_closed_forms():
    k = np.array([40e-6, -10e-6, 25e-6])
    eps = np.array([0.01, -0.02, 0.03]) * DEG_H
    bias = np.array([50.0, -30.0, 80.0]) * UG
    imu = rm.ImuErrors(gyro_drift=eps, accel_bias=bias, gyro_scale_factor=k)
    w, lat, om = SITE.earth_rate_rad_s, SITE.latitude_rad, math.radians(6)
    w_ie = np.array([0.0, w * math.cos(lat), w * math.sin(lat)])
    # single axis: horizontal drift/bias gone; up: eps_z + kz (W sinL + Omega);
    # north: (kx + ky) / 2 W cosL
    s1 = rm.make_scheme("single-axis", 600.0, rate_rad_s=om)
    np.testing.assert_allclose(
        rm.cycle_mean_inputs(SITE, s1, imu),
        [0, 0, 0, (k[0] + k[1]) / 2 * w_ie[1], eps[2] + k[2] * (w_ie[2] + om)], atol=1e-18)
    # sixteen position: drift and bias gone; the dwells (180-deg flips) keep diag(k), a half
    # turn about z averages kx, ky and one about x averages ky, kz (8 of each per cycle)
    td, tau = 30.0, math.pi / W10
    s16 = rm.make_scheme("sixteen-position", 3000.0, rate_rad_s=W10, dwell_s=td)
    m_mean = (16 * td * k + 8 * tau * np.r_[(k[0] + k[1]) / 2, (k[0] + k[1]) / 2, k[2]]
              + 8 * tau * np.r_[k[0], (k[1] + k[2]) / 2, (k[1] + k[2]) / 2]) / (16 * (td + tau))
    np.testing.assert_allclose(rm.cycle_mean_inputs(SITE, s16, imu),
                               np.r_[0, 0, m_mean * w_ie], atol=1e-18)
    assert m_mean.sum() == pytest.approx(k.sum())  # the trace survives any rotation
    # static: the input itself
    s0 = rm.make_scheme("none", 100.0)
    np.testing.assert_allclose(rm.cycle_mean_inputs(SITE, s0, imu),
                               np.r_[bias[:2], eps + k * w_ie], rtol=1e-14)


def test_cycle_mean_inputs_match_quadrature_for_four_position():
    # the turns' sin(2 theta) terms of (ky - kx) W cosL leave an east drift: compare the exact
    # mean with quadrature of the directly evaluated inputs
    imu = rm.ImuErrors(gyro_scale_factor=np.array([40e-6, -10e-6, 25e-6]),
                       gyro_misalignment=np.array([[0, 2e-5, 3e-5], [-1e-5, 0, 4e-5],
                                                   [2e-5, 1e-5, 0]]))
    s = rm.make_scheme("four-position", 3000.0, rate_rad_s=W10, dwell_s=30.0)
    edges = np.r_[s.start_s[s.start_s < s.cycle_s], s.cycle_s]
    tot = sum(quad_vec(lambda t: rm.navigation_inputs(SITE, s, imu, [t])[0], p, q,
                       epsabs=1e-22, epsrel=1e-13)[0]
              for p, q in zip(edges[:-1], edges[1:], strict=True))
    mean = rm.cycle_mean_inputs(SITE, s, imu)
    np.testing.assert_allclose(mean, tot / s.cycle_s, atol=1e-20)
    # scale factor alone: (R M R^T)_EN = (kx - ky) / 2 sin(2 theta); per half cycle the arcs
    # swept integrate sin(2 theta) |d theta| to 0 + 1 + 0 + 1 = 2 (module notes)
    sf = rm.ImuErrors(gyro_scale_factor=np.array([40e-6, -10e-6, 25e-6]))
    w_n = SITE.earth_rate_rad_s * math.cos(SITE.latitude_rad)
    expected_e = (40e-6 + 10e-6) / 2 * w_n * 4 / W10 / s.cycle_s
    assert rm.cycle_mean_inputs(SITE, s, sf)[2] == pytest.approx(expected_e, rel=1e-9)


def test_convention_gyro_misalignment_by_name_from_the_triad_model():
    """Static IMU, body = ENU, only M_xy = 5 urad built by name through the triad model: by hand,
    gyro x reads M_xy times the Earth rate about y (north), W cos L, so eE = M_xy W cos L and
    eN = eU = 0 (the transposed order, M_yx, would have gyro y read the east rate: zero)."""
    from inertest.models.triad import TriadErrors

    imu = rm.ImuErrors.from_triads(TriadErrors.from_engineering(
        "gyroscope", misalignment_urad={"M_xy": 5.0}, bias=[0.01, 0.0, 0.0]))
    s = rm.make_scheme("none", 600.0)
    u = rm.navigation_inputs(SITE, s, imu, [0.0])[0]
    w, lat = SITE.earth_rate_rad_s, SITE.latitude_rad
    np.testing.assert_allclose(u[2:], [5e-6 * w * math.cos(lat) + 0.01 * DEG_H, 0.0, 0.0],
                               rtol=1e-12, atol=1e-24)
    assert imu.gyro_misalignment[0, 1] == pytest.approx(5e-6, rel=1e-15)


def test_scheme_as_motion_closed_form():
    """A rotation scheme is an equipment motion: at a dwell the IMU feels W and g on its axes;
    in a turn about up the body rate adds the turn rate along the turn axis."""
    from inertest.earth import Site
    from inertest.equipment.motion import Motion

    site = Site.at(39.0, 9.80)
    scheme = rm.make_scheme("single-axis", 3600.0, rate_rad_s=np.radians(6.0), dwell_s=60.0)
    m = scheme.motion(site)
    assert isinstance(m, Motion)
    labels = m.segments
    assert len(labels) == scheme.start_s.size and any(s.startswith("turn") for s in labels)
    w_n = 7.2921151467e-5 * np.array([0.0, np.cos(np.radians(39.0)), np.sin(np.radians(39.0))])
    for label in labels[:4]:
        k = labels.index(label)
        tau = np.linspace(0.0, scheme.duration_s[k], 5)
        inp = m.inputs(label, tau)
        c = scheme.attitude(scheme.start_s[k] + tau)
        np.testing.assert_allclose(inp.C_ni, c, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(inp.f_i, axis=1), 9.80, rtol=1e-12)
        np.testing.assert_allclose(inp.f_i, np.einsum("nji,j->ni", c, [0, 0, 9.80]), atol=1e-12)
        mount = scheme.mount_rate_body(scheme.start_s[k] + tau)
        np.testing.assert_allclose(inp.omega_i - mount, np.einsum("nji,j->ni", c, w_n),
                                   atol=1e-18)
        if label.startswith("turn"):
            assert np.allclose(np.linalg.norm(mount, axis=1), np.radians(6.0))
