"""Automatic detection of the static intervals of a hand-held multi-position recording.

The detector of Tedaldi, Pretto and Menegatti, "A robust and easy to implement method for IMU
calibration without external equipments", ICRA 2014, pp. 3042-3049,
doi:10.1109/ICRA.2014.6907297 (Sec. III-C, "static detector"): for every sample t the
*variance magnitude* of the accelerometer readings in a window of ``w`` samples centred on t,

    varsigma(t) = sqrt( var_w(a_x)^2 + var_w(a_y)^2 + var_w(a_z)^2 )     [raw unit^2]

is compared with a threshold ``k varsigma_init``, where ``varsigma_init`` is the same
magnitude over the whole initial static period ``T_init`` (the IMU left still at the start of
the recording) and ``k`` a user factor (Tedaldi try k = 2..10; imu_tk's default window is 101
samples). Runs of samples with ``varsigma(t) < k varsigma_init`` are static intervals; runs
shorter than a minimum duration (Tedaldi's ``t_wait``, 1-4 s) are dropped.

A window centred on t is quiet only when all its samples are, so every interval found is the
true still period shortened by half a window at each end: its samples are clean of the motion.
The initial static period is itself the first interval when the IMU was still.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError, InputError


@dataclass(frozen=True)
class StaticDetection:
    """Static intervals of a recording and how they were found.

    Attributes
    ----------
    intervals : ndarray of int, shape (m, 2)
        ``[start, end)`` sample indices of each static interval, in time order.
    variance_magnitude : ndarray, shape (n,)
        ``varsigma(t)`` [raw unit^2] (NaN within half a window of the ends).
    init_variance_magnitude : float
        ``varsigma_init`` over the initial static period [raw unit^2].
    threshold : float
        ``k varsigma_init`` [raw unit^2].
    threshold_factor : float
        ``k`` [1].
    window : int
        Window length [samples] (odd).
    n_init : int
        Samples of the initial static period.
    n_short : int
        Quiet runs dropped for being shorter than the minimum duration.
    """

    intervals: NDArray[np.intp]
    variance_magnitude: NDArray[np.float64]
    init_variance_magnitude: float
    threshold: float
    threshold_factor: float
    window: int
    n_init: int
    n_short: int

    @property
    def count(self) -> int:
        """Number of static intervals."""
        return int(self.intervals.shape[0])


def moving_variance(x: ArrayLike, window: int) -> NDArray[np.float64]:
    """Variance (ddof 1) of each column of ``x`` over a centred window of ``window`` samples.

    Parameters
    ----------
    x : array_like, shape (n, k)
    window : int
        Odd number of samples >= 3.

    Returns
    -------
    ndarray, shape (n, k)
        NaN where the window does not fit (the first and last ``window // 2`` samples).
    """
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    n = a.shape[0]
    out = np.full(a.shape, np.nan)
    if window < 3 or window % 2 == 0:
        raise InputError(f"window must be an odd number of samples >= 3, got {window}")
    if n < window:
        return out
    c = a - a.mean(axis=0)  # centred: the running sums keep their precision (counts ~ 3e4)
    s1 = np.vstack([np.zeros((1, a.shape[1])), np.cumsum(c, axis=0)])
    s2 = np.vstack([np.zeros((1, a.shape[1])), np.cumsum(c * c, axis=0)])
    h = window // 2
    sum1 = s1[window:] - s1[:-window]
    sum2 = s2[window:] - s2[:-window]
    var = (sum2 - sum1 * sum1 / window) / (window - 1)
    out[h:n - h] = np.clip(var, 0.0, None)
    return out


def variance_magnitude(acc: ArrayLike, window: int) -> NDArray[np.float64]:
    """Tedaldi's ``varsigma(t)``: norm of the three moving variances [raw unit^2], shape (n,)."""
    return np.asarray(np.linalg.norm(moving_variance(acc, window), axis=1), dtype=float)


def detect_static_intervals(
    acc: ArrayLike,
    *,
    sample_rate_hz: float,
    init_duration_s: float,
    threshold_factor: float,
    window_s: float = 1.0,
    min_duration_s: float = 1.0,
) -> StaticDetection:
    """Static intervals of an accelerometer recording (Tedaldi et al. 2014, Sec. III-C).

    Parameters
    ----------
    acc : array_like, shape (n, 3)
        Accelerometer readings, any unit (raw counts), in time order at ``sample_rate_hz``.
    sample_rate_hz : float
        [Hz].
    init_duration_s : float
        Length of the initial static period ``T_init`` [s] (Tedaldi: about 50 s).
    threshold_factor : float
        ``k`` of the threshold ``k varsigma_init`` [1] (Tedaldi try 2..10).
    window_s : float
        Length of the centred variance window [s] (rounded to an odd number of samples >= 3).
    min_duration_s : float
        Shortest static interval kept [s].

    Returns
    -------
    StaticDetection

    Raises
    ------
    DataError
        When the recording is shorter than the initial period or the initial period is not
        still (its own windows exceed the threshold).
    """
    a = np.asarray(acc, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"accelerometer readings must have shape (n, 3), got {a.shape}")
    for name, v in (("sample_rate_hz", sample_rate_hz), ("init_duration_s", init_duration_s),
                    ("threshold_factor", threshold_factor), ("window_s", window_s)):
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"{name} must be positive, got {v!r}")
    window = max(3, int(round(window_s * sample_rate_hz)) | 1)
    n_init = int(round(init_duration_s * sample_rate_hz))
    n = a.shape[0]
    if n_init < window or n_init > n:
        raise DataError(
            f"the initial static period of {init_duration_s:g} s ({n_init} samples) must be "
            f"longer than the {window}-sample window and fit in the {n}-sample recording; set "
            "init_duration_s to the time the IMU was left still at the start")
    init_var = np.var(a[:n_init], axis=0, ddof=1)
    init_mag = float(np.linalg.norm(init_var))
    if init_mag == 0:
        init_mag = float(np.finfo(float).tiny)  # quantised noise-free data: any motion counts
    threshold = threshold_factor * init_mag
    mag = variance_magnitude(a, window)
    quiet = np.nan_to_num(mag, nan=np.inf) < threshold
    edges = np.diff(np.r_[0, quiet.astype(np.int8), 0])
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    n_min = max(1, int(round(min_duration_s * sample_rate_hz)))
    keep = (ends - starts) >= n_min
    if not np.any(quiet[window // 2: n_init - window // 2]):
        raise DataError(
            f"the first {init_duration_s:g} s are not still: no window in them is below "
            f"threshold_factor x their variance; leave the IMU still for init_duration_s at "
            "the start, or shorten init_duration_s to the still part")
    intervals = np.column_stack([starts[keep], ends[keep]]).astype(np.intp)
    return StaticDetection(
        intervals=intervals.reshape(-1, 2), variance_magnitude=mag,
        init_variance_magnitude=init_mag, threshold=float(threshold),
        threshold_factor=float(threshold_factor), window=window, n_init=n_init,
        n_short=int(np.count_nonzero(~keep)),
    )
