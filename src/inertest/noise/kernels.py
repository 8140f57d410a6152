"""Fused numba kernels: sums of squared phase differences, one pass, no temporaries.

Each kernel receives *windows* of the phase record (views of one array in memory, or buffers
read from a file by :mod:`inertest.noise.streaming`), so the in-memory and the streaming paths
run the same arithmetic in the same order and give the same result.
"""

from __future__ import annotations

import numba
from numpy.typing import NDArray

# fastmath lets LLVM vectorise the sums of squares (reassociation only); the inputs are checked
# finite before any kernel runs, so its no-NaN assumption holds.


@numba.njit(cache=True, nogil=True, fastmath=True)
def _ssq2(x0: NDArray, x1: NDArray, x2: NDArray) -> float:
    s = 0.0
    for i in range(x0.shape[0]):
        d = x2[i] - 2.0 * x1[i] + x0[i]
        s += d * d
    return s


@numba.njit(cache=True, nogil=True, fastmath=True)
def _ssq3(x0: NDArray, x1: NDArray, x2: NDArray, x3: NDArray) -> float:
    s = 0.0
    for i in range(x0.shape[0]):
        d = x3[i] - 3.0 * x2[i] + 3.0 * x1[i] - x0[i]
        s += d * d
    return s


@numba.njit(cache=True, nogil=True)
def sum_second_diff(x0: NDArray, x1: NDArray, x2: NDArray, stride: int) -> float:
    """Sum of ``(x2[i] - 2 x1[i] + x0[i])**2`` for ``i = 0, stride, 2 stride, ...`` (Allan)."""
    if stride == 1:
        return _ssq2(x0, x1, x2)
    s = 0.0
    n = x0.shape[0]
    for i in range(0, n, stride):
        d = x2[i] - 2.0 * x1[i] + x0[i]
        s += d * d
    return s


@numba.njit(cache=True, nogil=True)
def sum_third_diff(x0: NDArray, x1: NDArray, x2: NDArray, x3: NDArray, stride: int) -> float:
    """Sum of ``(x3[i] - 3 x2[i] + 3 x1[i] - x0[i])**2`` for ``i = 0, stride, ...`` (Hadamard)."""
    if stride == 1:
        return _ssq3(x0, x1, x2, x3)
    s = 0.0
    n = x0.shape[0]
    for i in range(0, n, stride):
        d = x3[i] - 3.0 * x2[i] + 3.0 * x1[i] - x0[i]
        s += d * d
    return s


@numba.njit(cache=True, nogil=True)
def integrate(y: NDArray, mean: float, start: float, tau0: float, out: NDArray) -> float:
    """Phase from rates: ``c_0 = start, c_{k+1} = c_k + (y_k - mean)``, ``out[k] = tau0 c_k``.

    ``out`` has ``len(y) + 1`` elements; returns the final running sum. The sum runs strictly
    in sample order, so a record integrated in pieces from checkpoints gives the same digits.
    """
    c = start
    out[0] = tau0 * c
    for k in range(y.shape[0]):
        c += y[k] - mean
        out[k + 1] = tau0 * c
    return c


@numba.njit(cache=True, nogil=True)
def second_diff_sum(x0: NDArray, x1: NDArray, x2: NDArray) -> float:
    """Plain sum of ``x2[i] - 2 x1[i] + x0[i]`` (start value of the modified-Allan window)."""
    s = 0.0
    for i in range(x0.shape[0]):
        s += x2[i] - 2.0 * x1[i] + x0[i]
    return s


@numba.njit(cache=True, nogil=True)
def sum_modified(
    x0: NDArray, x1: NDArray, x2: NDArray, x3: NDArray, window: float, count: int
) -> tuple[float, float]:
    """Sum of squared sliding window sums of second differences (modified Allan).

    With ``d[j] = x[j+2m] - 2 x[j+m] + x[j]`` and ``s_j = sum_{i=j}^{j+m-1} d[i]``, the windows are
    ``x0 = x[j]``, ``x1 = x[j+m]``, ``x2 = x[j+2m]``, ``x3 = x[j+3m]`` for ``count`` values of j.
    ``window`` is ``s_j`` at the first j; returns (sum of s_j**2, s after the last step) so that
    the next chunk continues the recursion ``s_{j+1} = s_j + d[j+m] - d[j]``.
    """
    # Neumaier-compensated running sum: the window sum is updated 1e7 times and must not drift.
    s = window
    c = 0.0
    acc = 0.0
    for j in range(count):
        w = s + c
        acc += w * w
        step = (x3[j] - 2.0 * x2[j] + x1[j]) - (x2[j] - 2.0 * x1[j] + x0[j])
        t = s + step
        if abs(s) >= abs(step):
            c += (s - t) + step
        else:
            c += (step - t) + s
        s = t
    return acc, s + c
