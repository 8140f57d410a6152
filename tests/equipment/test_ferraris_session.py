"""Ferraris session kinematics: face specific force, sampled turn profile."""

import numpy as np
import pytest

from inertest.equipment import ferraris_session as fs
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
