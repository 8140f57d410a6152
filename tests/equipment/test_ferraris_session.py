"""Ferraris session kinematics: face specific force, sampled turn profile."""

import numpy as np
import pytest
from scipy.integrate import quad

from inertest.earth import OMEGA_IE, Site
from inertest.equipment import ferraris_session as fs
from inertest.equipment.motion import Motion
from inertest.errors import InputError


def test_faces_and_turn_labels():
    assert fs.FACE_LABELS == ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")
    assert fs.TURN_LABELS == ("x_rot", "y_rot", "z_rot")
    np.testing.assert_allclose(fs.face_specific_force(1, -1, 9.8), [0, -9.8, 0])


def test_tilted_face_keeps_g_and_tilts_by_the_angle():
    """A 2 deg tilt about y of the z-up face: f = g (sin 2deg, 0, cos 2deg) (closed form)."""
    t = np.radians(2.0)
    f = fs.face_specific_force(2, +1, 9.8, np.array([0.3, t, 0.0]) * [0, 1, 1])
    np.testing.assert_allclose(f, 9.8 * np.array([np.sin(t), 0, np.cos(t)]), atol=1e-12)


def test_sampled_turn_integrates_exactly():
    w = fs.turn_rate_profile(0, -2 * np.pi, 3.0, 100.0, rest_s=0.5)
    assert w.shape == (400, 3)
    assert w[:, 0].sum() / 100.0 == pytest.approx(-2 * np.pi, rel=1e-14)
    assert np.all(w[:50] == 0) and np.all(w[:, 1:] == 0)
    with pytest.raises(InputError, match="whole"):
        fs.turn_rate_profile(0, 1.0, 1.005, 100.0)


def test_faces_motion_is_the_face_specific_force_and_earth_rate():
    site = Site.at(50.0)
    m = fs.faces_motion(site)
    assert isinstance(m, Motion) and m.segments == fs.FACE_LABELS
    for label, axis, sign in fs.FACES:
        inp = m.inputs(label)
        np.testing.assert_allclose(inp.f_i[0], fs.face_specific_force(axis, sign,
                                                                      site.gravity_m_s2))
        assert np.linalg.norm(inp.omega_i[0]) == pytest.approx(OMEGA_IE, rel=1e-14)
        # The vertical Earth rate W sin L lies along the up axis.
        assert inp.omega_i[0, axis] == pytest.approx(sign * OMEGA_IE * np.sin(site.latitude_rad),
                                                     rel=1e-14)


def test_raised_cosine_turn_motion():
    """Continuous raised-cosine turn: the rate integrates to the angle, the turn returns the
    attitude, the integrated omega_i (adaptive quadrature) is the exact body angle, whose axis
    component is the angle plus W sin L times the window (the axis stays vertical)."""
    site = Site.at(50.0)
    m = fs.turns_motion(site, -2 * np.pi, 4.0, rest_s=1.0)
    assert isinstance(m, Motion) and m.segments == fs.TURN_LABELS
    p = m.profile
    assert quad(p.rate, 0, 4.0)[0] == pytest.approx(2 * np.pi, rel=1e-13)
    assert p.angle(4.0) == pytest.approx(2 * np.pi, rel=1e-15)
    np.testing.assert_allclose(p.rate(1.3), (p.angle(1.3 + 1e-6) - p.angle(1.3 - 1e-6)) / 2e-6,
                               rtol=1e-8)
    window = 6.0
    for label, axis in fs.TURNS:
        inp = m.inputs(label, [0.0, window])
        np.testing.assert_allclose(inp.C_ni[1], inp.C_ni[0], atol=1e-13)
        np.testing.assert_allclose(inp.f_i[:, axis], site.gravity_m_s2, rtol=1e-14)
        expect = [quad(lambda t, k=k, lab=label: m.inputs(lab, t).omega_i[0, k], 0, window,
                       limit=200, points=[1.0, 5.0], epsabs=1e-15)[0] for k in range(3)]
        got = m.body_angle(label, window)
        np.testing.assert_allclose(got, expect, rtol=1e-9, atol=1e-13)
        assert got[axis] == pytest.approx(
            -2 * np.pi + OMEGA_IE * np.sin(site.latitude_rad) * window, rel=1e-14)
