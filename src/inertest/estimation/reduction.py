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


def group_rows(*keys: ArrayLike) -> RowGroups:
    """Group rows by the combination of their values in one or more key columns.

    Each key column is coded by ``np.unique`` and the codes are combined into one integer per
    row, then one stable sort finds the runs (``np.unique(axis=0)`` on stacked keys is ~10x slower
    on millions of rows).

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
    values, code = [], np.zeros(cols[0].size, dtype=np.int64)
    for c in cols:
        v, inverse = np.unique(c, return_inverse=True)
        values.append(v)
        code = code * v.size + inverse.reshape(-1)
    order = np.argsort(code, kind="stable")
    sorted_code = code[order]
    starts = np.flatnonzero(np.r_[True, sorted_code[1:] != sorted_code[:-1]])
    first = sorted_code[starts] if starts.size else sorted_code[:0]
    run_keys: list[NDArray] = []
    for v in reversed(values):
        run_keys.append(v[first % v.size])
        first = first // v.size
    return RowGroups(keys=tuple(reversed(run_keys)), order=order,
                     bounds=np.r_[starts, code.size].astype(np.intp))


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
    a = abs(float(omega)) * (tt - tt.min())
    columns = [np.ones_like(a)]
    for k in range(1, int(harmonics) + 1):
        columns += [np.cos(k * a), np.sin(k * a)]
    basis = np.column_stack(columns)
    u = np.full(a.size, 1.0 / a.size)
    target = np.zeros(basis.shape[1])
    target[0] = 1.0
    gram = basis.T @ basis
    if a.size < basis.shape[1] or np.linalg.cond(gram) > 1e10:
        raise DataError(
            f"too few samples per cycle to average harmonics 1 to {int(harmonics)} of the motion "
            f"at {abs(float(omega)):g} rad/s to zero; sample at least {basis.shape[1]} times per "
            "cycle"
        )
    return u + basis @ np.linalg.solve(gram, target - basis.T @ u)
