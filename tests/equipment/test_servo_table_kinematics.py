"""Servo table: kinematics by independent construction, the servo loop against closed forms."""

import numpy as np
import pytest

from inertest.earth import Site
from inertest.equipment.motion import Motion
from inertest.equipment.servo_table import ServoTable, parse_mounting
from inertest.errors import InputError

OMEGA = 7.2921151467e-5  # WGS-84 Earth rate [rad/s]
K = np.pi / 180 / 3600   # deg/h -> rad/s


def _coeffs(**kw):
    names = ("DF", "DI", "DO", "DS", "DIO", "DOS", "DSI", "DII", "DOO", "DSS")
    return np.array([kw.get(n, 0.0) * K for n in names])


@pytest.fixture
def polar():
    return ServoTable(Site.at(45.0), "polar", ("I+H", "I-H", "I+E", "I-W"))


def test_seed000_polar_axes_by_hand(polar):
    # Independent construction: a = (0, cL, sL); H = (0, -sL, cL); a x H = E; axes turned by
    # theta about a with Rodrigues' formula written out here.
    L = np.radians(45.0)
    a = np.array([0.0, np.cos(L), np.sin(L)])
    H = np.array([0.0, -np.sin(L), np.cos(L)])
    E = np.array([1.0, 0.0, 0.0])
    assert np.allclose(np.cross(a, H), E)
    th = np.radians([0.0, 33.0, 190.0, 725.0])
    C = polar.attitude("I-H", th)
    for k, t in enumerate(th):
        def rot(v, t=t):
            return v * np.cos(t) + np.cross(a, v) * np.sin(t) + a * (a @ v) * (1 - np.cos(t))
        i, o = -a, rot(H)
        assert np.allclose(C[k][:, 0], i) and np.allclose(C[k][:, 1], o)
        assert np.allclose(C[k][:, 2], np.cross(i, o))
        assert np.isclose(np.linalg.det(C[k]), 1.0)
    g = polar.site.gravity_g
    f = polar.specific_force_g("I-H", th)
    # fI = s g sinL, fO = g cosL cos(theta), fS = -s g cosL sin(theta), s = -1
    assert np.allclose(f[:, 0], -g * np.sin(L))
    assert np.allclose(f[:, 1], g * np.cos(L) * np.cos(th))
    assert np.allclose(f[:, 2], g * np.cos(L) * np.sin(th))


def test_motion_protocol_and_drift_free_servo_nulls_input_rate(polar):
    assert isinstance(polar, Motion)
    inp = polar.inputs("I+E", np.linspace(0, 86400, 7))
    assert np.allclose(inp.omega_i[:, 0], 0.0, atol=1e-18)   # w_I + 0 = 0
    assert np.isclose(polar.earth_rate_along_axis, OMEGA)
    vert = ServoTable(Site.at(30.0), "vertical", ("I+N",))
    assert np.isclose(vert.earth_rate_along_axis, OMEGA * 0.5)
    f = vert.specific_force_g("I+N", np.radians([0, 90, 250]))
    assert np.allclose(f[:, 1:], 0.0) and np.allclose(f[:, 0], vert.site.gravity_g)


def test_seed000_drift_harmonics_closed_form(polar):
    # drift = B0 + S1 sin psi + C1 cos psi + S2 sin 2psi + C2 cos 2psi (I+H/I-H: psi = theta)
    c = dict(DF=1.2, DI=0.85, DO=-0.62, DS=0.31, DIO=0.12, DOS=-0.08, DSI=0.05, DII=0.04,
             DOO=-0.03, DSS=0.02)
    L, g = np.radians(45.0), polar.site.gravity_g
    sL, cL = np.sin(L), np.cos(L)
    for m, s in (("I+H", 1), ("I-H", -1)):
        ref = np.array([
            c["DF"] + s * g * sL * c["DI"] + g**2 * sL**2 * c["DII"]
            + g**2 * cL**2 * (c["DOO"] + c["DSS"]) / 2,
            -g * cL * (s * c["DS"] + g * sL * c["DSI"]),
            g * cL * (c["DO"] + s * g * sL * c["DIO"]),
            -s * g**2 * cL**2 * c["DOS"] / 2,
            g**2 * cL**2 * (c["DOO"] - c["DSS"]) / 2,
        ])
        assert np.allclose(polar.drift_harmonics(m, _coeffs(**c)) / K, ref, atol=1e-12)


def test_seed000_servo_angle_matches_closed_form_of_first_harmonic():
    # dtheta/dt = -(A + B cos theta), A = W + DF, B = g cosL DO (I+H): with u = -theta,
    # t(u) = 2/k atan(sqrt((A-B)/(A+B)) tan(u/2)) + n T, k = sqrt(A^2 - B^2), T = 2 pi/k.
    table = ServoTable(Site.at(45.0), "polar", ("I+H",))
    df, do = 40.0, 60.0                        # exaggerated, to make the motion non-uniform
    A = OMEGA + df * K
    B = table.site.gravity_g * np.cos(np.radians(45.0)) * do * K
    t = np.linspace(0.0, 2.2 * 86400, 400)
    theta = table.servo_angle("I+H", t, _coeffs(DF=df, DO=do))
    u = -theta
    k = np.sqrt(A**2 - B**2)
    n = np.round(u / (2 * np.pi))
    t_ref = 2 / k * np.arctan(np.sqrt((A - B) / (A + B)) * np.tan((u - 2 * np.pi * n) / 2))
    t_ref += n * 2 * np.pi / k
    assert np.max(np.abs(t_ref - t)) < 1e-4    # s, over two days
    # and the uniform case: theta = -(W + s DF) t exactly
    th2 = ServoTable(Site.at(45.0), "polar", ("I-H",)).servo_angle("I-H", t, _coeffs(DF=2.0))
    assert np.allclose(th2, -(OMEGA - 2.0 * K) * t, rtol=0, atol=1e-10)


@pytest.mark.parametrize("label, axis, match", [
    ("I+HW", "polar", "left-handed"),
    ("I-NW", "vertical", "left-handed"),
    ("O+H", "polar", "input axis I along it"),
    ("S-E", "vertical", "input axis I along it"),
    ("I+N", "polar", "not normal to the polar"),
    ("I+", "polar", "needs the sign of I and the direction of O"),
])
def test_bad_mounting_labels_one_line(label, axis, match):
    with pytest.raises(InputError, match=match) as exc:
        parse_mounting(label, axis, np.radians(45.0))
    assert "\n" not in str(exc.value)


def test_full_labels_are_accepted_when_right_handed():
    m = parse_mounting("I+HE", "polar", np.radians(45.0))
    assert m.label == "I+H" and m.sign == 1
    assert parse_mounting("I-NE", "vertical", 0.5).sign == -1  # down x N = E
