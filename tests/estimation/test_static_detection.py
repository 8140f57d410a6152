"""Tedaldi's static detector: moving variance against numpy, intervals of a synthetic record."""

from __future__ import annotations

import numpy as np
import pytest

from inertest.errors import DataError, InputError
from inertest.estimation.static_detection import (
    detect_static_intervals,
    moving_variance,
    variance_magnitude,
)


def test_moving_variance_equals_numpy_on_each_window():
    rng = np.random.default_rng(1)
    x = rng.normal(3e4, 5.0, (200, 3))  # raw counts far from zero: precision of running sums
    got = moving_variance(x, 11)
    for i in (5, 50, 194):
        np.testing.assert_allclose(got[i], np.var(x[i - 5:i + 6], axis=0, ddof=1), rtol=1e-9)
    assert np.all(np.isnan(got[:5])) and np.all(np.isnan(got[-5:]))
    np.testing.assert_allclose(variance_magnitude(x, 11)[50],
                               np.linalg.norm(np.var(x[45:56], axis=0, ddof=1)))


def _record(rng, fs=100.0):
    """Still 20 s, then 2 s moving / 3 s still, five times; true still periods returned."""
    parts, still, t = [], [], 0
    for n_still, n_move in ((2000, 200), (300, 200), (300, 200), (80, 200), (300, 200),
                            (300, 0)):
        parts.append(np.tile([0.0, 0.0, 9.8], (n_still, 1)))
        still.append((t, t + n_still))
        t += n_still
        if n_move:
            tau = np.arange(n_move) / n_move
            parts.append(np.outer(np.sin(np.pi * tau) ** 2, [3.0, -2.0, 1.0]) + [0, 0, 9.8])
            t += n_move
    acc = np.vstack(parts) + rng.normal(0.0, 0.01, (t, 3))
    return acc, still


def test_intervals_found_inside_the_true_still_periods():
    acc, still = _record(np.random.default_rng(2))
    det = detect_static_intervals(acc, sample_rate_hz=100.0, init_duration_s=20.0,
                                  threshold_factor=6.0, window_s=0.5, min_duration_s=1.0)
    # the 0.8 s still period is shorter than min_duration_s: dropped
    assert det.count == 5 and det.n_short >= 1
    long_still = [s for s in still if s[1] - s[0] >= 100]
    h = det.window // 2
    for (a, b), (s0, s1) in zip(det.intervals, long_still, strict=True):
        assert s0 <= a <= s0 + h + 5 and s1 - h - 5 <= b <= s1  # shrunk by about half a window
    assert det.threshold == pytest.approx(6.0 * det.init_variance_magnitude)


def test_bad_inputs_are_named():
    acc, _ = _record(np.random.default_rng(3))
    with pytest.raises(DataError, match="init_duration_s"):
        detect_static_intervals(acc, sample_rate_hz=100.0, init_duration_s=1e4,
                                threshold_factor=6.0)
    moving_first = acc[2000:]
    with pytest.raises(DataError, match="not still"):
        detect_static_intervals(moving_first, sample_rate_hz=100.0, init_duration_s=2.0,
                                threshold_factor=0.01)
    with pytest.raises(InputError, match="shape"):
        detect_static_intervals(acc[:, :2], sample_rate_hz=100.0, init_duration_s=5.0,
                                threshold_factor=6.0)
