"""PHASE.DAT against Stable32 1.60: noise type, term count, deviation and 68.3 % bounds.

Reference: ../shared/realdata/stable32 (PHASE.DAT and Stable32's octave tables for every
statistic, published with allantools' tests). Stable32 prints five significant digits.
Achieved on every row: alpha and N equal; deviation within 5e-5 (rounding of the print);
bounds within 1e-3 relative (largest seen 4e-4: Greenhall's EDF vs Stable32's, through the
chi-squared quantiles).
"""

from __future__ import annotations

import numpy as np
import pytest

from inertest.noise.deviations import deviations

STATS = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")


def _stable32(realdata_dir, stat):
    rows = np.loadtxt(realdata_dir / "stable32" / f"phase_dat_{stat}_octave.txt", comments="#")
    phase = np.loadtxt(realdata_dir / "stable32" / "PHASE.DAT", comments="#")
    return rows, phase


def _check(realdata_dir, stat):
    rows, phase = _stable32(realdata_dir, stat)
    assert phase.size == 1001
    af = rows[:, 0].astype(int)
    res = deviations(phase, 1.0, [stat], af.astype(float), "angle")[stat]
    np.testing.assert_array_equal(res.taus, rows[:, 1])
    np.testing.assert_array_equal(res.n, rows[:, 2].astype(int))
    np.testing.assert_array_equal(res.alpha, rows[:, 3].astype(int))
    np.testing.assert_allclose(res.dev, rows[:, 5], rtol=5e-5, atol=0)
    np.testing.assert_allclose(res.dev_lo, rows[:, 4], rtol=1e-3, atol=0)
    np.testing.assert_allclose(res.dev_hi, rows[:, 6], rtol=1e-3, atol=0)


def test_stable32_phase_dat_adev(realdata_dir):
    _check(realdata_dir, "adev")


def test_stable32_phase_dat_oadev(realdata_dir):
    _check(realdata_dir, "oadev")


def test_stable32_phase_dat_mdev(realdata_dir):
    _check(realdata_dir, "mdev")


def test_stable32_phase_dat_tdev(realdata_dir):
    _check(realdata_dir, "tdev")


def test_stable32_phase_dat_hdev(realdata_dir):
    _check(realdata_dir, "hdev")


def test_stable32_phase_dat_ohdev(realdata_dir):
    _check(realdata_dir, "ohdev")


def test_stable32_phase_dat_totdev(realdata_dir):
    _check(realdata_dir, "totdev")


@pytest.mark.parametrize("stat", STATS)
def test_stable32_phase_dat_rate_input_same(realdata_dir, stat):
    """The same record given as rates (first differences of the phase) gives the same rows."""
    rows, phase = _stable32(realdata_dir, stat)
    res = deviations(np.diff(phase), 1.0, [stat], rows[:, 1])[stat]
    np.testing.assert_array_equal(res.alpha, rows[:, 3].astype(int))
    np.testing.assert_allclose(res.dev_hi, rows[:, 6], rtol=1e-3, atol=0)
