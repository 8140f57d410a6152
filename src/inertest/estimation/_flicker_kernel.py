"""Numba kernels of the flicker row covariance of :mod:`inertest.estimation.noise_models`.

``c(L) = Ci(pi L) - Ci(w L)`` at integer lags ``L = 1 .. n`` (``w = 2 pi f_lo``, ``w n <= pi``;
Ci the cosine integral, Abramowitz & Stegun 5.2.2), and its even second antidifference
``Phi`` by the running sums of :func:`inertest.estimation.noise_models.flicker_phi`, in one loop
without arrays of the record's length. The cosine integrals:

* ``Ci(x)`` for ``0 < x <= pi`` by its power series (A&S 5.2.16),
  ``gamma + ln x + sum_k (-x^2)^k / (2k (2k)!)``, 16 terms (the next is below 1e-21);
* ``Ci(pi L)`` from :data:`ASYMPTOTIC_FROM` on by the asymptotic expansion (A&S 5.2.8-5.2.9,
  5.2.34-5.2.35): ``Ci(x) = f(x) sin x - g(x) cos x``, at ``x = pi L`` exactly
  ``-(-1)^L g(pi L)`` with ``g(x) ~ x^-2 sum_k (-1)^k (2k + 1)! x^-2k``, 7 terms (the next,
  ``15! x^-14``, is below 1e-20 of the first there); below it the caller passes scipy's values.

scipy's ``sici`` takes the rounded argument ``fl(pi L)``, whose sine is not 0: its ``Ci(pi L)``
differs from the exact one by about 4e-17 (alternating in sign), far below the digits of the
covariance (``c(0) = ln(1 / (2 f_lo))`` ~ 10-20). Tested against ``scipy.special.sici``. This
module imports numba: import it lazily.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Euler's constant.
EULER = 0.57721566490153286061
#: ``Ci(pi L)`` by the asymptotic expansion from this lag on (``x >= 64 pi = 201``).
ASYMPTOTIC_FROM = 64

#: ``(-1)^k / (2k (2k)!)``, k = 1 .. 16: the power series of ``Ci(x) - gamma - ln x`` in x^2.
_SERIES = np.array([(-1.0) ** k / (2 * k * math.factorial(2 * k)) for k in range(1, 17)])
#: ``(-1)^k (2k + 1)!``, k = 0 .. 6: the asymptotic series of ``x^2 g(x)`` in x^-2.
_ASYMPTOTIC = np.array([(-1.0) ** k * math.factorial(2 * k + 1) for k in range(7)])


@njit(cache=True, nogil=True)
def _ci_series(x: float) -> float:
    """``Ci(x)`` for ``0 < x <= pi`` (power series, in Estrin's scheme: short dependencies)."""
    a = _SERIES
    t = x * x
    t2 = t * t
    t4 = t2 * t2
    t8 = t4 * t4
    q0 = (a[0] + a[1] * t) + (a[2] + a[3] * t) * t2
    q1 = (a[4] + a[5] * t) + (a[6] + a[7] * t) * t2
    q2 = (a[8] + a[9] * t) + (a[10] + a[11] * t) * t2
    q3 = (a[12] + a[13] * t) + (a[14] + a[15] * t) * t2
    return EULER + math.log(x) + t * ((q0 + q1 * t4) + (q2 + q3 * t4) * t8)


@njit(cache=True, nogil=True)
def _ci_pi_multiple(lag: int) -> float:
    """``Ci(pi lag)`` for ``lag >= ASYMPTOTIC_FROM`` (asymptotic expansion, exact argument)."""
    b = _ASYMPTOTIC
    x = math.pi * lag
    u = 1.0 / (x * x)
    u2 = u * u
    u4 = u2 * u2
    g = u * (((b[0] + b[1] * u) + (b[2] + b[3] * u) * u2) + ((b[4] + b[5] * u) + b[6] * u2) * u4)
    return -g if lag % 2 == 0 else g


@njit(cache=True, nogil=True)
def _c(lag: int, w: float, head: np.ndarray) -> float:
    """``c(lag) = Ci(pi lag) - Ci(w lag)``; ``head[L]`` is ``Ci(pi L)`` below ASYMPTOTIC_FROM."""
    big = head[lag] if lag < head.shape[0] else _ci_pi_multiple(lag)
    return big - _ci_series(w * lag)


@njit(cache=True, nogil=True)
def row_covariance(w: float, head: np.ndarray, out: np.ndarray) -> None:
    """``out[L] = c(L)`` for ``L = 1 .. len(out) - 1`` (``out[0]`` is left alone)."""
    for lag in range(1, out.shape[0]):
        out[lag] = _c(lag, w, head)


@njit(cache=True, nogil=True)
def second_antidifference(n: int, w: float, c0: float, head: np.ndarray, lags: np.ndarray,
                          out: np.ndarray) -> int:
    """``out[i] = Phi(lags[i])`` for sorted ``lags`` in ``0 .. n + 1``; returns how many.

    ``Phi(0) = 0``, ``Phi(j + 1) = Phi(j) + (c0 / 2 + S(j))``, ``S(0) = 0``,
    ``S(j) = S(j - 1) + c(j)``: the additions of ``flicker_phi`` in its order. Stops at the
    largest lag asked for.
    """
    nl = lags.shape[0]
    i = 0
    while i < nl and lags[i] == 0:
        out[i] = 0.0
        i += 1
    half = c0 / 2
    s = 0.0
    phi = 0.0
    for j in range(n + 1):
        if i >= nl:
            break
        if j >= 1:
            s += _c(j, w, head)
        phi += half + s
        while i < nl and lags[i] == j + 1:
            out[i] = phi
            i += 1
    return i
