"""Exact kinematics of the imperfect dual-axis centrifuge (issue 5, seed 004 eqs. 1-13)."""

import numpy as np
import pytest

from inertest.earth import OMEGA_IE, Site, earth_rate_enu
from inertest.equipment import centrifuge as cf
from inertest.equipment.motion import Motion
from inertest.errors import InputError

R, G, LAT = 2.5, 9.8066, np.radians(45.0)
KW = {"radius_m": R, "gravity_m_s2": G, "latitude_rad": LAT}

#: Deliberately large errors so that every link of the chain is exercised.
BIG = cf.CentrifugeErrors(
    radius_poly_m=(1e-3, 2e-4),
    misalignment_y_poly_rad=(2e-3, 1e-3),
    misalignment_z_poly_rad=(-3e-3, 5e-4),
    parallelism_x_rad=0.02,
    parallelism_y_rad=-0.03,
    wobble_x_rad=0.04,
    wobble_y_rad=0.025,
    wobble_x_phase_rad=0.3,
    wobble_y_phase_rad=-1.1,
    eccentricity_x_m=0.05,
    eccentricity_y_m=-0.07,
)
PHASE = cf.PhaseTracking(amplitude_rad=0.1, frequency_hz=1.7, phase_rad=0.4)

# 8th-order central-difference stencils (Fornberg 1988) for the first and second derivative.
_D1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
_D2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])


def _stencil(fun, t, h, weights, order):
    vals = [fun(t + k * h) for k in range(-4, 5)]
    return sum(w * v for w, v in zip(weights, vals, strict=True)) / h**order


@pytest.mark.parametrize("position", cf.POSITIONS)
@pytest.mark.parametrize("omega", [4.43, 8.85])
def test_error_free_machine_equals_the_closed_form(position, omega):
    t = np.linspace(0.0, 5.0, 501)
    f, w, att = cf.instrument_inputs(t, omega, position, earth_rotation_in_acceleration=False, **KW)
    f0, w0 = cf.ideal_inputs(t, omega, position, **KW)
    np.testing.assert_allclose(f, f0, rtol=0, atol=1e-12 * R * omega**2)
    # the arm and platform rates cancel to rounding, |w| eps ~ 1e-15 rad/s (2e-10 deg/h)
    np.testing.assert_allclose(w, w0, rtol=0, atol=1e-14)
    # the attitude is fixed: rows I, O, S of the position, expressed in ENU
    expected = cf.platform_to_enu(0.0) @ cf.position_axes(position).T
    np.testing.assert_allclose(att, np.broadcast_to(expected, att.shape), atol=1e-14)


def test_position_1_matches_the_hand_formula_of_the_issue():
    t = np.linspace(0.0, 2.0, 101)
    f, _, _ = cf.instrument_inputs(t, 4.43, 1, earth_rotation_in_acceleration=False, **KW)
    a = 4.43 * t
    ref = np.column_stack([-R * 4.43**2 * np.cos(a), -R * 4.43**2 * np.sin(a), G + 0 * t])
    np.testing.assert_allclose(f, ref, atol=1e-12)


@pytest.mark.parametrize("omega", [4.43, 8.85])
def test_earth_rate_terms_in_the_acceleration_are_bounded_by_2_w_W_R(omega):
    t = np.linspace(0.0, 3.0, 301)
    f1, _, _ = cf.instrument_inputs(t, omega, 4, **KW)
    f0, _, _ = cf.instrument_inputs(t, omega, 4, earth_rotation_in_acceleration=False, **KW)
    d = np.linalg.norm(f1 - f0, axis=1)
    bound = 2 * OMEGA_IE * omega * R + OMEGA_IE**2 * R
    assert d.max() <= bound * (1 + 1e-9)
    # and the Coriolis term is really there: only its vertical Earth-rate part is horizontal
    assert d.max() > 0.5 * 2 * OMEGA_IE * np.sin(LAT) * omega * R


