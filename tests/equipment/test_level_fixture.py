import numpy as np
import pytest

from inertest.earth import OMEGA_IE
from inertest.equipment import level_fixture as fx
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
