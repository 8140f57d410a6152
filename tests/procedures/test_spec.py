"""Input checks shared by the procedures (procedures/spec.py): time columns and noise levels."""

from __future__ import annotations

import numpy as np
import pytest

from inertest.errors import DataError, PlanError
from inertest.procedures.spec import check_sample_rate, known_sigma


def _segments(reverse: bool) -> dict[str, np.ndarray]:
    """Six segments of 200 readings at 200 Hz, each restarting its clock at 0."""
    t = np.tile(np.arange(200) / 200.0, 6)
    if reverse:
        t = np.concatenate([seg[::-1] for seg in np.split(t, 6)])
    return {"t_s": t}


def test_a_clock_restarting_per_segment_passes():
    check_sample_rate(_segments(reverse=False), 200.0)


@pytest.mark.parametrize("reverse_all", [False, True])
def test_a_time_column_running_backwards_is_named_as_such(reverse_all):
    """Issue 34: reversed segments were reported as a wrong sample rate (their restarts,
    9.995 s apart, were the only positive steps)."""
    data = _segments(reverse=True)
    if reverse_all:
        data = {"t_s": np.arange(1200)[::-1] / 200.0}
    with pytest.raises(DataError, match=r"time column 't_s' runs backwards \(\d+ of 1199 steps "
                       r"are negative, the first at data row 2\); sort the rows by time"):
        check_sample_rate(data, 200.0)


def test_a_wrong_rate_is_still_a_wrong_rate():
    with pytest.raises(DataError, match="sample_rate_hz = 20 Hz, but the time column"):
        check_sample_rate(_segments(reverse=False), 20.0)


@pytest.mark.parametrize("sigma, what", [(1e300, "large"), (1e-300, "small")])
def test_a_noise_level_whose_square_overflows_is_refused(sigma, what):
    """Issue 34: sigma = 1e300 ended in an OverflowError (internal error) in the fit."""
    with pytest.raises(PlanError, match=f"too {what} to compute with"):
        known_sigma(sigma, 1.0)
    assert known_sigma(2e-3, 0.5) == 1e-3
