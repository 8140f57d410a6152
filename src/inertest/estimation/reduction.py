"""Data reduction before the fit: grouping samples into runs and averaging over whole cycles.

A *run* is the set of samples that share the values of one or more key columns (e.g. a test
position and a rate); :func:`group_rows` finds the runs of per-sample columns. A *periodic motion*
of angular frequency ``omega`` [rad/s] (a centrifuge arm, a rotating table, a vibrating shaker)
has cycles of period ``2 pi / |omega|``; :func:`whole_cycle_mask` keeps the samples of a run that
lie in whole cycles, and :func:`whole_cycle_weights` gives averaging weights over them that make
the weighted mean of the motion's low harmonics exactly zero, as the integral over whole cycles
is. Output and regressors averaged with the same weights keep a linear model exact.

Whole-cycle integration: Sun, Ren & Wang (seed ``004_f16e7c07e7c35fdc.txt``), eqs. 18-22.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import DataError, InputError

#: Fraction of a cycle within which a sample counts as lying *on* a cycle boundary (absorbs the
#: rounding of ``t`` and ``omega`` in a data file; 1e-9 cycle ~ 1.4 ns at 4.43 rad/s).
BOUNDARY_TOLERANCE_CYCLES = 1e-9


@dataclass(frozen=True)
class RowGroups:
    """Runs of per-sample columns: the rows sharing one combination of key values.

    Attributes
    ----------
    keys : tuple of ndarray, each shape (m,)
        The key values of each run, one array per key column (in the keys' own dtypes), runs
        sorted by the first key, then the second, ...
    order : ndarray of int, shape (n,)
        Row indices sorted by run (stable: the rows of a run keep their original order).
    bounds : ndarray of int, shape (m + 1,)
        The rows of run ``r`` are ``order[bounds[r]:bounds[r + 1]]``.
    """

    keys: tuple[NDArray, ...]
    order: NDArray[np.intp]
    bounds: NDArray[np.intp]

    def __len__(self) -> int:
        """Number of runs ``m``."""
        return int(self.bounds.size - 1)

    def rows(self, r: int) -> NDArray[np.intp]:
        """Row indices of run ``r`` in their original order."""
        return self.order[self.bounds[r] : self.bounds[r + 1]]

    def span(self, r: int) -> slice | NDArray[np.intp]:
        """The rows of run ``r``: a slice when they are one stretch of rows, else their indices.

        Indexing with a slice gives views, not copies; the indices are those of :meth:`rows`.
        """
        a, b = int(self.bounds[r]), int(self.bounds[r + 1])
        first, last = int(self.order[a]), int(self.order[b - 1])
        return slice(first, last + 1) if last - first == b - a - 1 else self.rows(r)


def group_rows(*keys: ArrayLike) -> RowGroups:
    """Group rows by the combination of their values in one or more key columns.

    Test data come in stretches of rows with equal keys (the samples of one run, one after
    another): only the first row of each stretch is coded (``np.unique`` of each key column
    there, the codes combined into one integer), the stretches are sorted by their codes
    (stable) and the rows follow, so that no sort runs over the rows themselves
    (``np.unique(axis=0)`` on the stacked keys of millions of rows is some 100x slower).

    Parameters
    ----------
    *keys : array_like, each shape (n,)
        Key columns (any sortable dtype); equal values are the same run.

    Returns
    -------
    RowGroups
        Run keys, row order and run bounds.

    Raises
    ------
    InputError
        No key column, or columns that are not 1-D of one length.
    """
    cols = [np.asarray(k) for k in keys]
    if not cols or any(c.ndim != 1 or c.shape != cols[0].shape for c in cols):
        raise InputError(
            "group_rows needs one or more 1-D key columns of equal length, got shapes "
            f"{[c.shape for c in cols]}"
        )
    n = cols[0].size
    change = np.zeros(n, dtype=bool)
    change[:1] = True
    for c in cols:
        change[1:] |= c[1:] != c[:-1]  # NaN != NaN: a stretch of its own (np.unique merges)
    starts = np.flatnonzero(change)
    lengths = np.diff(np.append(starts, n))
    values, code = [], np.zeros(starts.size, dtype=np.int64)
    for c in cols:
        v, inverse = np.unique(c[starts], return_inverse=True)
        values.append(v)
        code = code * v.size + inverse.reshape(-1)
    by_code = np.argsort(code, kind="stable")  # stretches by run, in row order within a run
    sorted_code = code[by_code]
    first_row, length = starts[by_code], lengths[by_code]
    offset = np.cumsum(length) - length  # where each stretch begins in ``order``
    order = np.arange(n, dtype=np.intp)
    if not np.array_equal(first_row, offset):  # else each run is one stretch, runs in order
        order += np.repeat(first_row - offset, length)
    new_run = np.flatnonzero(np.r_[True, sorted_code[1:] != sorted_code[:-1]]) if n else starts
    first = sorted_code[new_run]
    run_keys: list[NDArray] = []
    for v in reversed(values):
        run_keys.append(v[first % v.size])
        first = first // v.size
    return RowGroups(keys=tuple(reversed(run_keys)), order=order,
                     bounds=np.r_[offset[new_run], n].astype(np.intp))


def whole_cycle_mask(t: ArrayLike, omega: float) -> tuple[NDArray[np.bool_], int]:
    """Samples of one run that lie in whole cycles of a periodic motion, from its first sample.

    With ``t0`` the first (earliest) sample, the run spans ``n = floor(|w| (t_last - t0) / 2 pi)``
    whole cycles and the kept samples are those with ``|w| (t - t0) / 2 pi < n``: the half-open
    interval ``[t0, t0 + n 2 pi / |w|)``. A sample exactly on the closing boundary repeats the
    phase of ``t0`` and is excluded, so uniform sampling with an integer number of samples per
    cycle averages every harmonic exactly; otherwise :func:`whole_cycle_weights` removes the
    leakage of the low harmonics. Samples within :data:`BOUNDARY_TOLERANCE_CYCLES` of a boundary
    are treated as on it.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times of the run [s] (any order).
    omega : float
        Angular frequency of the motion [rad/s] (sign ignored).

    Returns
    -------
    mask : ndarray of bool, shape (n,)
        Samples kept.
    cycles : int
        Whole cycles ``n`` (0 when the run is shorter than one cycle).
    """
    tt = np.asarray(t, dtype=float)
    w = abs(float(omega))
    if tt.size == 0 or w == 0.0:
        return np.zeros(tt.shape, dtype=bool), 0
    phase = w * (tt - tt.min()) / (2.0 * np.pi)  # cycles since the run's first sample
    n_cyc = int(np.floor(phase.max() + BOUNDARY_TOLERANCE_CYCLES))
    return phase < n_cyc - BOUNDARY_TOLERANCE_CYCLES, n_cyc


def whole_cycle_weights(t: ArrayLike, omega: float, *, harmonics: int = 2) -> NDArray[np.float64]:
    """Averaging weights over whole cycles that integrate the motion's low harmonics exactly.

    A plain mean over ``n`` cycles averages ``cos(w t)`` to exactly zero only when a cycle holds
    an integer number of samples; otherwise ``O(1/samples)`` leaks (e.g. 50 Hz at 4.43 rad/s is
    70.9 samples per cycle). The weights are the equal weights ``1/n`` corrected by the least
    amount (minimum norm) that makes the weighted mean of ``cos k a`` and ``sin k a``
    (``k = 1 .. harmonics``, ``a = |w| (t - t0)``) exactly zero, as the integral over whole cycles
    is (Sun, Ren & Wang, eqs. 19-21). With an integer number of samples per cycle the
    correction vanishes. Averaging the output and the regressors of a linear model with the same
    weights keeps the averaged model exact whatever the weights.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times of the kept samples (whole cycles) of one run [s].
    omega : float
        Angular frequency of the motion [rad/s] (sign ignored).
    harmonics : int
        Highest harmonic averaged to zero (2 for products of a once-per-cycle quantity).

    Returns
    -------
    ndarray, shape (n,)
        Weights summing to 1.

    Raises
    ------
    DataError
        Too few samples per cycle (fewer than ``2 harmonics + 1``) to average the harmonics out.
    """
    tt = np.asarray(t, dtype=float)
    rows = harmonic_rows(abs(float(omega)) * (tt - tt.min()), harmonics)
    gram = rows @ rows.T
    return 1.0 / tt.size + whole_cycle_correction(gram, tt.size, omega, harmonics) @ rows


def harmonic_rows(angle: ArrayLike, harmonics: int) -> NDArray[np.float64]:
    """The basis of :func:`whole_cycle_weights` at angles ``a`` [rad], one row per function.

    Rows ``1, cos a, sin a, cos 2a, sin 2a, ..., cos(K a), sin(K a)`` (``K = harmonics``); the
    higher harmonics from the first by the addition theorem (equal to ``cos(k a)`` to rounding).

    Returns
    -------
    ndarray, shape (2 K + 1, n)
    """
    a = np.asarray(angle, dtype=float)
    out = np.empty((2 * int(harmonics) + 1, a.size))
    out[0] = 1.0
    if harmonics >= 1:
        np.cos(a, out=out[1])
        np.sin(a, out=out[2])
        c, s = out[1], out[2]
        for k in range(2, int(harmonics) + 1):
            ck, sk = out[2 * k - 3], out[2 * k - 2]
            np.multiply(ck, c, out=out[2 * k - 1])
            out[2 * k - 1] -= sk * s
            np.multiply(sk, c, out=out[2 * k])
            out[2 * k] += ck * s
    return out


def whole_cycle_correction(gram: ArrayLike, n: int, omega: float, harmonics: int
                           ) -> NDArray[np.float64]:
    """``l`` with the weights of :func:`whole_cycle_weights` equal to ``1/n + l @ rows``.

    ``rows`` is :func:`harmonic_rows` of the run's ``n`` samples and ``gram = rows @ rows.T``:
    the minimum-norm correction of the equal weights ``u`` that zeroes the weighted mean of
    every harmonic is ``rows.T l`` with ``gram l = e_0 - rows u`` (``rows u`` is the first row
    of ``gram`` over ``n``, the first basis function being 1). So a caller that sums
    ``rows @ values`` (block by block, say) has every weighted mean, ``(e_0 / n + l) @ sums``,
    without the weights.

    Raises
    ------
    DataError
        Too few samples per cycle (fewer than ``2 harmonics + 1``, or a Gram matrix of
        condition number above 1e10) to average the harmonics out.
    """
    g = np.asarray(gram, dtype=float)
    if n < g.shape[0] or np.linalg.cond(g) > 1e10:
        raise DataError(
            f"too few samples per cycle to average harmonics 1 to {int(harmonics)} of the motion "
            f"at {abs(float(omega)):g} rad/s to zero; sample at least {g.shape[0]} times per "
            "cycle"
        )
    target = np.zeros(g.shape[0])
    target[0] = 1.0
    return np.asarray(np.linalg.solve(g, target - g[0] / n))
