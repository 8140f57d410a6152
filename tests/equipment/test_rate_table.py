"""Rate table / two-axis turntable kinematics: closed forms and brute-force integrals."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.spatial.transform import Rotation

from inertest.earth import OMEGA_IE, Site
from inertest.equipment import rate_table as rt
from inertest.equipment.motion import Motion
from inertest.errors import InputError

LAT = np.radians(34.246)


def test_earth_rate_along_the_local_directions():
    assert rt.earth_rate_along(rt.direction_vector("U"), LAT) == pytest.approx(
        OMEGA_IE * np.sin(LAT), rel=1e-15)
    assert rt.earth_rate_along(rt.direction_vector("N"), LAT) == pytest.approx(
        OMEGA_IE * np.cos(LAT), rel=1e-15)
    assert rt.earth_rate_along(rt.direction_vector("d"), LAT) == pytest.approx(
        -OMEGA_IE * np.sin(LAT), rel=1e-15)
    assert abs(rt.earth_rate_along(rt.direction_vector("E"), LAT)) < 1e-20
    # A table axis tilted 45 deg from up towards north.
    v = rt.direction_vector([0.0, 1.0, 1.0])
    assert rt.earth_rate_along(v, LAT) == pytest.approx(
        OMEGA_IE * (np.cos(LAT) + np.sin(LAT)) / np.sqrt(2), rel=1e-15)


@pytest.mark.parametrize("spec, msg", [("Q", "not one of E, W"), ([0, 0, 0], "non-zero"),
                                       ([1, 2], "three numbers")])
def test_bad_table_axis(spec, msg):
    with pytest.raises(InputError, match=msg):
        rt.direction_vector(spec)


def test_triad_attitudes():
    np.testing.assert_array_equal(rt.triad_attitude("ENU"), np.eye(3))
    C = rt.triad_attitude("UEN")  # x up, y east, z north
    np.testing.assert_array_equal(C[:, 0], [0, 0, 1])
    assert np.linalg.det(C) == pytest.approx(1.0)
    assert rt.vertical_axis(C) == 0 and rt.vertical_axis(rt.triad_attitude("NUE")) == 1
    with pytest.raises(InputError, match="left-handed: x x y = z, so z must be U here"):
        rt.triad_attitude("END")
    with pytest.raises(InputError, match="not an orthogonal triad"):
        rt.triad_attitude("EWU")
    with pytest.raises(InputError, match="three directions"):
        rt.triad_attitude("EN")


def test_profile_durations_closed_form():
    w, a = np.radians(20.0), np.radians(10.0)
    assert rt.RotationProfile(w).duration_s == pytest.approx(18.0)
    # Trapezoid: accelerate for w/a, cruise, decelerate: T = angle/w + w/a.
    assert rt.RotationProfile(w, a).duration_s == pytest.approx(18.0 + 2.0)
    # Triangular (the rate is never reached): T = 2 sqrt(angle/a).
    tri = rt.RotationProfile(np.radians(200.0), a)
    assert tri.duration_s == pytest.approx(2 * np.sqrt(2 * np.pi / a))
    for p in (rt.RotationProfile(w), rt.RotationProfile(w, a), tri):
        assert p.angle(p.duration_s)[()] == pytest.approx(2 * np.pi, rel=1e-14)
        t = np.linspace(0.01, p.duration_s - 0.01, 101)
        num = (p.angle(t + 1e-6) - p.angle(t - 1e-6)) / 2e-6
        np.testing.assert_allclose(num, p.rate(t), atol=1e-6)


def test_uniform_turn_earth_angle_closed_form():
    """Constant rate, whole turn: the perpendicular Earth rate averages out during the turn."""
    C0 = rt.triad_attitude("NUE")  # y up
    prof = rt.RotationProfile(np.radians(15.0))
    window = prof.duration_s + 7.0
    w_b0 = C0.T @ (OMEGA_IE * np.array([0, np.cos(LAT), np.sin(LAT)]))
    got = rt.rotation_earth_angle(C0, 1, -1, prof, window, LAT)
    expect = w_b0 * 7.0
    expect[1] = w_b0[1] * window
    np.testing.assert_allclose(got, expect, rtol=1e-12, atol=1e-18)
    total = rt.body_angle(C0, 1, -1, prof, window, LAT)
    assert total[1] == pytest.approx(-2 * np.pi + w_b0[1] * window, rel=1e-15)


def test_trapezoid_turn_earth_angle_against_adaptive_quadrature():
    C0 = rt.triad_attitude("ESD")
    prof = rt.RotationProfile(np.radians(30.0), np.radians(4.0))
    window = prof.duration_s + 3.0
    w_n = OMEGA_IE * np.array([0, np.cos(LAT), np.sin(LAT)])

    def w_body(t, k):
        C = C0 @ Rotation.from_rotvec([0, 0, prof.angle(t)[()]]).as_matrix()
        return (C.T @ w_n)[k]

    expect = [quad(w_body, 0, prof.duration_s, args=(k,), limit=200, epsabs=1e-16)[0]
              + (C0.T @ w_n)[k] * 3.0 for k in range(3)]
    np.testing.assert_allclose(rt.rotation_earth_angle(C0, 2, 1, prof, window, LAT), expect,
                               rtol=1e-10, atol=1e-15)


def test_window_shorter_than_turn_is_an_error():
    prof = rt.RotationProfile(np.radians(10.0))
    with pytest.raises(InputError, match="shorter than the rotation time 36 s"):
        rt.rotation_earth_angle(np.eye(3), 2, 1, prof, 30.0, LAT)


def test_attitude_history_turns_about_the_body_axis():
    C0 = rt.triad_attitude("UEN")
    R = rt.attitude_history(C0, 0, 1, [0.0, np.pi / 2])
    np.testing.assert_allclose(R[0].as_matrix(), C0, atol=1e-15)
    # After +90 deg about x (up): y (east) has turned to north.
    np.testing.assert_allclose(R[1].as_matrix()[:, 1], [0, 1, 0], atol=1e-15)


@pytest.mark.slow
def test_real_rlg_senses_the_earth_rate_of_a_vertical_table_axis(realdata_dir):
    """PSINS navigation-grade RLG triad at rest (latitude 34.246048 deg, 1847 s): its rate along
    the measured vertical (from its accelerometers) is the Earth rate a vertical table axis
    feels, W sin L = 8.464 deg/h, to within the gyros' bias (nav grade: a few 0.01 deg/h)."""
    x = np.loadtxt(realdata_dir / "psins" / "lasergyro.imu", comments="%")[3:]
    rate = x[:, :3].sum(axis=0) * 0.1 / (x.shape[0] * 0.01)  # 0.1 arcsec LSB, 10 ms -> deg/h
    up = x[:, 3:].sum(axis=0)
    up /= np.linalg.norm(up)  # specific force at rest points up
    expect = rt.earth_rate_along(rt.direction_vector("U"), np.radians(34.246048))
    assert rate @ up == pytest.approx(expect / (np.pi / 180 / 3600), abs=0.05)


