"""Kinematics of the polar-axis table against the seed's specific-force table (issues 2, 14)."""

import numpy as np
import pytest

from inertest.earth import OMEGA_IE, Site
from inertest.equipment import polar_axis_table as table
from inertest.equipment.motion import Motion
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


SEED000_TABLE = {  # fI, fO, fS in units of local gravity (seed 000, sec. 2(5))
    "O-Np": lambda t: (np.cos(L) * np.sin(t), np.sin(L) + 0 * t, np.cos(L) * np.cos(t)),
    "O-Sp": lambda t: (np.cos(L) * np.sin(t), -np.sin(L) + 0 * t, np.cos(L) * np.cos(t)),
    "S-Np": lambda t: (np.cos(L) * np.sin(t), np.cos(L) * np.cos(t), np.sin(L) + 0 * t),
    "S-Sp": lambda t: (np.cos(L) * np.sin(t), np.cos(L) * np.cos(t), -np.sin(L) + 0 * t),
}


def test_seed000_motion_inputs_follow_the_table_with_no_earth_rate_on_i():
    site = Site.at(np.degrees(L), 9.79)
    angles = np.degrees(TH)
    m = table.motion(table.MOUNTINGS, angles, site)
    assert isinstance(m, Motion) and len(m.segments) == 4 * TH.size
    assert m.segments[:3] == ("O-Np@0", "O-Np@15", "O-Np@30") and m.segments[-1] == "S-Sp@345"
    for mounting, expected in SEED000_TABLE.items():
        rows = m.inputs_of_rows(table.position_labels(mounting, angles))
        np.testing.assert_allclose(rows.f_i, np.column_stack(expected(TH)) * 9.79, atol=1e-13)
        np.testing.assert_allclose(np.linalg.norm(rows.f_i, axis=1), 9.79, rtol=1e-15)
        assert np.max(np.abs(rows.omega_i[:, 0])) < 1e-18  # I stays in the equatorial plane
        np.testing.assert_allclose(np.linalg.norm(rows.omega_i, axis=1), OMEGA_IE, rtol=1e-15)
        # the same as the module's own functions
        np.testing.assert_allclose(rows.f_i / 9.80665,
                                   table.specific_force_ios(mounting, TH, L, 9.79), atol=1e-15)
        np.testing.assert_allclose(rows.C_ni.transpose(0, 2, 1),
                                   table.instrument_axes_enu(mounting, TH, L), atol=1e-15)


def test_position_labels_wrap_and_one_reading_of_a_position_per_label():
    labels = table.position_labels(["O-Np", "S-Sp", "O-Np"], [360.0, -22.5, 1 / 3])
    assert labels.tolist() == ["O-Np@0", "S-Sp@337.5", "O-Np@0.333333333"]
    with pytest.raises(InputError, match="O-Np"):
        table.motion(["O-Up"], [0.0], Site.at(30.0))
