"""Dividing-head geometry: which instrument axes turn in the vertical plane."""

import numpy as np
import pytest

from inertest.earth import OMEGA_IE, Site
from inertest.equipment import dividing_head as head
from inertest.equipment.motion import Motion
from inertest.errors import InputError


@pytest.mark.parametrize("mounting, still", [("IA-PA", 2), ("IA-OA", 1), ("PA-OA", 0)])
def test_axis_along_head_axis_feels_no_gravity(mounting, still):
    t = head.equally_spaced(16)
    a = head.specific_force(mounting, t, 0.998)
    np.testing.assert_array_equal(a[:, still], 0.0)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 0.998, rtol=1e-15)


def test_angle_zero_first_axis_up_and_90_second_axis_up():
    a = head.specific_force(["IA-PA", "IA-PA", "IA-OA", "PA-OA"], [0, 90, 90, 180], 1.0)
    np.testing.assert_allclose(a, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0]], atol=1e-15)


def test_equally_spaced_and_bad_mounting():
    np.testing.assert_allclose(head.equally_spaced(8), np.arange(0, 360, 45))
    assert head.check_mounting(" ia-pa ") == "IA-PA"
    with pytest.raises(InputError, match='unknown dividing-head mounting "IA-SA"'):
        head.specific_force("IA-SA", [0.0], 1.0)
    with pytest.raises(InputError, match="positive"):
        head.equally_spaced(0)


@pytest.mark.parametrize("mounting", head.MOUNTINGS)
def test_motion_specific_force_is_the_module_closed_form(mounting):
    site = Site.at(34.0, 9.7962)
    angles = head.equally_spaced(24)
    m = head.motion([mounting], angles, site)
    assert isinstance(m, Motion) and m.segments[1] == f"{mounting}@15"
    rows = m.inputs_of_rows(head.position_labels(mounting, angles))
    np.testing.assert_allclose(rows.f_i / 9.80665,
                               head.specific_force(mounting, angles, site.gravity_g), atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(rows.f_i, axis=1), 9.7962, rtol=1e-15)
    for c in rows.C_ni:  # (IA, PA, OA) right-handed: OA = IA x PA
        np.testing.assert_allclose(np.cross(c[:, 0], c[:, 1]), c[:, 2], atol=1e-15)


def test_motion_earth_rate_follows_the_head_azimuth():
    """IA up, head axis (OA) north: W sin L on IA, W cos L on OA; head axis east: none on OA."""
    L = np.radians(34.0)
    site = Site.at(34.0)
    w = head.motion(["IA-PA"], [0.0], site).inputs("IA-PA@0").omega_i[0]
    np.testing.assert_allclose(w, OMEGA_IE * np.array([np.sin(L), 0.0, np.cos(L)]), atol=1e-19)
    east = head.motion(["IA-PA"], [0.0], site, head_azimuth_deg=90.0).inputs("IA-PA@0")
    np.testing.assert_allclose(east.C_ni[0][:, 2], [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(east.omega_i[0], OMEGA_IE * np.array([np.sin(L), -np.cos(L), 0.0]),
                               atol=1e-19)
    assert head.position_labels([" ia-oa", "PA-OA"], [-90.0, 720.0]).tolist() == [
        "IA-OA@270", "PA-OA@0"]
