"""Multi-position orientation sets: 6 axis up/down, 12 cube-edge, 24 cube rotations."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from inertest.earth import OMEGA_IE, Site
from inertest.equipment import multiposition as mp
from inertest.equipment.motion import Motion
from inertest.errors import InputError


def test_six_positions_are_each_axis_up_and_down():
    f = mp.attitudes(mp.SIX)[:, 2, :]  # up on the body axes
    np.testing.assert_allclose(f, [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1],
                                   [0, 0, -1]], atol=1e-15)


def test_twelve_positions_are_the_cube_edge_directions():
    f = mp.attitudes(mp.TWELVE)[:, 2, :]
    edges = {tuple(v) for v in np.array(
        [[s1, s2, 0] for s1 in (1, -1) for s2 in (1, -1)]
        + [[s1, 0, s2] for s1 in (1, -1) for s2 in (1, -1)]
        + [[0, s1, s2] for s1 in (1, -1) for s2 in (1, -1)])}
    got = {tuple(np.round(v * np.sqrt(2)).astype(int)) for v in f}
    assert got == edges
    np.testing.assert_allclose(f.T @ f, 4 * np.eye(3), atol=1e-14)
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-14)


def test_tilt_is_a_right_handed_turn_about_the_body_axis():
    C = mp.attitude("ENU/x+30")  # z up, turned +30 deg about x: y rises
    np.testing.assert_allclose(C, Rotation.from_euler("x", 30, degrees=True).as_matrix(),
                               atol=1e-15)


def test_24_positions_are_the_proper_cube_rotations():
    C = mp.attitudes(mp.scheme_positions("24"))
    assert len({tuple(np.round(c, 6).ravel()) for c in C}) == 24
    np.testing.assert_allclose(np.linalg.det(C), 1.0)


@pytest.mark.parametrize("label, message", [
    ("UEX", "not of the form"), ("UUN", "must point along different axes"), ("UNE", "left-handed"),
    ("UEN/q+4", "not of the form")])
def test_bad_labels(label, message):
    with pytest.raises(InputError, match=message):
        mp.attitude(label)


def test_unknown_scheme():
    with pytest.raises(InputError, match='unknown multi-position scheme "7"'):
        mp.scheme_positions("7")


def test_motion_static_positions_match_the_specific_force_and_earth_rate():
    """|omega_i| = W_ie, |f_i| = g, f_i = C^T (0, 0, g) of each label (closed forms)."""
    site = Site.at(45.0)
    labels = ["UEN", "DWN", "UEN", "NUE/x+45"]
    m = mp.motion(labels, site)
    assert isinstance(m, Motion)
    assert m.segments == ("UEN", "DWN", "NUE/x+45")
    inp = m.inputs_of_rows(labels)
    np.testing.assert_allclose(np.linalg.norm(inp.omega_i, axis=1), OMEGA_IE, rtol=1e-14)
    np.testing.assert_allclose(inp.f_i[:2], [[site.gravity_m_s2, 0, 0],
                                             [-site.gravity_m_s2, 0, 0]], atol=1e-15)
    s = np.sqrt(0.5) * site.gravity_m_s2  # NUE/x+45: up is between y and -z... by hand:
    # NUE: x north, y up, z east; +45 deg about x turns y towards z, so up = (0, c, -s) in body.
    np.testing.assert_allclose(inp.f_i[3], [0.0, s, -s], atol=1e-12)
    # Earth rate on the x-up position: x feels W sin L, y (east) nothing, z (north) W cos L.
    lat = site.latitude_rad
    np.testing.assert_allclose(inp.omega_i[0], OMEGA_IE * np.array([np.sin(lat), 0, np.cos(lat)]),
                               atol=1e-19)