@pytest.mark.parametrize("position", [2, 6, 7])
def test_finite_differences_agree_with_the_analytic_acceleration_and_rate(position):
    omega, h = 8.85, 2e-4
    t = np.linspace(0.1, 1.3, 37)
    kw = dict(KW, errors=BIG, dgamma=PHASE, platform_heading_rad=0.7)

    def pose(tt):
        return cf.centrifuge_motion(tt, omega, position, **kw).pose

    m = cf.centrifuge_motion(t, omega, position, **kw)
    vel = _stencil(lambda tt: pose(tt)[:, :3, 3], t, h, _D1, 1)
    acc = _stencil(lambda tt: pose(tt)[:, :3, 3], t, h, _D2, 2)
    np.testing.assert_allclose(vel, m.velocity_p, rtol=0, atol=1e-8 * np.abs(m.velocity_p).max())
    np.testing.assert_allclose(
        acc, m.acceleration_p, rtol=0, atol=1e-7 * np.abs(m.acceleration_p).max()
    )
    cdot = _stencil(lambda tt: pose(tt)[:, :3, :3], t, h, _D1, 1)
    c = m.pose[:, :3, :3]
    skew = cdot @ np.transpose(c, (0, 2, 1))  # = [w_rel x] in P
    w_fd = np.column_stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]])
    np.testing.assert_allclose(w_fd, m.omega_rel_p, rtol=0, atol=1e-8 * omega)
    # the inertial rate on I, O, S is the relative rate plus the Earth rate, both rotated
    earth_p = cf.platform_to_enu(0.7).T @ earth_rate_enu(LAT)
    np.testing.assert_allclose(
        m.omega_ios, np.einsum("nji,nj->ni", c, m.omega_rel_p + earth_p), atol=1e-15
    )
    # specific force from the finite-difference motion: a + 2 W x v + W x (W x p) + g up
    pos = m.pose[:, :3, 3]
    f_p = (acc + 2 * np.cross(earth_p, vel) + np.cross(earth_p, np.cross(earth_p, pos))
           + [0.0, 0.0, G])
    np.testing.assert_allclose(
        m.f_ios, np.einsum("nji,nj->ni", c, f_p), rtol=0, atol=1e-7 * R * omega**2
    )


def test_attitude_is_a_rotation():
    t = np.linspace(0.0, 4.0, 400)
    _, _, att = cf.instrument_inputs(t, 8.85, 5, errors=BIG, dgamma=PHASE, **KW)
    eye = np.broadcast_to(np.eye(3), att.shape)
    np.testing.assert_allclose(att @ np.transpose(att, (0, 2, 1)), eye, atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(att), 1.0, atol=1e-14)


