"""Dividing-head geometry: which instrument axes turn in the vertical plane."""

import numpy as np
import pytest

from inertest.equipment import dividing_head as head
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
