"""Rows reduced to units of independence: the positions or runs a noise model works on.

A static test holds the instrument in a few positions (a run at a rate, a centrifuge run) for many
readings each. The noise models of :mod:`inertest.estimation.noise_models` describe how the
noise of one position's mean relates to another's; so the identification
(:func:`inertest.estimation.identify.solve`) first reduces the rows to their units: the count,
first and last row (time order), mean observation and mean design row of each.
:class:`PositionDesign` says the same for a design whose rows repeat by position without ever
building the full design.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InputError
from inertest.estimation.least_squares import LinearFit, weighted_least_squares
from inertest.results import sum_of_squares


@dataclass(frozen=True)
class PositionDesign:
    """A design whose rows repeat by position: row ``i`` of the design is ``rows[index[i]]``.

    A static test holds the instrument in a few positions for many readings each; the design
    of each position once (``G x p``) and the position of each reading (``n`` ints) say
    everything the full ``n x p`` design does, at ``G p + n`` numbers instead of ``n p``.
    :func:`solve` then works on the sufficient statistics of each position (count, mean,
    sum of squares) and never builds the full design. Build it with :meth:`from_codes`.

    Attributes
    ----------
    rows : ndarray, shape (G, p)
        Design row of each position, positions in time order (of their first reading).
    index : ndarray of int, shape (n,)
        Position of each reading (every position has readings).
    labels : tuple of str
        Name of each position.
    """

    rows: NDArray[np.float64]
    index: NDArray[np.intp]
    labels: tuple[str, ...]

    @classmethod
    def from_codes(
        cls, rows: ArrayLike, codes: ArrayLike, labels: Sequence[str]
    ) -> PositionDesign:
        """Design from the row and label of each position and a code per reading.

        Parameters
        ----------
        rows : array_like, shape (k, p)
            Design row of each position, in any order.
        codes : array_like of int, shape (n,)
            Position of each reading, ``0 <= codes < k``, readings in time order.
        labels : sequence of str, length k
            Name of each position.

        Returns
        -------
        PositionDesign
            Positions without readings dropped, the others in the order of their first reading.
        """
        R = np.asarray(rows, dtype=float)
        c = np.asarray(codes, dtype=np.intp)
        if R.ndim != 2 or len(labels) != R.shape[0] or c.ndim != 1:
            raise InputError(f"position design: {R.shape} rows, {len(labels)} labels and codes "
                             f"of shape {c.shape}; give one row and one label per position and "
                             "one code per reading")
        if c.size and (c.min() < 0 or c.max() >= R.shape[0]):
            raise InputError(f"position codes must lie in 0..{R.shape[0] - 1}")
        change = np.ones(c.size, dtype=bool)
        change[1:] = c[1:] != c[:-1]
        starts = np.flatnonzero(change)
        used, first = np.unique(c[starts], return_index=True)
        order = used[np.argsort(first, kind="stable")]  # positions in time order
        rank = np.full(R.shape[0], -1, dtype=np.intp)
        rank[order] = np.arange(order.size)
        index = np.repeat(rank[c[starts]], np.diff(np.append(starts, c.size)))
        return cls(rows=R[order], index=index, labels=tuple(str(labels[k]) for k in order))

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of the full design, ``(n, p)``."""
        return int(self.index.size), int(self.rows.shape[1])

    def __matmul__(self, x: ArrayLike) -> NDArray[np.float64]:
        """``A @ x`` for every reading, from the ``G`` positions' values."""
        return np.asarray(self.rows @ np.asarray(x, dtype=float))[self.index]


