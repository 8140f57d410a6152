"""Multi-position orientation sets: 6 axis up/down, 12 cube-edge, 24 cube rotations."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from inertest.equipment import multiposition as mp
from inertest.errors import InputError


def test_six_positions_are_each_axis_up_and_down():
    f = mp.specific_force_body(mp.SIX, 1.0)
    np.testing.assert_allclose(f, [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1],
                                   [0, 0, -1]], atol=1e-15)


def test_twelve_positions_are_the_cube_edge_directions():
    f = mp.specific_force_body(mp.TWELVE, 1.0)
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
    ("UEX", "not of the form"), ("UUN", "three different axes"), ("UNE", "left-handed"),
    ("UEN/q+4", "not of the form")])
def test_bad_labels(label, message):
    with pytest.raises(InputError, match=message):
        mp.attitude(label)


def test_unknown_scheme():
    with pytest.raises(InputError, match='unknown multi-position scheme "7"'):
        mp.scheme_positions("7")