@pytest.mark.parametrize(
    "dgamma",
    [
        cf.PhaseTracking(amplitude_rad=np.radians(2 / 60), frequency_hz=0.7, phase_rad=0.2),
        cf.RateTracking(rate_rad_s=np.radians(20.7 / 60), offset_rad=0.01),
    ],
)
def test_residual_rate_is_d_dgamma_dt_about_the_platform_axis(dgamma):
    t = np.linspace(0.0, 10.0, 1001)
    m = cf.centrifuge_motion(t, 4.43, 8, dgamma=dgamma, **KW)
    c = m.pose[:, :3, :3]
    earth_p = cf.platform_to_enu(0.0).T @ earth_rate_enu(LAT)
    rel = m.omega_ios - np.einsum("nji,j->ni", c, earth_p)
    if isinstance(dgamma, cf.PhaseTracking):
        w = 2 * np.pi * 0.7
        rate = dgamma.amplitude_rad * w * np.cos(w * t + 0.2)
    else:
        rate = np.full_like(t, dgamma.rate_rad_s)
    expected = rate[:, None] * np.einsum("nji,j->ni", c, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(rel, expected, atol=1e-16)
    # and the instrument has turned by dgamma about z_P relative to its ideal attitude
    turned = c @ cf.position_axes(8)  # = Rz(dgamma)
    dg = dgamma.evaluate(t)[0]
    np.testing.assert_allclose(np.arctan2(turned[:, 1, 0], turned[:, 0, 0]), dg, atol=1e-13)


def test_measured_dgamma_reproduces_the_model_it_was_sampled_from():
    phase = cf.PhaseTracking(amplitude_rad=np.radians(2 / 60), frequency_hz=0.5)
    tm = np.linspace(0.0, 4.0, 4001)
    measured = cf.MeasuredDgamma(tm, phase.evaluate(tm)[0])
    t = np.linspace(0.5, 3.5, 301)
    a = cf.instrument_inputs(t, 4.43, 3, dgamma=phase, **KW)
    b = cf.instrument_inputs(t, 4.43, 3, dgamma=measured, **KW)
    np.testing.assert_allclose(b[1], a[1], atol=1e-13)
    np.testing.assert_allclose(b[0], a[0], atol=1e-9)


def test_bad_inputs_name_the_problem_and_the_fix():
    with pytest.raises(InputError, match="1..9"):
        cf.instrument_inputs([0.0], 4.43, 10, **KW)
    with pytest.raises(InputError, match="whole run"):
        short = cf.MeasuredDgamma(np.arange(4.0), np.zeros(4))
        cf.instrument_inputs([5.0], 4.43, 1, dgamma=short, **KW)
    with pytest.raises(InputError, match="increasing"):
        cf.MeasuredDgamma(np.array([0.0, 2.0, 1.0, 3.0]), np.zeros(4))
    with pytest.raises(InputError, match="finite"):
        cf.CentrifugeErrors(parallelism_y_rad=float("nan"))
    with pytest.raises(InputError, match="finite"):
        cf.instrument_inputs([0.0, float("nan")], 4.43, 1, **KW)
    with pytest.raises(InputError, match="radius must be positive"):
        cf.instrument_inputs([0.0], 4.43, 1, **dict(KW, radius_m=-1.0))


def test_wobble_with_y_phase_plus_90_deg_is_a_static_parallelism_about_x():
    # Tilts (a cos beta, -a sin beta) in the azimuth frame turned by beta are (a, 0) seen from
    # the arm: a constant tilt about x, to second order in a (a^2 ~ 2.5e-11 rad)
    t = np.linspace(0.0, 4.0, 801)
    a = 5e-6
    wobble = cf.CentrifugeErrors(wobble_x_rad=a, wobble_y_rad=a, wobble_y_phase_rad=np.pi / 2)
    tilt = cf.CentrifugeErrors(parallelism_x_rad=a)
    turning = cf.CentrifugeErrors(wobble_x_rad=a, wobble_y_rad=a, wobble_y_phase_rad=-np.pi / 2)
    for pos in (1, 2, 8):
        f1, w1, _ = cf.instrument_inputs(t, 8.85, pos, errors=wobble, **KW)
        f2, w2, _ = cf.instrument_inputs(t, 8.85, pos, errors=tilt, **KW)
        np.testing.assert_allclose(f1, f2, rtol=0, atol=10 * a**2 * R * 8.85**2)
        np.testing.assert_allclose(w1, w2, rtol=0, atol=10 * a**2 * 8.85)
        # with -90 deg the tilt turns at 2 beta: rate error 2 w a about a horizontal axis
        _, w3, _ = cf.instrument_inputs(t, 8.85, pos, errors=turning, **KW)
        assert np.abs(w3 - w2).max() == pytest.approx(2 * 8.85 * a, rel=1e-3)


def test_runs_as_a_motion_match_the_kinematics_and_the_seed004_closed_form():
    """Segments are runs (position, signed rate); inputs are those of centrifuge_motion, and
    without the Earth-rate acceleration the seed-004 closed form of the ideal machine."""
    site = Site.at(45.0, G)
    runs = ((1, 4.43), (8, -8.85))
    m = cf.CentrifugeRuns(runs, radius_m=R, site=site, platform_heading_rad=0.3,
                          errors=BIG, dgamma=PHASE)
    assert isinstance(m, Motion) and m.segments == ("1@4.43", "8@-8.85")
    t = np.linspace(0.0, 2.0, 201)
    got = m.inputs("8@-8.85", t)
    ref = cf.centrifuge_motion(t, -8.85, 8, platform_heading_rad=0.3, errors=BIG, dgamma=PHASE,
                               **KW)
    np.testing.assert_array_equal(got.f_i, ref.f_ios)
    np.testing.assert_array_equal(got.omega_i, ref.omega_ios)
    np.testing.assert_array_equal(got.C_ni, ref.attitude)
    ideal = cf.CentrifugeRuns(runs, radius_m=R, site=site, earth_rotation_in_acceleration=False)
    labels = cf.run_labels([8, 1, 8, 1], [-8.85, 4.43, -8.85, 4.43])
    assert labels.tolist() == ["8@-8.85", "1@4.43", "8@-8.85", "1@4.43"]
    tt = np.array([0.1, 0.2, 0.3, 0.4])
    rows = ideal.inputs_of_rows(labels, tt)
    for k, (p, w) in enumerate([(8, -8.85), (1, 4.43), (8, -8.85), (1, 4.43)]):
        a = w * tt[k]  # f_P = -R w^2 (cos a, sin a, 0) + (0, 0, g), on the rows I, O, S
        f_p = np.array([-R * w**2 * np.cos(a), -R * w**2 * np.sin(a), G])
        np.testing.assert_allclose(rows.f_i[k], cf.position_axes(p) @ f_p, atol=1e-12)
        # the platform counter-rotates: the instrument turns with the Earth only
        np.testing.assert_allclose(np.linalg.norm(rows.omega_i[k]), OMEGA_IE, rtol=1e-9)
    # the rate and force without the attitude: the same digits as the full inputs
    w_only, f_only = m.rate_and_force("8@-8.85", t)
    np.testing.assert_array_equal(w_only, ref.omega_ios)
    np.testing.assert_array_equal(f_only, ref.f_ios)
    # runs in several stretches of rows: each row gets its own run's inputs
    stretch = np.array(["8@-8.85"] * 3 + ["1@4.43"] * 2 + ["8@-8.85"] * 2)
    ts = np.linspace(0.0, 0.6, stretch.size)
    both = m.inputs_of_rows(stretch, ts)
    for k, lab in enumerate(stretch):
        one = m.inputs(str(lab), ts[k:k + 1])
        np.testing.assert_array_equal(both.f_i[k], one.f_i[0])
        np.testing.assert_array_equal(both.C_ni[k], one.C_ni[0])
    with pytest.raises(InputError, match="unknown centrifuge run"):
        m.inputs("2@4.43", t)
    with pytest.raises(InputError, match="unknown centrifuge run"):
        m.rate_and_force("2@4.43", t)
    with pytest.raises(InputError, match="not one of 1..9"):
        cf.CentrifugeRuns(((10, 4.43),), radius_m=R, site=site)
