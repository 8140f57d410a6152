"""The motion protocol: a fixture holding an instrument still (closed forms of the 1 g field)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from inertest.earth import Site
from inertest.equipment.motion import Motion, StaticPositions
from inertest.errors import InputError

W_IE = 7.2921151467e-5  # WGS-84 [rad/s]


def test_static_positions_closed_form():
    site = Site.at(45.0, 9.80)
    c_up = np.eye(3)
    c_tilt = Rotation.from_euler("x", 90, degrees=True).as_matrix()  # y -> up, z -> south
    m = StaticPositions({"level": c_up, "tilted": c_tilt}, site)
    assert isinstance(m, Motion) and m.segments == ("level", "tilted")
    a = m.inputs("level", np.zeros(4))
    assert a.n == 4
    np.testing.assert_allclose(a.f_i, np.tile([0, 0, 9.80], (4, 1)), atol=1e-15)
    wn = W_IE * np.array([0, np.cos(np.pi / 4), np.sin(np.pi / 4)])
    np.testing.assert_allclose(a.omega_i[0], wn, atol=1e-18)
    b = m.inputs("tilted")
    # Rotating the body +90 deg about x: body y is up, body z is south.
    np.testing.assert_allclose(b.f_i[0], [0, 9.80, 0], atol=1e-12)
    np.testing.assert_allclose(b.omega_i[0], [0, wn[2], -wn[1]], atol=1e-18)
    rows = m.inputs_of_rows(["tilted", "level", "tilted"])
    np.testing.assert_allclose(rows.f_i[[0, 2]], np.tile(b.f_i[0], (2, 1)))
    np.testing.assert_allclose(rows.f_i[1], a.f_i[0])


def test_bad_attitudes_and_labels():
    site = Site.at(30.0)
    with pytest.raises(InputError, match="left-handed"):
        StaticPositions({"mirror": np.diag([1.0, 1.0, -1.0])}, site)
    with pytest.raises(InputError, match="not a rotation"):
        StaticPositions({"scaled": 2 * np.eye(3)}, site)
    with pytest.raises(InputError, match="unknown position"):
        StaticPositions({"a": np.eye(3)}, site).inputs("b")