def residuals_of(
    A: NDArray[np.float64] | PositionDesign, x: NDArray[np.float64], y: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``y - A @ x`` in one new array (no second record-length temporary)."""
    out = np.asarray(A @ x)
    return np.subtract(y, out, out=out)


@dataclass(frozen=True)
class Units:
    """Rows reduced to units (positions/runs): means, design, counts, time order.

    Attributes
    ----------
    index : ndarray of int, shape (n,)
        Unit of each row; units numbered in time order (of their first row).
    labels : tuple of str or None
        Name of each unit; None when the units are the readings.
    counts : ndarray, shape (G,)
        Rows of each unit.
    first, last : ndarray of int, shape (G,)
        First and last row of each unit.
    y : ndarray, shape (G,)
        Mean observation of each unit.
    A : ndarray, shape (G, p)
        Mean design row of each unit.
    n_rows : int
        Rows in the record.
    """

    index: NDArray[np.intp]
    labels: tuple[str, ...] | None  # None: the units are the readings
    counts: NDArray[np.float64]
    first: NDArray[np.intp]
    last: NDArray[np.intp]
    y: NDArray[np.float64]
    A: NDArray[np.float64]
    n_rows: int

    @property
    def size(self) -> int:
        """Number of units."""
        return int(self.counts.size)

    def label(self, i: int) -> str:
        """Name of unit ``i`` (``reading i+1`` when the units are the readings)."""
        return f"reading {i + 1}" if self.labels is None else self.labels[i]

    @property
    def contiguous(self) -> bool:
        """True when each unit's rows are one block in time."""
        return bool(np.all(self.last - self.first + 1 == self.counts))

    @classmethod
    def of_values(cls, y: ArrayLike, A: ArrayLike, labels: Sequence[str] | None = None
                  ) -> Units:
        """Units that are single observations (a window, a face mean) in time order."""
        yy, AA = np.asarray(y, dtype=float), np.asarray(A, dtype=float)
        idx = np.arange(yy.size, dtype=np.intp)
        return cls(index=idx, labels=None if labels is None else tuple(labels),
                   counts=np.ones(yy.size), first=idx, last=idx, y=yy, A=AA, n_rows=yy.size)


def position_units(P: PositionDesign, y: NDArray[np.float64]) -> Units:
    """The units of a :class:`PositionDesign`: its positions, from per-position sums."""
    n, G = y.size, P.rows.shape[0]
    idx = P.index
    change = np.ones(n, dtype=bool)
    change[1:] = idx[1:] != idx[:-1]
    starts = np.flatnonzero(change)
    ends = np.append(starts[1:], n) - 1
    first = np.full(G, n, dtype=np.intp)
    np.minimum.at(first, idx[starts], starts)
    last = np.zeros(G, dtype=np.intp)
    np.maximum.at(last, idx[starts], ends)
    counts = np.bincount(idx, minlength=G).astype(float)
    return Units(index=idx, labels=P.labels, counts=counts, first=first, last=last,
                  y=np.bincount(idx, y, minlength=G) / counts, A=P.rows, n_rows=n)


def position_row_fit(
    P: PositionDesign, u: Units, y: NDArray[np.float64], sigma_si: float | ArrayLike | None,
) -> LinearFit:
    """:func:`weighted_least_squares` over the readings of a :class:`PositionDesign`.

    Rows of one position share the design row, so ``sum_i w_i (y_i - a_g x)^2`` over a
    position is ``W_g (ybar_g - a_g x)^2`` plus a constant, with ``W_g = sum_i w_i`` and
    ``ybar_g`` the ``w``-weighted mean: the least squares over the ``G`` weighted position
    means has the same normal equations, singular values and null space as over the readings.
    Residuals, degrees of freedom and the noise level are those of the readings.
    """
    n = y.size
    if sigma_si is None or np.ndim(sigma_si) == 0:
        s2 = 1.0 if sigma_si is None else float(np.asarray(sigma_si)) ** 2
        if not (np.isfinite(s2) and s2 > 0):
            raise InputError("observation sigmas must be finite and positive")
        W, ymean = u.counts / s2, u.y
    else:
        s = np.broadcast_to(np.asarray(sigma_si, dtype=float), (n,))
        if not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError("observation sigmas must be finite and positive")
        inv = 1.0 / s**2
        W = np.bincount(u.index, inv, minlength=u.size).astype(float)
        ymean = np.bincount(u.index, y * inv, minlength=u.size) / W
    sq = np.sqrt(W)
    red = weighted_least_squares(P.rows * sq[:, None], ymean * sq, sigma=1.0)
    residuals = residuals_of(P, red.x, y)
    dof = n - red.rank
    if sigma_si is not None:
        return replace(red, residuals=residuals, dof=dof)
    if dof <= 0:
        raise IdentifiabilityError(
            f"{n} observations leave no degree of freedom to estimate the noise "
            f"({red.rank} independent unknowns); add positions or samples, or give the noise "
            "level")
    sigma0 = float(np.sqrt(sum_of_squares(residuals) / dof))
    return replace(red, covariance=red.covariance * sigma0**2, residuals=residuals,
                   sigma=sigma0, sigma_from_residuals=True, dof=dof)


def units_of_rows(A: NDArray[np.float64], y: NDArray[np.float64], groups: ArrayLike | None
                  ) -> Units:
    """The units of ``groups`` (a label per row; None: every reading its own unit)."""
    n = y.size
    if groups is None:
        idx = np.arange(n, dtype=np.intp)
        return Units(index=idx, labels=None, counts=np.ones(n), first=idx, last=idx, y=y, A=A,
                      n_rows=n)
    labels_row = np.asarray(groups).astype(str, copy=False)
    if labels_row.shape != (n,):
        raise InputError(f"groups has shape {labels_row.shape}; give one label per row ({n})")
    # np.unique over the runs of equal labels only (the readings of a position come together).
    change = np.ones(n, dtype=bool)
    change[1:] = labels_row[1:] != labels_row[:-1]
    starts = np.flatnonzero(change)
    lengths = np.diff(np.append(starts, n))
    uniq, first_run, inv_run = np.unique(labels_row[starts], return_index=True,
                                         return_inverse=True)
    first = starts[first_run]
    order = np.argsort(first, kind="stable")  # units in time order
    rank_of = np.empty_like(order)
    rank_of[order] = np.arange(order.size)
    index = np.repeat(rank_of[inv_run], lengths)
    counts = np.bincount(index).astype(float)
    last = np.zeros(order.size, dtype=np.intp)
    np.maximum.at(last, rank_of[inv_run], starts + lengths - 1)
    ybar = np.bincount(index, y) / counts
    Abar = np.stack([np.bincount(index, A[:, j], minlength=order.size) for j in
                     range(A.shape[1])], axis=1) / counts[:, None]
    # Column by column: no temporary of the whole design.
    scale = max(max((float(np.max(np.abs(A[:, j]))) for j in range(A.shape[1])), default=0.0),
                1e-300)
    spread = max((float(np.max(np.abs(A[:, j] - Abar[index, j]))) for j in range(A.shape[1])),
                 default=0.0)
    if groups is not None and spread > 1e-9 * scale:
        # The design varies inside a group: the labels are not positions; use the readings.
        return units_of_rows(A, y, None)
    return Units(index=index, labels=tuple(uniq[order].tolist()), counts=counts,
                  first=first[order].astype(np.intp), last=last, y=ybar, A=Abar, n_rows=n)
