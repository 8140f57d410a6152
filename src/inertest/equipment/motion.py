"""What test equipment does to an instrument over time: one protocol for every machine.

A turntable, dividing head, multi-position fixture, rate table, centrifuge or rotation scheme is,
to the error models, the same thing: over labelled segments (a position, a mounting at a table
angle, a rate, a turn, a centrifuge run) it gives the instrument an attitude, an inertial angular
rate and a specific force. :class:`Motion` is that protocol; :class:`Inputs` is what it returns.
Procedures ask a motion for the inputs of each data row's segment at the row's time and build
the regressors of the instrument's model from them (DESIGN.md: plan -> equipment kinematics ->
model -> reduction -> identification).

Conventions
-----------
* ``C_ni`` maps instrument axes to the local-level frame n = ENU (x east, y north, z up); its
  columns are the instrument axes (I, O, S of an SDF gyro; x, y, z of a triad) in ENU.
* ``omega_i`` is the inertial angular rate of the instrument (Earth rate plus the machine's
  rates) on the instrument axes [rad/s]; ``f_i`` the specific force on the instrument axes
  [m/s^2]. At rest ``f_i = C_ni^T (0, 0, g)``: +g along up.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.earth import Site, earth_rate_enu, specific_force_enu
from inertest.errors import InputError


def run_starts(*columns: NDArray) -> NDArray[np.intp]:
    """Index of the first row of each run of rows equal in every column, shape (k,).

    Test data come in runs (the readings of one position, one after another), so that a
    per-row function of the labels need only be evaluated once per run.
    """
    n = columns[0].shape[0]
    change = np.zeros(n, dtype=bool)
    change[:1] = True
    for c in columns:
        change[1:] |= c[1:] != c[:-1]
    return np.flatnonzero(change)


def per_run(fn: Callable[..., NDArray], *columns: NDArray) -> NDArray:
    """``fn(*columns)`` for a row-wise ``fn``, evaluated on the first row of each run only.

    Equal to ``fn(*columns)`` whenever ``fn`` maps equal rows to equal results (labels).
    """
    starts = run_starts(*columns)
    lengths = np.diff(np.append(starts, columns[0].shape[0]))
    return np.repeat(fn(*(c[starts] for c in columns)), lengths, axis=0)


def unique_by_runs(values: NDArray) -> tuple[NDArray, NDArray[np.intp]]:
    """``np.unique(values, return_inverse=True)`` of a 1-d array, sorting only its runs."""
    starts = run_starts(values)
    uniq, inv = np.unique(values[starts], return_inverse=True)
    return uniq, np.repeat(inv, np.diff(np.append(starts, values.shape[0])))


@dataclass(frozen=True)
class Inputs:
    """Attitude, angular rate and specific force of an instrument at ``n`` instants.

    Attributes
    ----------
    C_ni : ndarray, shape (n, 3, 3)
        Instrument axes -> ENU (columns: the instrument axes in ENU).
    omega_i : ndarray, shape (n, 3)
        Inertial angular rate on the instrument axes [rad/s].
    f_i : ndarray, shape (n, 3)
        Specific force on the instrument axes [m/s^2].
    """

    C_ni: NDArray[np.float64]
    omega_i: NDArray[np.float64]
    f_i: NDArray[np.float64]

    @property
    def n(self) -> int:
        """Number of instants."""
        return int(self.f_i.shape[0])


@runtime_checkable
class Motion(Protocol):
    """What a machine does to the instrument, segment by segment.

    ``segments`` names the labelled segments (positions, runs, turns) in plan order;
    ``inputs(segment, t)`` gives the instrument's :class:`Inputs` at times ``t`` [s] since the
    segment's start (a static segment ignores ``t`` beyond its length).
    """

    @property
    def segments(self) -> tuple[str, ...]:
        """Segment labels in plan order."""
        ...

    def inputs(self, segment: str, t: ArrayLike) -> Inputs:
        """Inputs of ``segment`` at times ``t`` [s], shape (n,)."""
        ...


@dataclass(frozen=True)
class StaticPositions:
    """A fixture that holds the instrument still in labelled attitudes at a site.

    Tumble positions, dividing-head angles, cube faces, multi-position sets. At rest the
    instrument feels the Earth rate and +g along up, resolved on its axes:
    ``omega_i = C_ni^T W_n``, ``f_i = C_ni^T (0, 0, g)``.

    Attributes
    ----------
    attitudes : mapping of str to ndarray (3, 3)
        ``C_ni`` of each position, by label.
    site : Site
    """

    attitudes: Mapping[str, NDArray[np.float64]]
    site: Site

    def __post_init__(self) -> None:
        labels = list(self.attitudes)
        m = np.asarray([np.asarray(self.attitudes[k], dtype=float) for k in labels])
        if m.ndim != 3 or m.shape[1:] != (3, 3):
            raise InputError("every attitude must be a 3x3 rotation matrix")
        # All positions checked at once: a tumble or dividing head has dozens of them.
        off = np.abs(np.einsum("nji,njk->nik", m, m) - np.eye(3)).max(axis=(1, 2))
        for k in np.flatnonzero(off > 1e-9):
            raise InputError(f"attitude of position {labels[k]!r} is not a rotation matrix")
        for k in np.flatnonzero(np.linalg.det(m) < 0):
            raise InputError(f"attitude of position {labels[k]!r} is left-handed")

    @property
    def segments(self) -> tuple[str, ...]:
        """Position labels in plan order."""
        return tuple(self.attitudes)

    def inputs(self, segment: str, t: ArrayLike = 0.0) -> Inputs:
        """Inputs in position ``segment`` (constant in time), one row per element of ``t``."""
        try:
            c = np.asarray(self.attitudes[segment], dtype=float)
        except KeyError:
            raise InputError(f"unknown position {segment!r}; the plan has "
                             f"{', '.join(self.segments)}") from None
        n = np.atleast_1d(np.asarray(t, dtype=float)).size
        w = c.T @ earth_rate_enu(self.site.latitude_rad)
        f = c.T @ specific_force_enu(self.site.gravity_m_s2)
        return Inputs(np.broadcast_to(c, (n, 3, 3)).copy(), np.tile(w, (n, 1)),
                      np.tile(f, (n, 1)))

    def inputs_of_rows(self, labels: ArrayLike) -> Inputs:
        """Inputs of every data row, by its position label, shape (n,)."""
        uniq, inv = unique_by_runs(np.asarray(labels).astype(str, copy=False))
        parts = [self.inputs(str(u)) for u in uniq]
        C = np.stack([p.C_ni[0] for p in parts])[inv]
        w = np.stack([p.omega_i[0] for p in parts])[inv]
        f = np.stack([p.f_i[0] for p in parts])[inv]
        return Inputs(C, w, f)


@dataclass(frozen=True)
class Fixture:
    """A static test machine at a site, with its Type-B errors: its positions on demand.

    A polar-axis table, a level fixture, a multi-position cube or a dividing head holds the
    instrument in positions that a plan lists and that the data name (a test may run fewer or
    other positions than planned). ``positions(*where)`` is the equipment module's
    ``motion(*where, site, type_b=...)``: the :class:`StaticPositions` of those positions on
    this machine, with its Type-B errors (:mod:`inertest.equipment.type_b`) applied.

    Attributes
    ----------
    place : callable
        The equipment module's ``motion`` function.
    site : Site
    type_b : mapping of str to float
        ``{source name: error [SI]}``; empty for the nominal machine.
    """

    place: Callable[..., StaticPositions]
    site: Site
    type_b: Mapping[str, float] = field(default_factory=dict)

    def positions(self, *where: object, **options: object) -> StaticPositions:
        """The static positions ``where`` (labels, or mountings and angles) on this machine."""
        return self.place(*where, self.site, type_b=self.type_b, **options)
