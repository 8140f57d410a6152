"""Fused numba kernels of the whole-cycle reduction of one run (seed 004, eqs. 18-22).

The basis of :func:`inertest.estimation.reduction.harmonic_rows` for two harmonics,
``b = (1, cos a, sin a, cos 2a, sin 2a)`` with ``a = rate (t - t0)`` (the second harmonic by the
addition theorem, as there), over the samples of one run, and the sums that a whole-cycle
reduction of a model quadratic in a 3-vector input ``f`` (the SDF gyro's drift model) needs:

1. :func:`gram`: ``cos a``, ``sin a`` of every sample and the Gram matrix ``sum b b^T``, from
   which the caller finds the whole-cycle weights ``w = c . b`` (:func:`~inertest.estimation.
   reduction.whole_cycle_correction`);
2. :func:`weighted_sums`: with those weights, the weighted sums of the drift ``y - r``, the
   input rate ``r``, ``f`` and its six products; the sums of ``f``, ``cos a f`` and ``sin a f`` (the
   least-squares fit of a constant and the first harmonic to ``f``); and ``sum b (y - r)`` (the
   fit of the basis to the drift);
3. :func:`basis_residuals`: ``(y - r) - b . k`` for the fitted ``k``.

One loop each, the accumulators in registers: numpy needs the ``(n, 5)`` basis, the weights and
the ``(n, 10)`` regressors in memory, and its small matrix products run at a fraction of the
speed. The sums restart every :data:`TILE` samples and are added to the sum of the tiles
before, so their rounding does not pile up over a long run. Compiled with ``fastmath`` off and
cached on disk; equal to the numpy formulation to rounding (tested). This module imports numba:
import it lazily.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Samples per tile of the running sums.
TILE = 4096


@njit(cache=True, fastmath=False, nogil=True)
def gram(t, rate, t0, cos_sin, out):  # noqa: ANN001, ANN201
    """``cos_sin[:, i] = (cos a_i, sin a_i)`` and ``out = sum_i b_i b_i^T`` (5, 5)."""
    n = t.shape[0]
    for i0 in range(0, n, TILE):
        i1 = min(n, i0 + TILE)
        g01 = g02 = g03 = g04 = 0.0
        g11 = g12 = g13 = g14 = g22 = g23 = g24 = g33 = g34 = g44 = 0.0
        for i in range(i0, i1):
            a = rate * (t[i] - t0)
            c = np.cos(a)
            s = np.sin(a)
            cos_sin[0, i] = c
            cos_sin[1, i] = s
            c2 = c * c - s * s
            s2 = s * c + c * s
            g01 += c
            g02 += s
            g03 += c2
            g04 += s2
            g11 += c * c
            g12 += c * s
            g13 += c * c2
            g14 += c * s2
            g22 += s * s
            g23 += s * c2
            g24 += s * s2
            g33 += c2 * c2
            g34 += c2 * s2
            g44 += s2 * s2
        out[0, 1] += g01
        out[0, 2] += g02
        out[0, 3] += g03
        out[0, 4] += g04
        out[1, 1] += g11
        out[1, 2] += g12
        out[1, 3] += g13
        out[1, 4] += g14
        out[2, 2] += g22
        out[2, 3] += g23
        out[2, 4] += g24
        out[3, 3] += g33
        out[3, 4] += g34
        out[4, 4] += g44
    out[0, 0] = float(n)
    for p in range(5):  # the lower triangle
        for q in range(p):
            out[p, q] = out[q, p]


@njit(cache=True, fastmath=False, nogil=True)
def weighted_sums(cos_sin, y, r, f, scale, weights, out):  # noqa: ANN001, ANN201
    """The sums of one run over its samples (``f`` multiplied by ``scale``, e.g. 1 / g0).

    With ``w = weights . b`` per sample, ``out`` (25,) receives: ``sum w v`` for
    ``v = y - r, r, f0, f1, f2, f0 f1, f1 f2, f2 f0, f0^2, f1^2, f2^2`` (0-10: the
    difference summed as such, not from the sums of ``y`` and ``r``, which are larger);
    ``sum f_k``, ``sum cos a f_k``, ``sum sin a f_k`` (11-19, k = 0, 1, 2 within each); and
    ``sum b (y - r)`` (20-24). ``y`` and ``r`` may have any stride.
    """
    n = y.shape[0]
    k0, k1, k2, k3, k4 = weights[0], weights[1], weights[2], weights[3], weights[4]
    for i0 in range(0, n, TILE):
        i1 = min(n, i0 + TILE)
        wd = wr = w0 = w1 = w2 = w01 = w12 = w20 = w00 = w11 = w22 = 0.0
        a0 = a1 = a2 = c0 = c1 = c2 = s0 = s1 = s2 = 0.0
        d0 = d1 = d2 = d3 = d4 = 0.0
        for i in range(i0, i1):
            c = cos_sin[0, i]
            s = cos_sin[1, i]
            cc = c * c - s * s
            ss = s * c + c * s
            wt = k0 + k1 * c + k2 * s + k3 * cc + k4 * ss
            ri = r[i]
            d = y[i] - ri
            f0 = f[i, 0] * scale
            f1 = f[i, 1] * scale
            f2 = f[i, 2] * scale
            wd += wt * d
            wr += wt * ri
            wf0 = wt * f0
            wf1 = wt * f1
            wf2 = wt * f2
            w0 += wf0
            w1 += wf1
            w2 += wf2
            w01 += wf0 * f1
            w12 += wf1 * f2
            w20 += wf2 * f0
            w00 += wf0 * f0
            w11 += wf1 * f1
            w22 += wf2 * f2
            a0 += f0
            a1 += f1
            a2 += f2
            c0 += c * f0
            c1 += c * f1
            c2 += c * f2
            s0 += s * f0
            s1 += s * f1
            s2 += s * f2
            d0 += d
            d1 += c * d
            d2 += s * d
            d3 += cc * d
            d4 += ss * d
        out[0] += wd
        out[1] += wr
        out[2] += w0
        out[3] += w1
        out[4] += w2
        out[5] += w01
        out[6] += w12
        out[7] += w20
        out[8] += w00
        out[9] += w11
        out[10] += w22
        out[11] += a0
        out[12] += a1
        out[13] += a2
        out[14] += c0
        out[15] += c1
        out[16] += c2
        out[17] += s0
        out[18] += s1
        out[19] += s2
        out[20] += d0
        out[21] += d1
        out[22] += d2
        out[23] += d3
        out[24] += d4


@njit(cache=True, fastmath=False, nogil=True)
def basis_residuals(cos_sin, y, r, k, out):  # noqa: ANN001, ANN201
    """``out = (y - r) - b . k`` per sample, ``b`` from ``cos_sin`` as in :func:`gram`."""
    for i in range(out.shape[0]):
        c = cos_sin[0, i]
        s = cos_sin[1, i]
        out[i] = (y[i] - r[i]) - (k[0] + k[1] * c + k[2] * s + k[3] * (c * c - s * s)
                                  + k[4] * (s * c + c * s))
