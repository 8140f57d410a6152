"""Level fixture: positions along the local directions (seed 000, ch. 3, sec. 3), as a motion."""

import numpy as np
import pytest

from inertest.earth import OMEGA_IE, Site
from inertest.equipment import level_fixture as fx
from inertest.equipment.motion import Motion
from inertest.errors import InputError


def test_24_positions_distinct_right_handed():
    pos = fx.all_positions()
    assert len(set(pos)) == 24
    for p in pos:
        a = fx.axes_from_directions(*p)
        assert np.linalg.det(a) == pytest.approx(1.0)


def test_earth_rate_on_input_axis():
    lat = np.radians(40.0)
    axes = np.stack([fx.axes_from_directions(*p) for p in [("N", "U", "E"), ("U", "N", "W"),
                                                             ("E", "N", "U"), ("S", "D", "E")]])
    np.testing.assert_allclose(
        fx.input_rate(axes, lat),
        [OMEGA_IE * np.cos(lat), OMEGA_IE * np.sin(lat), 0.0, -OMEGA_IE * np.cos(lat)],
        atol=1e-20,
    )


def test_bad_positions_named():
    with pytest.raises(InputError, match="left-handed.*S must be D"):
        fx.axes_from_directions("W", "N", "U")
    with pytest.raises(InputError, match="not an orthogonal triad"):
        fx.axes_from_directions("N", "S", "U")
    with pytest.raises(InputError, match='"X" is not one of'):
        fx.axes_from_directions("X", "N", "U")


def test_seed000_motion_one_axis_vertical_and_earth_rate_on_i():
    """Each position puts +-g on its vertical axis only; I feels W (0, cos L, sin L) . I."""
    lat = 40.0
    site = Site.at(lat, 9.80)
    L = np.radians(lat)
    m = fx.motion(["UNW", ("N", "U", "E"), "S D E", ["e", "n", "u"]], site)
    assert isinstance(m, Motion) and m.segments == ("U N W", "N U E", "S D E", "E N U")
    rows = m.inputs_of_rows(["S D E", "U N W", "E N U", "N U E", "U N W"])
    np.testing.assert_allclose(rows.f_i, [[0, -9.8, 0], [9.8, 0, 0], [0, 0, 9.8], [0, 9.8, 0],
                                          [9.8, 0, 0]], atol=1e-15)
    w_i = OMEGA_IE * np.array([-np.cos(L), np.sin(L), 0.0, np.cos(L), np.sin(L)])
    np.testing.assert_allclose(rows.omega_i[:, 0], w_i, atol=1e-20)
    np.testing.assert_allclose(np.linalg.norm(rows.omega_i, axis=1), OMEGA_IE, rtol=1e-15)
    # the same as the module's own functions
    axes = np.stack([fx.axes_from_directions(*p.split()) for p in m.segments])
    ins = m.inputs_of_rows(list(m.segments))
    np.testing.assert_allclose(ins.f_i / 9.80665, fx.specific_force_ios(axes, 9.80), atol=1e-16)
    np.testing.assert_allclose(ins.omega_i[:, 0], fx.input_rate(axes, L), atol=1e-20)


def test_motion_labels_and_bad_positions():
    labels = fx.position_labels(["u", "N"], ["n", "U"], ["W", "e"])
    assert labels.tolist() == ["U N W", "N U E"]
    with pytest.raises(InputError, match="left-handed"):
        fx.motion(["WNU"], Site.at(30.0))
    with pytest.raises(InputError, match="three directions"):
        fx.motion(["UN"], Site.at(30.0))
