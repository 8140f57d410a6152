"""Closed forms of the constant and secular error parts, by the final value theorem (sympy).

For a constant source the static-base errors (seed 002) are, per state,

    x_i(t) = c0 + c1 t + (oscillations at the Schuler, Foucault-split Schuler and Earth rates)

because every pole of ``X(s) = (sI - A)^-1 (x0 + B u / s)`` is on the imaginary axis except
the one at ``s = 0``. The non-oscillating part is the residue at ``s = 0``:

* ``c1 = lim_{s->0} s^2 X(s)`` (the *secular* part; non-zero only where the pole at 0 is double:
  the longitude error, which integrates a constant east velocity error), and
* ``c0 = lim_{s->0} d/ds [s^2 X(s)]``, which equals the final-value limit ``lim s X(s)`` of the
  source whenever the pole at 0 is simple (all states but longitude).

Signs follow :mod:`inertest.ins.error_model` (errors = computed - true; drift and bias are
sensor output errors; ``C_b^n(computed) = (I - [phi x]) C_b^n(true)``). So, for example, the
east gyro drift settles the azimuth error at ``phiU = -eE / (W cos L)`` and the drift along
the polar axis makes the longitude error grow at ``+(eN cos L + eU sin L)``.

The oscillations at the Earth rate are *not* part of ``c0``: "constant" means "not oscillating
at any of the three natural periods", as in the source's decomposition. The seven-state matrix
is singular (longitude feeds nothing back), but the six other states form a non-singular
``A6``, so the Laurent series ``(sI - A6)^-1 = -A6^-1 - s A6^-2 - ...`` gives exactly::

    c0[6 states] = -A6^-1 B6 u                    c1[6 states] = 0
    c1[dlambda]  = -a' A6^-1 B6 u                 a = e_dVE / (R cos L)
    c0[dlambda]  = dlambda0 - a' A6^-1 (x06 + A6^-1 B6 u)

The initial errors of the six coupled states excite only oscillations (zero ``c0`` there) but
leave a constant longitude offset. :func:`fit_constant_and_secular` recovers ``c0`` and ``c1``
from a numerical history by least squares on the modal basis, which checks the algebra.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.ins.error_model import INPUTS, STATES, InsSite
from inertest.ins.propagation import SOURCES, characteristic_periods

__all__ = [
    "ClosedForms",
    "closed_forms",
    "fit_constant_and_secular",
    "symbolic_system",
]

#: Symbols of the closed forms: gravity, radius, Earth rate, latitude.
g, R, W, L = sp.symbols("g R W L", positive=True)
_SOURCE_SYMBOLS = sp.symbols(" ".join(SOURCES), real=True)


@dataclass(frozen=True)
class ClosedForms:
    """Constant and secular parts of each state for each source, as sympy expressions.

    Attributes
    ----------
    coriolis : bool
        Whether the model keeps the ``2 W sin L`` terms.
    constant : dict
        ``constant[(source, state)]``: expression of ``c0`` in ``g, R, W, L`` and the source
        symbol (e.g. ``bE``, ``dVE0``), SI.
    secular : dict
        ``secular[(source, state)]``: expression of ``c1`` (rate of linear growth, per second).
    """

    coriolis: bool
    constant: dict[tuple[str, str], sp.Expr]
    secular: dict[tuple[str, str], sp.Expr]

    def evaluate(self, site: InsSite, magnitudes: ArrayLike) -> tuple[
        NDArray[np.float64], NDArray[np.float64]
    ]:
        """Numerical ``(c0, c1)`` arrays of shape (12, 7) for source magnitudes (12,), SI.

        ``magnitudes`` follows :data:`~inertest.ins.propagation.SOURCES`: ``[bE, bN, eE,
        eN, eU, dVE0, ..., phiU0]``.
        """
        if site.coriolis != self.coriolis:
            raise InputError("closed forms were derived for the other Coriolis setting")
        if site.earth_rate_rad_s == 0:
            raise InputError("the closed forms assume a rotating Earth (W > 0): with W = 0 more "
                             "poles sit at s = 0 and errors grow without bound; use W > 0")
        mags = np.asarray(magnitudes, dtype=float)
        if mags.shape != (len(SOURCES),):
            raise InputError(f"magnitudes must have {len(SOURCES)} entries, got {mags.shape}")
        subs = {g: site.gravity_m_s2, R: site.radius_m, W: site.earth_rate_rad_s,
                L: site.latitude_rad}
        c0 = np.zeros((len(SOURCES), len(STATES)))
        c1 = np.zeros_like(c0)
        for j, src in enumerate(SOURCES):
            sym = {_SOURCE_SYMBOLS[j]: mags[j]}
            for i, st in enumerate(STATES):
                c0[j, i] = float(self.constant[(src, st)].subs(subs).subs(sym))
                c1[j, i] = float(self.secular[(src, st)].subs(subs).subs(sym))
        return c0, c1

    def rows(self) -> list[tuple[str, str, str, str]]:
        """``(state, source, c0, c1)`` strings for every pair with a non-zero part."""
        out = []
        for st in STATES:
            for src in SOURCES:
                c0, c1 = self.constant[(src, st)], self.secular[(src, st)]
                if c0 != 0 or c1 != 0:
                    out.append((st, src, sp.sstr(c0), sp.sstr(c1)))
        return out


def symbolic_system(*, coriolis: bool = True) -> tuple[sp.Matrix, sp.Matrix]:
    """Symbolic ``A`` (7x7) and ``B`` (7x5) of :mod:`~inertest.ins.error_model`."""
    k = 2 * W * sp.sin(L) if coriolis else sp.Integer(0)
    s, c, t = sp.sin(L), sp.cos(L), sp.tan(L)
    A = sp.zeros(7, 7)
    A[0, 5], A[0, 1] = -g, k
    A[1, 4], A[1, 0] = g, -k
    A[2, 1] = 1 / R
    A[3, 0] = 1 / (R * c)
    A[4, 1], A[4, 5], A[4, 6] = -1 / R, W * s, -W * c
    A[5, 0], A[5, 2], A[5, 4] = 1 / R, -W * s, -W * s
    A[6, 0], A[6, 2], A[6, 4] = t / R, W * c, W * c
    B = sp.zeros(7, 5)
    B[0, 0] = B[1, 1] = 1  # accelerometer output errors enter dV' with +
    B[4, 2] = B[5, 3] = B[6, 4] = -1  # gyro output errors enter phi' with -
    return A, B


@functools.lru_cache(maxsize=2)
def closed_forms(*, coriolis: bool = True) -> ClosedForms:
    """Constant and secular parts of every state for every source (module docstring).

    Derived once per Coriolis setting (a few seconds of sympy) and cached.
    """
    A, B = symbolic_system(coriolis=coriolis)
    keep = [0, 1, 2, 4, 5, 6]  # every state but longitude
    A6 = A.extract(keep, keep)
    A6inv = A6.inv(method="LU").applyfunc(_simplify)
    a = A.extract([3], keep)  # dlambda' = a . x6
    constant: dict[tuple[str, str], sp.Expr] = {}
    secular: dict[tuple[str, str], sp.Expr] = {}
    for j, src in enumerate(SOURCES):
        mag = _SOURCE_SYMBOLS[j]
        b6 = sp.zeros(6, 1)
        x06 = sp.zeros(6, 1)
        dlambda0 = sp.Integer(0)
        if j < len(INPUTS):
            b6 = B.extract(keep, [j]) * mag
        else:
            i = j - len(INPUTS)
            if STATES[i] == "dlambda":
                dlambda0 = mag
            else:
                x06[keep.index(i)] = mag
        c0_6 = (-A6inv * b6).applyfunc(_simplify)
        c1_lon = _simplify((a * c0_6)[0])
        c0_lon = _simplify(dlambda0 - (a * A6inv * (x06 + A6inv * b6))[0])
        for i, st in enumerate(STATES):
            if st == "dlambda":
                constant[(src, st)], secular[(src, st)] = c0_lon, c1_lon
            else:
                constant[(src, st)] = c0_6[keep.index(i)]
                secular[(src, st)] = sp.Integer(0)
    return ClosedForms(coriolis=coriolis, constant=constant, secular=secular)


def fit_constant_and_secular(
    site: InsSite, t: ArrayLike, history: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Constant and secular parts of a numerical history, by least squares on the modal basis.

    Parameters
    ----------
    site : InsSite
        Gives the natural frequencies (eigenvalues of ``A``).
    t : array_like, shape (n,)
        Sample times [s]; the span should cover at least one Earth period for a
        well-conditioned fit (24 h does).
    history : array_like, shape (n, 7) or (m, n, 7)
        State histories, SI.

    Returns
    -------
    c0, c1 : ndarray, shape (7,) or (m, 7)
        Fitted constant [SI] and linear-growth rate [SI/s] of each state.

    Notes
    -----
    The basis is ``1, t`` and ``cos w t, sin w t`` for every distinct natural frequency ``w``;
    the exact solution lies in its span (the Schuler pair of the model without Coriolis is
    double but not defective, so no ``t cos`` terms appear), so the fit residual is rounding.
    """
    tt = np.asarray(t, dtype=float)
    x = np.asarray(history, dtype=float)
    single = x.ndim == 2
    x3 = x[None] if single else x
    if x3.shape[1:] != (tt.size, len(STATES)):
        raise InputError(f"history must be (n, 7) or (m, n, 7) with n = {tt.size}, got {x.shape}")
    periods = characteristic_periods(site)
    ws = [2 * math.pi / p for p in periods.modes_s]
    span = max(float(tt[-1] - tt[0]), 1.0)
    cols = [np.ones_like(tt), tt / span]
    for w in ws:
        cols += [np.cos(w * tt), np.sin(w * tt)]
    design = np.column_stack(cols)
    m = x3.shape[0]
    rhs = x3.transpose(1, 0, 2).reshape(tt.size, m * len(STATES))
    coef, *_ = np.linalg.lstsq(design, rhs, rcond=None)
    c0 = coef[0].reshape(m, len(STATES))
    c1 = coef[1].reshape(m, len(STATES)) / span
    return (c0[0], c1[0]) if single else (c0, c1)


def _simplify(e: sp.Expr) -> sp.Expr:
    # expand_trig first: otherwise sympy leaves e.g. (sin 2L tan L + cos 2L + 1) / (2 cos L)
    # instead of sec L.
    return sp.simplify(sp.expand_trig(sp.together(e)))
