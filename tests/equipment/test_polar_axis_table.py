"""Kinematics of the polar-axis table against the seed's specific-force table (issue 2)."""

import numpy as np
import pytest

from inertest.equipment import polar_axis_table as table
from inertest.errors import InputError

L = np.radians(34.246)
TH = np.radians(np.arange(0, 360, 15.0))


@pytest.mark.parametrize(
    "mounting, expected",
    [
        ("O-Np", lambda t: (np.cos(L) * np.sin(t), np.sin(L) + 0 * t, np.cos(L) * np.cos(t))),
        ("O-Sp", lambda t: (np.cos(L) * np.sin(t), -np.sin(L) + 0 * t, np.cos(L) * np.cos(t))),
        ("S-Np", lambda t: (np.cos(L) * np.sin(t), np.cos(L) * np.cos(t), np.sin(L) + 0 * t)),
        ("S-Sp", lambda t: (np.cos(L) * np.sin(t), np.cos(L) * np.cos(t), -np.sin(L) + 0 * t)),
    ],
)
def test_seed000_specific_force_table(mounting, expected):
    g = 9.79
    f = table.specific_force_ios(mounting, TH, L, g)
    np.testing.assert_allclose(f, np.column_stack(expected(TH)) * g / 9.80665, atol=1e-15)


@pytest.mark.parametrize("mounting", table.MOUNTINGS)
def test_axes_are_a_right_handed_triad_and_i_never_senses_earth_rate(mounting):
    axes = table.instrument_axes_enu(mounting, TH, L)
    for a in axes:
        np.testing.assert_allclose(a @ a.T, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(np.cross(a[0], a[1]), a[2], atol=1e-14)
    assert np.max(np.abs(table.input_rate(mounting, TH, L))) < 1e-18


def test_unknown_mounting():
    with pytest.raises(InputError, match="O-Np"):
        table.instrument_axes_enu("O-Up", TH, L)