def test_table_turn_body_rate_integrates_to_the_body_angle():
    C0 = rt.triad_attitude("SDE")
    prof = rt.RotationProfile(np.radians(25.0), np.radians(8.0))
    turn = rt.TableTurn(C0, 1, -1, prof, LAT, start_s=2.0)
    window = 2.0 + prof.duration_s + 3.0
    expect = [quad(lambda t, k=k: turn.body_rate(t)[0, k], 0, window, limit=400,
                   points=[2.0, 2.0 + prof.duration_s], epsabs=1e-14)[0] for k in range(3)]
    np.testing.assert_allclose(rt.body_angle(C0, 1, -1, prof, window, LAT), expect,
                               rtol=1e-9, atol=1e-12)
    # At rest before the turn the attitude is the start attitude.
    np.testing.assert_allclose(turn.attitude([1.0]).as_matrix()[0], C0, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# The rate table and its turns as motions (inertest.equipment.motion.Motion)

SITE = Site.at(34.246)


def test_constant_rates_motion_closed_forms():
    """omega_i = C^T (w a + W_ie): |omega_i - w a_i| = W_ie, a . omega = w + W_ie . a; |f| = g."""
    a = rt.direction_vector("N")
    w = np.radians(-30.0)
    m = rt.ConstantRates(SITE, a, (np.radians(10.0), w))
    assert isinstance(m, Motion)
    assert m.segments == ("rate 10 deg/s", "rate -30 deg/s")
    t = np.linspace(0.0, 20.0, 7)
    inp = m.inputs("rate -30 deg/s", t)
    a_i = np.einsum("kji,j->ki", inp.C_ni, a)
    np.testing.assert_allclose(a_i, np.tile([1.0, 0, 0], (7, 1)), atol=1e-15)  # x on the axis
    np.testing.assert_allclose(inp.omega_i[:, 0], w + rt.earth_rate_along(a, SITE.latitude_rad),
                               rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(inp.omega_i - w * a_i, axis=1), OMEGA_IE,
                               rtol=1e-11)  # w cancels: rounding of w (0.5 rad/s) / W_ie
    np.testing.assert_allclose(np.linalg.norm(inp.f_i, axis=1), SITE.gravity_m_s2, rtol=1e-14)
    # A whole table turn returns the attitude; a quarter turn at -30 deg/s (left-handed about
    # north) takes up to west.
    back = m.inputs_at_rate(w, [0.0, 2 * np.pi / abs(w), np.pi / 2 / abs(w)]).C_ni
    np.testing.assert_allclose(back[1], back[0], atol=1e-14)
    np.testing.assert_allclose(back[2] @ (back[0].T @ [0, 0, 1.0]), [-1.0, 0, 0], atol=1e-14)
    with pytest.raises(InputError, match="unknown rate-table segment"):
        m.inputs("rate 11 deg/s")


def test_constant_rates_triad_on_its_z_axis_feels_the_earth_rate_of_rt():
    C0 = rt.triad_attitude("ENU")
    m = rt.ConstantRates(SITE, rt.direction_vector("U"), (np.radians(5.0),), C_ni0=C0)
    inp = m.inputs(m.segments[0], [0.0, 3.0])
    np.testing.assert_allclose(inp.omega_i[:, 2], np.radians(5.0) + OMEGA_IE * np.sin(
        SITE.latitude_rad), rtol=1e-14)
    np.testing.assert_allclose(inp.f_i[:, 2], SITE.gravity_m_s2, rtol=1e-15)


def test_turns_motion_integrates_to_the_exact_body_angle():
    """A trapezoid turn as a motion: a whole turn returns the attitude, |f| = g throughout, and
    the integral of omega_i (adaptive quadrature) is body_angle = 2 pi e_j + Earth angle."""
    prof = rt.RotationProfile(np.radians(25.0), np.radians(8.0))
    C0 = rt.triad_attitude("SDE")
    m = rt.Turns(SITE, {"y-": (C0, 1, -1)}, prof, start_s=2.0)
    assert isinstance(m, Motion) and m.segments == ("y-",)
    window = 2.0 + prof.duration_s + 3.0
    end = m.inputs("y-", [0.0, window, 2.0 + prof.duration_s / 2])
    np.testing.assert_allclose(end.C_ni[1], C0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(end.f_i, axis=1), SITE.gravity_m_s2, rtol=1e-14)
    expect = [quad(lambda t, k=k: m.inputs("y-", t).omega_i[0, k], 0, window, limit=400,
                   points=[2.0, 2.0 + prof.duration_s], epsabs=1e-14)[0] for k in range(3)]
    got = m.body_angle("y-", window)
    np.testing.assert_allclose(got, expect, rtol=1e-9, atol=1e-12)
    w_b0 = C0.T @ (OMEGA_IE * np.array([0, np.cos(SITE.latitude_rad), np.sin(SITE.latitude_rad)]))
    assert got[1] == pytest.approx(-2 * np.pi + w_b0[1] * window, rel=1e-14)
