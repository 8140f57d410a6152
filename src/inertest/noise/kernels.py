"""Fused numba kernels: sums of squared phase differences, one pass, no temporaries.

Each kernel receives *windows* of the phase record (views of one array in memory, or chunk
buffers of the one-pass streaming engine in :mod:`inertest.noise.deviations`); both paths form
every difference with the same expression, so they agree to round-off in the order of the sums
(NIST SP 1065 eqs. 7-25). The whole-record kernels trade a fixed summation order for SIMD lanes,
cache tiles and shared loads (several octaves per pass, four interleaved modified-Allan
recursions, tiled lag-1 sums); tests hold them to the sequential sums within 1e-12.
"""

from __future__ import annotations

import numba
import numpy as np
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


#: Samples per tile of the phase's running sum (:func:`integrate`, :func:`integrate_fused`).
TILE = 4096


@numba.njit(cache=True, nogil=True)
def integrate(y: NDArray, mean: float, first: int, base: float, c: float, tau0: float,
              out: NDArray) -> tuple[float, float]:
    """Phase from rates, summed tile by tile: ``out[k] = tau0 (base + c)`` after sample k - 1.

    The running sum of ``y - mean`` restarts at every sample whose index in the record is a
    multiple of :data:`TILE`, and the finished tile's sum is added to ``base`` (the sum of the
    tiles before), so its rounding does not pile up over the record; these are the sums of
    :func:`integrate_fused`, whatever piece of the record a call integrates. ``y`` holds the
    samples ``first, first + 1, ...`` of the record (float32 or float64: converted exactly, one
    sample at a time), ``(base, c)`` is the state after sample ``first - 1`` (``(0, 0)`` at the
    start), ``out`` has ``len(y) + 1`` elements (``out[0]`` the phase at ``first``). Returns
    the state after the last sample, from which the next call continues.
    """
    n = y.shape[0]
    out[0] = tau0 * (base + c)
    i = 0
    k = first
    while i < n:
        if k % TILE == 0 and k > 0:
            base += c
            c = 0.0
        stop = min(n, i + TILE - k % TILE)
        for j in range(i, stop):
            c += y[j] - mean
            out[j + 1] = tau0 * (base + c)
        k += stop - i
        i = stop
    return base, c


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


# --------------------------------------------------------------------------- whole-record sums
# One call per statistic for a phase record held in memory: the per-tau Python overhead of a
# dense tau grid (``taus="all"``: one tau per sample interval) is gone, and TOTDEV reads the
# reflected phase by index instead of building two reflected copies of the record per tau.


@numba.njit(cache=True, nogil=True, fastmath=True)
def _ssq2_octave(x0: NDArray, x1: NDArray, x2: NDArray, x4: NDArray,
                 x8: NDArray) -> tuple[float, float, float]:
    """:func:`_ssq2` at m, 2m and 4m in one pass (windows at lags 0, m, 2m, 4m, 8m).

    The three sums share their loads (``x[i]``, ``x[i+2m]``, ``x[i+4m]``), which is what
    bounds :func:`_ssq2`; each difference is the same expression as there.
    """
    a = 0.0
    b = 0.0
    c = 0.0
    for i in range(x0.shape[0]):
        u0 = x0[i]
        u2 = x2[i]
        u4 = x4[i]
        d = u2 - 2.0 * x1[i] + u0
        e = u4 - 2.0 * u2 + u0
        f = x8[i] - 2.0 * u4 + u0
        a += d * d
        b += e * e
        c += f * f
    return a, b, c


#: Terms per tile of :func:`allan_sums`: the windows of the short taus stay in L2 between them.
_ALLAN_TILE = 1 << 16


@numba.njit(cache=True, nogil=True)
def allan_sums(x: NDArray, ms: NDArray, terms: NDArray, strided: bool) -> NDArray:
    """Sums of squared second differences of ``x`` at each averaging factor ``ms[k]``.

    ``terms[k]`` differences ``x[i+2m] - 2 x[i+m] + x[i]`` for ``i = 0, 1, ...`` (overlapping
    Allan, SP 1065 eq. 11) or ``i = 0, m, 2m, ...`` (``strided``: non-overlapping, eq. 7).
    Overlapping sums at three successive octaves (m, 2m, 4m) are taken in one pass over the
    terms they share, then each over its own remaining terms; every tau is summed tile by
    tile of terms, so that the record is read from the cache rather than from memory.
    """
    out = np.zeros(ms.size)
    if strided:
        for k in range(ms.size):
            m = ms[k]
            span = (terms[k] - 1) * m + 1
            out[k] = sum_second_diff(x[:span], x[m : m + span], x[2 * m : 2 * m + span], m)
        return out
    # groups: (first index, size 1 or 3, terms summed together)
    first = np.empty(ms.size, dtype=np.int64)
    size = np.empty(ms.size, dtype=np.int64)
    common = np.empty(ms.size, dtype=np.int64)
    g = 0
    k = 0
    while k < ms.size:
        m = ms[k]
        first[g] = k
        if k + 2 < ms.size and ms[k + 1] == 2 * m and ms[k + 2] == 4 * m:
            size[g] = 3
            common[g] = min(terms[k], terms[k + 1], terms[k + 2])
        else:
            size[g] = 1
            common[g] = terms[k]
        k += size[g]
        g += 1
    longest = 0
    for j in range(g):
        longest = max(longest, common[j])
    tile = _ALLAN_TILE
    for a in range(0, longest, tile):
        for j in range(g):
            b = min(a + tile, common[j])
            if b <= a:
                continue
            k = first[j]
            m = ms[k]
            if size[j] == 3:
                p, q, r = _ssq2_octave(x[a:b], x[a + m : b + m], x[a + 2 * m : b + 2 * m],
                                       x[a + 4 * m : b + 4 * m], x[a + 8 * m : b + 8 * m])
                out[k] += p
                out[k + 1] += q
                out[k + 2] += r
            else:
                out[k] += _ssq2(x[a:b], x[a + m : b + m], x[a + 2 * m : b + 2 * m])
    for j in range(g):  # the terms of the shorter taus of a group beyond their common ones
        if size[j] == 3:
            n = common[j]
            for k in range(first[j], first[j] + 3):
                mk = ms[k]
                nk = terms[k]
                if nk > n:
                    out[k] += _ssq2(x[n:nk], x[n + mk : nk + mk], x[n + 2 * mk : nk + 2 * mk])
    return out


@numba.njit(cache=True, nogil=True)
def hadamard_sums(x: NDArray, ms: NDArray, terms: NDArray, strided: bool) -> NDArray:
    """Sums of squared third differences (Hadamard, SP 1065 eqs. 17-18), as :func:`allan_sums`.

    Non-overlapping sums (``strided``) run over a contiguous copy of ``x[0], x[m], ...``.
    """
    out = np.empty(ms.size)
    for k in range(ms.size):
        m = ms[k]
        if strided and m > 1:  # gathered tile by tile: SIMD sums
            out[k] = _lag1_two_strided(x, m, terms[k] + 2, np.zeros((2, LAG1_FIELDS)), True)
        elif strided:
            n = terms[k]
            out[k] = _ssq3(x[:n], x[1 : n + 1], x[2 : n + 2], x[3 : n + 3])
        else:
            n = terms[k]
            out[k] = _ssq3(x[:n], x[m : m + n], x[2 * m : 2 * m + n], x[3 * m : 3 * m + n])
    return out


@numba.njit(cache=True, nogil=True)
def _modified_window(x: NDArray, m: int, j: int) -> float:
    """``s_j = sum_{i=j}^{j+m-1} (x[i+2m] - 2 x[i+m] + x[i])``, summed in order."""
    s = 0.0
    for i in range(j, j + m):
        s += x[i + 2 * m] - 2.0 * x[i + m] + x[i]
    return s


@numba.njit(cache=True, nogil=True, fastmath=True)
def _second_diff_total(x: NDArray, m: int, a: int, b: int) -> float:
    """``sum_{i=a}^{b-1} (x[i+2m] - 2 x[i+m] + x[i])`` in SIMD lanes."""
    x0 = x[a:b]
    x1 = x[a + m : b + m]
    x2 = x[a + 2 * m : b + 2 * m]
    s = 0.0
    for i in range(b - a):
        s += x2[i] - 2.0 * x1[i] + x0[i]
    return s


@numba.njit(cache=True, nogil=True)
def _modified_windows4(x: NDArray, m: int, j: int, gap: int
                       ) -> tuple[float, float, float, float]:
    """Window sums ``s_i = sum_{k=i}^{i+m-1} d[k]`` at ``i = j + r gap`` (r = 0..3).

    The windows overlap when ``gap < m``: the second differences are summed once per
    segment between window edges (in SIMD lanes), and each window adds its segments in order,
    so no difference is formed twice (at m = N/5 the windows would otherwise read the record
    nearly twice).
    """
    if gap >= m:  # disjoint windows
        return (_second_diff_total(x, m, j, j + m),
                _second_diff_total(x, m, j + gap, j + gap + m),
                _second_diff_total(x, m, j + 2 * gap, j + 2 * gap + m),
                _second_diff_total(x, m, j + 3 * gap, j + 3 * gap + m))
    edges = np.empty(8, dtype=np.int64)
    for r in range(4):
        edges[2 * r] = j + r * gap
        edges[2 * r + 1] = j + r * gap + m
    edges = np.unique(edges)
    out = np.zeros(4)
    for e in range(edges.size - 1):
        a, b = edges[e], edges[e + 1]
        seg = 0.0
        used = False
        for r in range(4):
            lo = j + r * gap
            if lo <= a and b <= lo + m:
                if not used:
                    seg = _second_diff_total(x, m, a, b)
                    used = True
                out[r] += seg
    return out[0], out[1], out[2], out[3]


@numba.njit(cache=True, nogil=True)
def _modified_steps(x: NDArray, m: int, j: int, count: int, out: NDArray) -> None:
    """``out[k] = d[j+k+m] - d[j+k]`` for ``k < count``: steps of the window sum (SIMD)."""
    x0 = x[j : j + count]
    x1 = x[j + m : j + m + count]
    x2 = x[j + 2 * m : j + 2 * m + count]
    x3 = x[j + 3 * m : j + 3 * m + count]
    for k in range(count):
        out[k] = (x3[k] - 2.0 * x2[k] + x1[k]) - (x2[k] - 2.0 * x1[k] + x0[k])


@numba.njit(cache=True, nogil=True)
def _modified_steps_pair(x: NDArray, m: int, j: int, count: int, out: NDArray,
                         dl: NDArray) -> None:
    """:func:`_modified_steps`, keeping the second differences ``d[j+k]`` in ``dl``."""
    x0 = x[j : j + count]
    x1 = x[j + m : j + m + count]
    x2 = x[j + 2 * m : j + 2 * m + count]
    x3 = x[j + 3 * m : j + 3 * m + count]
    for k in range(count):
        lo = x2[k] - 2.0 * x1[k] + x0[k]
        hi = x3[k] - 2.0 * x2[k] + x1[k]
        out[k] = hi - lo
        dl[k] = lo


#: Terms per tile of :func:`_modified_one` (four lanes of steps stay in L1).
_MOD_TILE = 1024


@numba.njit(cache=True, nogil=True)
def _modified_group(x: NDArray, m: int, j: int, gap: int, last: int, bufs: NDArray,
                    pair: bool) -> tuple[float, float]:
    """Four interleaved runs of the modified-Allan recursion, and their second differences.

    Runs start at ``j + r gap`` (r = 0..3); runs 0-2 have ``gap`` terms, run 3 ``last >= gap``.
    Each starts from its window sum ``s`` summed directly (:func:`_modified_windows4`) and
    follows ``s_{i+1} = s_i + (d[i+m] - d[i])`` (``d`` the second differences, the expression of
    :func:`sum_modified`). The steps of a tile are formed in SIMD lanes; the four recursions then
    run interleaved, so their additions overlap in the pipeline. Returns the sum of ``s_i**2``
    over the ``3 gap + last`` terms and, with ``pair``, the sum of ``d[i]**2`` over the same
    indices (overlapping Allan, for R(n)); ``bufs`` is scratch of shape (5, _MOD_TILE).
    """
    j0, j1, j2, j3 = j, j + gap, j + 2 * gap, j + 3 * gap
    s0, s1, s2, s3 = _modified_windows4(x, m, j, gap)
    a0 = a1 = a2 = a3 = 0.0
    oa = 0.0
    tile = bufs.shape[1]
    b0, b1, b2, b3, dl = bufs[0], bufs[1], bufs[2], bufs[3], bufs[4]
    for k0 in range(0, gap - 1, tile):
        cnt = min(tile, gap - 1 - k0)
        if pair:
            _modified_steps_pair(x, m, j0 + k0, cnt, b0, dl)
            oa += _sumsq(dl, cnt)
            _modified_steps_pair(x, m, j1 + k0, cnt, b1, dl)
            oa += _sumsq(dl, cnt)
            _modified_steps_pair(x, m, j2 + k0, cnt, b2, dl)
            oa += _sumsq(dl, cnt)
            _modified_steps_pair(x, m, j3 + k0, cnt, b3, dl)
            oa += _sumsq(dl, cnt)
        else:
            _modified_steps(x, m, j0 + k0, cnt, b0)
            _modified_steps(x, m, j1 + k0, cnt, b1)
            _modified_steps(x, m, j2 + k0, cnt, b2)
            _modified_steps(x, m, j3 + k0, cnt, b3)
        for k in range(cnt):
            a0 += s0 * s0
            a1 += s1 * s1
            a2 += s2 * s2
            a3 += s3 * s3
            s0 += b0[k]
            s1 += b1[k]
            s2 += b2[k]
            s3 += b3[k]
    a0 += s0 * s0
    a1 += s1 * s1
    a2 += s2 * s2
    m2, m3 = 2 * m, 3 * m
    end = j3 + last
    for i in range(j3 + gap - 1, end):  # run 3 takes the remainder
        a3 += s3 * s3
        if i < end - 1:
            s3 += ((x[i + m3] - 2.0 * x[i + m2] + x[i + m])
                   - (x[i + m2] - 2.0 * x[i + m] + x[i]))
    if pair:  # second differences the steps did not visit: each run's last, run 3's rest
        for i in (j1 - 1, j2 - 1, j3 - 1):
            d = x[i + m2] - 2.0 * x[i + m] + x[i]
            oa += d * d
        for i in range(j3 + gap - 1, end):
            d = x[i + m2] - 2.0 * x[i + m] + x[i]
            oa += d * d
    return (a0 + a1) + (a2 + a3), oa


@numba.njit(cache=True, nogil=True)
def _modified_one(x: NDArray, m: int, n: int) -> float:
    """Sum of ``s_j**2`` for ``j < n`` (modified Allan, SP 1065 eq. 14) in four runs.

    The terms are cut into four runs (:func:`_modified_group`); restarting every quarter
    bounds the round-off the recursion carries. Fewer than 64 terms: the sequential recursion.
    """
    if n < 64:  # too short for four runs
        acc, s = sum_modified(x[: n - 1], x[m : m + n - 1], x[2 * m : 2 * m + n - 1],
                              x[3 * m : 3 * m + n - 1], _modified_window(x, m, 0), n - 1)
        return acc + s * s
    q = n // 4
    return _modified_group(x, m, 0, q, n - 3 * q, np.empty((5, _MOD_TILE)), False)[0]


@numba.njit(cache=True, nogil=True, fastmath=True)
def _sumsq(b: NDArray, n: int) -> float:
    """Sum of ``b[k]**2`` for ``k < n`` (SIMD lanes)."""
    s = 0.0
    for k in range(n):
        s += b[k] * b[k]
    return s


@numba.njit(cache=True, nogil=True)
def _decimate_into(x: NDArray, m: int, count: int, scratch: NDArray, have: int) -> bool:
    """Put ``x[0], x[m], ..., x[count m]`` in ``scratch[: count + 1]``; True when done.

    ``scratch`` holds ``x`` decimated by ``have`` (0: nothing yet). When ``m`` is a multiple
    of ``have`` the points are taken from there, in place (index ``k r >= k``, ascending): the
    octave grid reads each decimation from the previous one, half as long, not from the record.
    """
    if scratch.shape[0] < count + 1:
        return False
    if have > 0 and m % have == 0:
        r = m // have
        if r == 1:  # already there
            return True
        src = scratch[: count * r + 1 : r]  # views: no wraparound checks in the loops
    else:
        src = x[: count * m + 1 : m]
    dst = scratch[: count + 1]
    for k in range(count + 1):
        dst[k] = src[k]
    return True


@numba.njit(cache=True, nogil=True)
def lag1_rows_many(x: NDArray, ms: NDArray, scratch: NDArray, have: int) -> NDArray:
    """:func:`lag1_first_two` at every ``ms[k]`` (ascending), shape (ms.size, 2, LAG1_FIELDS).

    Each decimated series from m = 4 on is taken from the previous one where the factors
    allow (see :func:`_decimate_into`), starting from ``scratch`` (``x`` decimated by
    ``have``, overwritten; empty and 0: nothing yet); m = 2, 3 are read strided from ``x`` (a
    fresh copy of half the record costs more in page faults than it saves); the same numbers
    as :func:`lag1_first_two`.
    """
    rows = np.zeros((ms.size, 2, LAG1_FIELDS))
    nx = x.shape[0]
    for k in range(ms.size):
        m = ms[k]
        count = (nx - 1) // m
        if count < 2:
            continue
        if m == 1:
            _lag1_two(x[: count + 1], rows[k])
            continue
        if m < 4:  # no copy of half the record (a fresh one costs its page faults)
            _lag1_two_strided(x, m, count, rows[k], False)
            continue
        if scratch.shape[0] == 0:
            scratch = np.empty(count + 1)
        if _decimate_into(x, m, count, scratch, have):
            _lag1_two(scratch[: count + 1], rows[k])
            have = m
        else:
            _lag1_two_strided(x, m, count, rows[k], False)
    return rows


@numba.njit(cache=True, nogil=True)
def hadamard_decimated(x: NDArray, ms: NDArray, terms: NDArray) -> tuple[NDArray, NDArray]:
    """Non-overlapping Hadamard sums and the noise-type rows 0-1 of each ``m``, in one pass.

    The terms of HDEV at ``m`` are the third differences of ``x[0], x[m], ..., x[count m]``,
    the very series whose lag-1 sums identify the noise type (``count = terms + 2``): one
    pass over it gives :func:`hadamard_sums` (``strided``) and :func:`lag1_first_two`, each
    series taken from the previous one where the factors allow (:func:`_decimate_into`).
    Returns the sums and the (ms.size, 2, LAG1_FIELDS) rows.
    """
    out = np.empty(ms.size)
    rows = np.zeros((ms.size, 2, LAG1_FIELDS))
    first = 1 if ms.size > 0 and ms[0] == 1 else 0
    if first:  # the record itself: no copy
        n = terms[0]
        out[0] = _lag1_two(x[: n + 3], rows[0], True)
    if ms.size > first:
        out[first:], rows[first:] = hadamard_from(x, ms[first:], terms[first:],
                                                  np.empty(terms[first] + 3), 0)
    return out, rows


@numba.njit(cache=True, nogil=True)
def modified_sums(x: NDArray, ms: NDArray, terms: NDArray) -> NDArray:
    """Sums of squared window sums of second differences (modified Allan, SP 1065 eq. 14).

    The recursion of :func:`sum_modified` over the whole record, in four interleaved runs.
    """
    out = np.empty(ms.size)
    for k in range(ms.size):
        out[k] = _modified_one(x, ms[k], terms[k])
    return out


@numba.njit(cache=True, nogil=True)
def _reflected(x: NDArray, t: int) -> float:
    """``x*[t]`` of SP 1065 eq. 25: the phase reflected about both end points."""
    last = x.shape[0] - 1
    if t < 0:
        return 2.0 * x[0] - x[-t]
    if t > last:
        return 2.0 * x[last] - x[2 * last - t]
    return x[t]


@numba.njit(cache=True, nogil=True)
def total_sums(x: NDArray, ms: NDArray) -> NDArray:
    """TOTVAR sums ``sum_{i=1}^{N-2} (x*[i-m] - 2 x[i] + x*[i+m])^2`` (SP 1065 eq. 25).

    The reflected phase ``x*`` is read by index; no copy of the record is made.
    """
    nx = x.shape[0]
    out = np.empty(ms.size)
    for k in range(ms.size):
        m = ms[k]
        lo = min(max(1, m), nx - 1)  # i >= lo: no reflection at the start
        hi = max(lo, nx - 1 - m)  # i < hi: no reflection at the end
        s = 0.0
        for i in range(1, lo):
            d = _reflected(x, i - m) - 2.0 * x[i] + _reflected(x, i + m)
            s += d * d
        if hi > lo:
            s += _ssq2(x[lo - m : hi - m], x[lo:hi], x[lo + m : hi + m])
        for i in range(max(lo, hi), nx - 1):
            d = _reflected(x, i - m) - 2.0 * x[i] + _reflected(x, i + m)
            s += d * d
        out[k] = s
    return out


# --------------------------------------------------------------------------- lag-1 noise type
# State of one differenced series, per difference order d (row d of a (dmax + 1, 10) array):
# count, shift (its first value), sum v, sum v^2, sum v_i v_{i+1}, first v, last v, last raw value,
# sum i v_i, sum i^2 v_i (v = value - shift, i = 0, 1, ... the index in that series: the index
# moments let the noise identification remove a polynomial trend, confidence.r1_of_state).
# The differences are formed on the fly, so no differenced copy is made.
LAG1_FIELDS = 10


@numba.njit(cache=True, nogil=True)
def _lag1_step(val: float, state: NDArray) -> None:
    """One value into the sums of every difference order (start-up: orders not yet begun)."""
    for d in range(state.shape[0]):
        row = state[d]
        if row[0] == 0.0:
            row[1] = val
            v = 0.0
            row[5] = v
        else:
            v = val - row[1]
            row[4] += row[6] * v
        row[2] += v
        row[3] += v * v
        i = row[0]
        row[8] += i * v
        row[9] += i * i * v
        row[6] = v
        prev = row[7]
        had = row[0] > 0.0
        row[7] = val
        row[0] += 1.0
        if not had:
            return  # the next order starts with the next value
        val = val - prev


@numba.njit(cache=True, nogil=True)
def lag1_update(z: NDArray, state: NDArray) -> None:
    """Feed the next values ``z`` of a series into the lag-1 sums of its differences.

    ``state`` has one row per difference order (see ``LAG1_FIELDS``), updated in place; row 0
    is the series itself, row d its d-th difference (as ``np.diff`` d times). Riley & Greenhall
    (2004) eq. 2 needs only these running sums. Once every order has begun, the sums run in
    local variables (up to 4 orders: dmax 3).
    """
    orders = state.shape[0]
    i = 0
    nz = z.shape[0]
    while i < nz and state[orders - 1, 0] == 0.0:
        _lag1_step(z[i], state)
        i += 1
    if i >= nz:
        return
    if orders > 4:
        for k in range(i, nz):
            _lag1_step(z[k], state)
        return
    # every order has begun: sums in registers
    sh = np.zeros(4)
    s1 = np.zeros(4)
    s2 = np.zeros(4)
    s11 = np.zeros(4)
    lv = np.zeros(4)
    raw = np.zeros(4)
    for d in range(orders):
        sh[d] = state[d, 1]
        s1[d] = state[d, 2]
        s2[d] = state[d, 3]
        s11[d] = state[d, 4]
        lv[d] = state[d, 6]
        raw[d] = state[d, 7]
    sh0, sh1, sh2, sh3 = sh[0], sh[1], sh[2], sh[3]
    # index moments: order d's next value has index state[d, 0] (+ the values fed since)
    base = np.zeros(4)
    t1 = np.zeros(4)
    t2 = np.zeros(4)
    for d in range(orders):
        base[d] = state[d, 0] - i
        t1[d] = state[d, 8]
        t2[d] = state[d, 9]
    i0, i1, i2, i3 = base[0], base[1], base[2], base[3]
    e1, e2, e3, e4 = t1[0], t1[1], t1[2], t1[3]
    f1, f2, f3, f4 = t2[0], t2[1], t2[2], t2[3]
    a1, a2, a3, a4 = s1[0], s1[1], s1[2], s1[3]
    b1, b2, b3, b4 = s2[0], s2[1], s2[2], s2[3]
    c1, c2, c3, c4 = s11[0], s11[1], s11[2], s11[3]
    l1, l2, l3, l4 = lv[0], lv[1], lv[2], lv[3]
    r0, r1, r2, r3 = raw[0], raw[1], raw[2], raw[3]
    for k in range(i, nz):
        fk = float(k)
        z0 = z[k]
        v = z0 - sh0
        c1 += l1 * v
        a1 += v
        b1 += v * v
        l1 = v
        j = i0 + fk
        e1 += j * v
        f1 += j * j * v
        if orders > 1:
            z1 = z0 - r0
            v = z1 - sh1
            c2 += l2 * v
            a2 += v
            b2 += v * v
            l2 = v
            j = i1 + fk
            e2 += j * v
            f2 += j * j * v
            if orders > 2:
                z2 = z1 - r1
                v = z2 - sh2
                c3 += l3 * v
                a3 += v
                b3 += v * v
                l3 = v
                j = i2 + fk
                e3 += j * v
                f3 += j * j * v
                if orders > 3:
                    z3 = z2 - r2
                    v = z3 - sh3
                    c4 += l4 * v
                    a4 += v
                    b4 += v * v
                    l4 = v
                    j = i3 + fk
                    e4 += j * v
                    f4 += j * j * v
                    r3 = z3
                r2 = z2
            r1 = z1
        r0 = z0
    cnt = float(nz - i)
    vals = ((a1, b1, c1, l1, r0, e1, f1), (a2, b2, c2, l2, r1, e2, f2),
            (a3, b3, c3, l3, r2, e3, f3), (a4, b4, c4, l4, r3, e4, f4))
    for d in range(orders):
        state[d, 0] += cnt
        state[d, 2] = vals[d][0]
        state[d, 3] = vals[d][1]
        state[d, 4] = vals[d][2]
        state[d, 6] = vals[d][3]
        state[d, 7] = vals[d][4]
        state[d, 8] = vals[d][5]
        state[d, 9] = vals[d][6]


@numba.njit(cache=True, nogil=True)
def lag1_extend(z: NDArray, state: NDArray) -> None:
    """:func:`lag1_update` with the sums of each tile in SIMD lanes (streamed records).

    The differences are formed by the same subtractions, carried across blocks by the last
    raw value of each order; only the order of the additions differs (round-off).
    """
    orders = state.shape[0]
    i = 0
    nz = z.shape[0]
    while i < nz and state[orders - 1, 0] == 0.0:
        _lag1_step(z[i], state)
        i += 1
    if i >= nz:
        return
    tile = _LAG1_TILE
    buf = np.empty((orders, tile))
    for t0 in range(i, nz, tile):
        cnt = min(tile, nz - t0)
        for k in range(cnt):
            buf[0, k] = z[t0 + k]
        for d in range(1, orders):
            buf[d, 0] = buf[d - 1, 0] - state[d - 1, 7]
            for k in range(1, cnt):
                buf[d, k] = buf[d - 1, k] - buf[d - 1, k - 1]
        for d in range(orders):
            row = state[d]
            sh = row[1]
            s1, s2, s11, t1, t2 = _moments(buf[d], cnt, sh, row[0])
            row[0] += cnt
            row[2] += s1
            row[3] += s2
            row[4] += s11 + row[6] * (buf[d, 0] - sh)
            row[8] += t1
            row[9] += t2
            row[6] = buf[d, cnt - 1] - sh
            row[7] = buf[d, cnt - 1]


@numba.njit(cache=True, nogil=True)
def r1_detrended(rows: NDArray, degree: NDArray) -> NDArray:
    """Lag-1 autocorrelation of each row's series less its polynomial trend.

    ``confidence.r1_detrended`` documents the arithmetic; one loop, no temporaries.
    """
    out = np.zeros(rows.shape[0])
    for r in range(rows.shape[0]):
        row = rows[r]
        n = row[0]
        if n < 1:
            continue
        s1, s2, s11, first, last, t1, t2 = row[2], row[3], row[4], row[5], row[6], row[8], row[9]
        mean = s1 / n
        if degree[r] <= 0:  # the mean: the expressions used before the index moments
            den = s2 - n * mean * mean
            num = s11 - mean * (2.0 * s1 - first - last) + (n - 1) * mean * mean
        else:
            c = (n - 1.0) / 2.0
            m1 = t1 - c * s1  # sum u v, u = i - c
            m2 = t2 - 2.0 * c * t1 + c * c * s1  # sum u^2 v
            u2 = n * (n * n - 1.0) / 12.0  # sum u^2
            u4 = n * (n * n - 1.0) * (3.0 * n * n - 7.0) / 240.0  # sum u^4
            b1 = m1 / u2 if u2 > 0 else 0.0
            q = u4 - u2 * u2 / n
            p2 = m2 - (u2 / n) * s1  # sum (u^2 - U2/n) v
            b2 = p2 / q if (degree[r] >= 2 and q > 0) else 0.0
            b0 = mean - b2 * u2 / n  # trend f(u) = b0 + b1 u + b2 u^2
            den = s2 - s1 * mean - b1 * m1 - b2 * p2
            g0, g1 = b0 + b1 + b2, b1 + 2.0 * b2  # f(u + 1)
            h0, h1 = b0 - b1 + b2, b1 - 2.0 * b2  # f(u - 1)
            fc = b0 + b1 * c + b2 * c * c
            fc1 = b0 + b1 * (c + 1.0) + b2 * (c + 1.0) * (c + 1.0)
            fm = b0 - b1 * (c + 1.0) + b2 * (c + 1.0) * (c + 1.0)  # f(-c - 1)
            a = g0 * s1 + g1 * m1 + b2 * m2 - last * fc1  # sum_{i<n-1} v_i f(u_i + 1)
            b = h0 * s1 + h1 * m1 + b2 * m2 - first * fm  # sum_{i<n-1} f(u_i) v_{i+1}
            cc = (b0 * g0 * n + (b0 * b2 + b1 * g1 + b2 * g0) * u2 + b2 * b2 * u4
                  - fc * fc1)  # sum_{i<n-1} f(u_i) f(u_i + 1)
            num = s11 - a - b + cc
        if den > 0:
            out[r] = num / den
    return out


@numba.njit(cache=True, nogil=True)
def lag1_decide_two(rows: NDArray, detrend: int, alpha_min: int, undecided: int) -> NDArray:
    """Riley & Greenhall's decision at orders 0-1 for many taus (phase data).

    ``rows`` (K, 2, LAG1_FIELDS): the decimated phase less a trend of degree ``detrend`` and
    its first difference less one of ``detrend - 1`` (:func:`r1_detrended`); the first order
    with ``delta = r1/(1 + r1) < 0.25`` gives ``alpha = round(-2 delta) + 2 - 2 d`` clipped to
    ``alpha_min .. 2`` (``confidence.alpha_from_lag1``); ``undecided`` where neither does.
    """
    k = rows.shape[0]
    flat = rows.reshape(2 * k, rows.shape[2])
    deg = np.empty(2 * k, dtype=np.int64)
    for i in range(k):
        deg[2 * i] = detrend
        deg[2 * i + 1] = max(0, detrend - 1)
    r1 = r1_detrended(flat, deg)
    out = np.empty(k, dtype=np.int64)
    for i in range(k):
        out[i] = undecided
        for d in range(2):
            r = r1[2 * i + d]
            delta = r / (1.0 + r) if r > -1.0 else -1.0
            if delta < 0.25:
                a = int(np.round(-2.0 * delta)) + 2 - 2 * d
                out[i] = min(2, max(alpha_min, a))
                break
    return out


@numba.njit(cache=True, nogil=True)
def lag1_state_of(x: NDArray, m: int, count: int, orders: int) -> NDArray:
    """Lag-1 sums of ``x[0], x[m], ..., x[count m]`` and its differences (whole record)."""
    state = np.zeros((orders, LAG1_FIELDS))
    lag1_update(x[: count * m + 1 : m], state)
    return state


@numba.njit(cache=True, nogil=True, fastmath=True)
def _moments(b: NDArray, n: int, shift: float, base: float
             ) -> tuple[float, float, float, float, float]:
    """Sums of ``v``, ``v**2``, ``v_k v_{k+1}`` (pairs: ``k < n - 1``), ``i v_k``, ``i**2 v_k``.

    ``v = b[k] - shift`` for ``k < n``; ``i = base + k`` is the index in the whole series.
    """
    s1 = 0.0
    s2 = 0.0
    s11 = 0.0
    t1 = 0.0
    t2 = 0.0
    for k in range(n - 1):
        v = b[k] - shift
        s1 += v
        s2 += v * v
        s11 += v * (b[k + 1] - shift)
        j = base + k
        t1 += j * v
        t2 += j * j * v
    if n > 0:
        v = b[n - 1] - shift
        s1 += v
        s2 += v * v
        j = base + (n - 1)
        t1 += j * v
        t2 += j * j * v
    return s1, s2, s11, t1, t2


#: Decimated points per tile of :func:`lag1_sums` (the tile and its differences stay in L1).
_LAG1_TILE = 2048


@numba.njit(cache=True, nogil=True)
def _first_difference_moments(state: NDArray) -> None:
    """Index moments of row 1 (first differences) from those of row 0, by summation by parts.

    With ``v_k`` the series (row 0, ``N + 1`` points) and ``w_k = (v_{k+1} - v_k) - sh1``:
    ``sum k w_k = N v_N - sum v + v_0 - sh1 N(N-1)/2`` and ``sum k^2 w_k = sum v - v_0 -
    2 sum k v + N^2 v_N - sh1 (N-1) N (2N-1)/6`` (exact for exact differences; the rounded
    ones differ by eps |v| per point, far below what a noise-type decision reads), so the
    SIMD loops need not carry them.
    """
    big_n = state[0, 0] - 1.0
    s0, v0, vn, t1 = state[0, 2], state[0, 5], state[0, 6], state[0, 8]
    sh1 = state[1, 1]
    state[1, 8] = big_n * vn - s0 + v0 - sh1 * big_n * (big_n - 1.0) / 2.0
    state[1, 9] = (s0 - v0 - 2.0 * t1 + big_n * big_n * vn
                   - sh1 * (big_n - 1.0) * big_n * (2.0 * big_n - 1.0) / 6.0)


@numba.njit(cache=True, nogil=True)
def _store_rows(state: NDArray, npts: int, sh0: float, sh1: float, last: float, prev: float,
                p1: float, p2: float, p11: float, q1: float, q2: float, q11: float,
                pk: float, pkk: float) -> None:
    """Rows 0-1 (``LAG1_FIELDS`` each) of a series of ``npts`` points ending ``prev, last``.

    ``p*``: sums of row 0 (v = value - sh0; v_0 = 0, so field 5 stays 0), ``q*`` of row 1, the
    index moments of row 0; row 1's follow (:func:`_first_difference_moments`).
    """
    state[0, 0] = npts
    state[0, 1] = sh0
    state[0, 2] = p1
    state[0, 3] = p2
    state[0, 4] = p11
    state[0, 6] = last - sh0
    state[0, 7] = last
    state[0, 8] = pk
    state[0, 9] = pkk
    state[1, 0] = npts - 1
    state[1, 1] = sh1
    state[1, 2] = q1
    state[1, 3] = q2
    state[1, 4] = q11
    state[1, 6] = (last - prev) - sh1
    state[1, 7] = last - prev
    _first_difference_moments(state)


@numba.njit(cache=True, nogil=True)
def _lag1_two(a: NDArray, state: NDArray, ssq3: bool = False) -> float:
    """Rows 0 and 1 of :func:`lag1_sums` for the series ``a`` (``a.size >= 3``), one pass.

    With ``ssq3``, also returns the sum of the squared third differences of ``a`` (the
    non-overlapping Hadamard sum when ``a`` is the decimated phase), taken in the same pass.
    """
    npts = a.shape[0]
    sh0 = a[0]
    sh1 = a[1] - a[0]
    acc = np.zeros(9)
    _rows_range(a, 0, npts, npts, sh0, sh1, acc, ssq3, 0)
    _store_rows(state, npts, sh0, sh1, a[npts - 1], a[npts - 2], acc[0], acc[1], acc[2],
                acc[3], acc[4], acc[5], acc[7], acc[8])
    return acc[6]


@numba.njit(cache=True, nogil=True)
def _lag1_two_strided(x: NDArray, m: int, count: int, state: NDArray,
                      ssq3: bool) -> float:
    """Rows 0-1 of ``x[0], x[m], ..., x[count m]`` by tiles gathered into a small buffer.

    No copy of the decimated series is made (a fresh array of N/2 points costs more in page
    faults than the sums). Each tile's sums are :func:`_rows_range`'s on the buffer (three
    points of look-ahead); with ``ssq3``, also returns the sum of the squared third
    differences (non-overlapping Hadamard).
    """
    npts = count + 1
    tile = _LAG1_TILE
    buf = np.empty(tile + 3)
    acc = np.zeros(9)
    sh0 = x[0]
    sh1 = x[m] - x[0]
    for t0 in range(0, npts, tile):
        w = min(tile + 3, npts - t0)
        for k in range(w):
            buf[k] = x[(t0 + k) * m]
        _rows_range(buf, 0, min(tile, npts - t0), npts - t0, sh0, sh1, acc, ssq3, t0)
    _store_rows(state, npts, sh0, sh1, x[count * m], x[(count - 1) * m], acc[0], acc[1],
                acc[2], acc[3], acc[4], acc[5], acc[7], acc[8])
    return acc[6]


@numba.njit(cache=True, nogil=True)
def lag1_first_two(x: NDArray, m: int, count: int) -> NDArray:
    """Rows 0 and 1 of :func:`lag1_sums` (the decimated phase and its first difference).

    One fused SIMD pass over ``x[0], x[m], ..., x[count m]`` (``count >= 2``); most noise
    types are decided on these two rows (Riley & Greenhall 2004).
    """
    state = np.zeros((2, LAG1_FIELDS))
    if m == 1:
        _lag1_two(x[: count + 1], state)  # contiguous: SIMD loads
    else:
        _lag1_two_strided(x, m, count, state, False)
    return state


@numba.njit(cache=True, nogil=True)
def lag1_sums(x: NDArray, m: int, count: int, orders: int) -> NDArray:
    """Lag-1 sums of ``x[0], x[m], ..., x[count m]`` and its differences, tile by tile.

    Same rows as :func:`lag1_update` (the differences formed by the same subtractions); the
    sums of each tile run in SIMD lanes, so they differ from the sequential sums by round-off
    only. Row d holds the d-th difference; rows do not depend on how many are asked for.
    """
    npts = count + 1
    state = np.zeros((orders, LAG1_FIELDS))
    tile = _LAG1_TILE
    buf = np.empty((orders, tile + orders))
    shift = np.zeros(orders)
    for t0 in range(0, npts, tile):
        width = min(tile + orders, npts - t0)
        for k in range(width):
            buf[0, k] = x[(t0 + k) * m]
        for d in range(1, orders):
            for k in range(width - d):
                buf[d, k] = buf[d - 1, k + 1] - buf[d - 1, k]
        for d in range(orders):
            length = npts - d  # points of the d-th difference
            if t0 >= length:
                continue
            if t0 == 0:
                shift[d] = buf[d, 0]
            hi = min(t0 + tile, length)  # this tile's points: t0 .. hi - 1
            pair_hi = min(t0 + tile, length - 1)  # pairs (i, i + 1) for i < pair_hi
            s1, s2, s11, t1, t2 = _moments(buf[d], hi - t0, shift[d], float(t0))
            if pair_hi == hi:  # the pair across the tile edge
                s11 += (buf[d, hi - t0 - 1] - shift[d]) * (buf[d, hi - t0] - shift[d])
            row = state[d]
            row[2] += s1
            row[3] += s2
            row[4] += s11
            row[8] += t1
            row[9] += t2
            if hi == length:
                row[6] = buf[d, hi - 1 - t0] - shift[d]
                row[7] = buf[d, hi - 1 - t0]
    for d in range(orders):
        state[d, 0] = npts - d
        state[d, 1] = shift[d]
    return state


@numba.njit(cache=True, nogil=True)
def b1_stats(x: NDArray, m: int, count: int) -> tuple[float, float]:
    """Sample variance (ddof 1) and non-overlapping Allan variance of the frequency averages.

    ``ybar_k = x[(k+1) m] - x[k m]`` for ``k < count`` (SP 1065 5.6.2; the B1 ratio is their
    quotient, so the common factor ``1/tau`` is left out).
    """
    s = 0.0
    for k in range(count):
        s += x[(k + 1) * m] - x[k * m]
    mean = s / count
    ss = 0.0
    for k in range(count):
        d = x[(k + 1) * m] - x[k * m] - mean
        ss += d * d
    a = 0.0
    for k in range(count - 1):
        d = (x[(k + 2) * m] - x[(k + 1) * m]) - (x[(k + 1) * m] - x[k * m])
        a += d * d
    return ss / (count - 1), a / (2.0 * (count - 1))


# --------------------------------------------------------------------------- Greenhall EDF


@numba.njit(cache=True, nogil=True)
def _sw(t: float, alpha: int) -> float:
    a = abs(t)
    lg = np.log(a) if a > 0.0 else 0.0
    if alpha == 2:
        return -a
    if alpha == 1:
        return a * a * lg
    if alpha == 0:
        return a**3
    if alpha == -1:
        return -(a**4) * lg
    if alpha == -2:
        return -(a**5)
    if alpha == -3:
        return a**6 * lg
    return a**7


@numba.njit(cache=True, nogil=True)
def _sx(t: float, f: float, alpha: int) -> float:
    if np.isinf(f):
        return _sw(t, alpha + 2)
    h = 1.0 / f
    return f * f * (2.0 * _sw(t, alpha) - _sw(t - h, alpha) - _sw(t + h, alpha))


_BINOM = np.array([[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                   [1.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0],
                   [1.0, 4.0, 6.0, 4.0, 1.0, 0.0, 0.0],
                   [1.0, 6.0, 15.0, 20.0, 15.0, 6.0, 1.0]])  # C(2d, k), d = 0 .. 3


@numba.njit(cache=True, nogil=True)
def greenhall_sz(t: float, f: float, alpha: int, d: int) -> float:
    """Greenhall & Riley (2003) eq. (9): autocovariance of the d-th difference at lag t."""
    out = _BINOM[d, d] * _sx(t, f, alpha)
    sign = -1.0
    for k in range(1, d + 1):
        out = out + sign * _BINOM[d, d + k] * (_sx(t - k, f, alpha) + _sx(t + k, f, alpha))
        sign = -sign
    return out


@numba.njit(cache=True, nogil=True)
def greenhall_basic_sum(j: int, m_terms: float, s: float, f: float, alpha: int,
                        d: int) -> float:
    """Greenhall & Riley (2003) eq. (10), the basic sum, summed lag by lag."""
    mid = 0.0
    for k in range(1, j):
        v = greenhall_sz(k / s, f, alpha, d)
        mid += (1.0 - k / m_terms) * v * v
    e = greenhall_sz(j / s, f, alpha, d)
    z = greenhall_sz(0.0, f, alpha, d)
    return z * z + 2.0 * mid + (1.0 - j / m_terms) * e * e


_NAN = np.nan
# Greenhall & Riley (2003) Tables 1 and 2, indexed [2 - alpha, d - 1, (a0, a1)]; Table 3 [d - 1].
_TABLE1 = np.array([
    [[2 / 3, 1 / 3], [7 / 9, 1 / 2], [22 / 25, 2 / 3]],
    [[0.840, 0.345], [0.997, 0.616], [1.141, 0.843]],
    [[1.079, 0.368], [1.033, 0.607], [1.184, 0.848]],
    [[_NAN, _NAN], [1.048, 0.534], [1.180, 0.816]],
    [[_NAN, _NAN], [1.302, 0.535], [1.175, 0.777]],
    [[_NAN, _NAN], [_NAN, _NAN], [1.194, 0.703]],
    [[_NAN, _NAN], [_NAN, _NAN], [1.489, 0.702]],
])
_TABLE2 = np.array([
    [[3 / 2, 1 / 2], [35 / 18, 1.0], [231 / 100, 3 / 2]],
    [[78.6, 25.2], [790.0, 410.0], [9950.0, 6520.0]],
    [[2 / 3, 1 / 6], [2 / 3, 1 / 3], [7 / 9, 1 / 2]],
    [[_NAN, _NAN], [0.852, 0.375], [0.997, 0.617]],
    [[_NAN, _NAN], [1.079, 0.368], [1.033, 0.607]],
    [[_NAN, _NAN], [_NAN, _NAN], [1.053, 0.553]],
    [[_NAN, _NAN], [_NAN, _NAN], [1.302, 0.535]],
])
_TABLE3 = np.array([[6.0, 4.0], [15.23, 12.0], [47.8, 40.0]])
_J_MAX = 100


@numba.njit(cache=True, nogil=True)
def greenhall_edf(alpha: int, d: int, m: int, terms: int, modified: bool,
                  overlapping: bool) -> float:
    """EDF by Greenhall & Riley (2003), cases 1-4 (see :func:`confidence.edf_greenhall`).

    The caller has checked ``alpha + 2 d > 1``.
    """
    m_terms = terms
    if m_terms <= 1:
        return 1.0
    s = float(m) if overlapping else 1.0
    j = int(min(float(m_terms), (d + 1) * s))
    r = m_terms / s
    if modified:  # case 1 (F = 1)
        if j <= _J_MAX:
            z = greenhall_sz(0.0, 1.0, alpha, d)
            return z * z * m_terms / greenhall_basic_sum(j, m_terms, s, 1.0, alpha, d)
        if r > d + 1:
            a0 = _TABLE1[2 - alpha, d - 1, 0]
            a1 = _TABLE1[2 - alpha, d - 1, 1]
            return r / (a0 - a1 / r)
        mp = _J_MAX / r
        z = greenhall_sz(0.0, 1.0, alpha, d)
        return z * z * _J_MAX / greenhall_basic_sum(_J_MAX, _J_MAX, mp, 1.0, alpha, d)
    if alpha == 2:  # case 4: exact
        k_max = int(np.ceil(r)) - 1
        c0 = _BINOM[d, d]
        acc = 0.0
        for k in range(1, min(k_max, d) + 1):
            rho = _BINOM[d, d + k] / c0
            acc += (1.0 - k / r) * (rho * rho)
        return m_terms / (1.0 + 2.0 * acc)
    if alpha <= 0:  # case 2
        if j <= _J_MAX:
            fp = float(m) if m * (d + 1) <= _J_MAX else np.inf
            z = greenhall_sz(0.0, fp, alpha, d)
            return z * z * m_terms / greenhall_basic_sum(j, m_terms, s, fp, alpha, d)
        if r > d + 1:
            a0 = _TABLE2[2 - alpha, d - 1, 0]
            a1 = _TABLE2[2 - alpha, d - 1, 1]
            return r / (a0 - a1 / r)
        mp = _J_MAX / r
        z = greenhall_sz(0.0, np.inf, alpha, d)
        return z * z * _J_MAX / greenhall_basic_sum(_J_MAX, _J_MAX, mp, np.inf, alpha, d)
    # case 3: flicker phase noise, unmodified
    b0 = _TABLE3[d - 1, 0]
    b1 = _TABLE3[d - 1, 1]
    if j <= _J_MAX:
        z = greenhall_sz(0.0, float(m), 1, d)
        return z * z * m_terms / greenhall_basic_sum(j, m_terms, s, float(m), 1, d)
    lm = b0 + b1 * np.log(m)
    if r > d + 1:
        a0 = _TABLE2[1, d - 1, 0]
        a1 = _TABLE2[1, d - 1, 1]
        return lm * lm * r / (a0 - a1 / r)
    mp = _J_MAX / r
    return lm * lm * _J_MAX / greenhall_basic_sum(_J_MAX, _J_MAX, mp, mp, 1, d)


@numba.njit(cache=True, nogil=True)
def greenhall_edf_many(alpha: NDArray, d: int, m: NDArray, terms: NDArray, modified: bool,
                       overlapping: bool) -> NDArray:
    """:func:`greenhall_edf` for arrays of ``alpha``, ``m`` and ``terms`` (one per tau)."""
    out = np.empty(m.size)
    for k in range(m.size):
        out[k] = greenhall_edf(alpha[k], d, m[k], terms[k], modified, overlapping)
    return out


# --------------------------------------------------------------------------- fused phase build
# The phase of an in-memory rate record is integrated tile by tile; while a tile is still in
# L1 the sums that read the whole record at m = 1 (and, for HDEV, the series x[::2]) are taken
# from it, so the record is not read back from memory for them.



@numba.njit(cache=True, nogil=True, fastmath=True)
def _rows_range(a: NDArray, k0: int, k1: int, npts: int, sh0: float, sh1: float,
                acc: NDArray, third: bool, base: int) -> None:
    """Add the terms of indices ``k0 <= k < k1`` of the series ``a[:npts]`` to ``acc``.

    Index ``k`` owns: row 0 ``v_k = a[k] - sh0`` and the pair ``v_k v_{k+1}``; row 1
    ``w_k = (a[k+1] - a[k]) - sh1`` and ``w_k w_{k+1}``; with ``third`` the squared third
    difference starting at ``k`` (the expressions of :func:`_lag1_two` and :func:`_ssq3`),
    each only where its points exist. ``acc``: p1, p2, p11, q1, q2, q11, h, and the index
    moments sum i v, sum i^2 v (``i = base + k``, the index in the series when ``a`` holds it
    from ``base`` on; row 1's follow from them, :func:`_first_difference_moments`).
    """
    p1 = p2 = p11 = q1 = q2 = q11 = h = pk = pkk = 0.0
    full = max(k0, min(k1, npts - 3))  # indices whose every term exists
    c0 = a[k0:full]
    c1 = a[k0 + 1 : full + 1]
    c2 = a[k0 + 2 : full + 2]
    c3 = a[k0 + 3 : full + 3]
    j0 = float(base + k0)
    for k in range(full - k0):  # SIMD lanes (the loop is unswitched on ``third``)
        u0 = c0[k]
        u1 = c1[k]
        u2 = c2[k]
        v = u0 - sh0
        p1 += v
        p2 += v * v
        p11 += v * (u1 - sh0)
        w = (u1 - u0) - sh1
        q1 += w
        q2 += w * w
        q11 += w * ((u2 - u1) - sh1)
        j = j0 + k
        pk += j * v
        pkk += j * j * v
        if third:
            d = c3[k] - 3.0 * u2 + 3.0 * u1 - u0
            h += d * d
    for k in range(full, k1):
        v = a[k] - sh0
        p1 += v
        p2 += v * v
        j = float(base + k)
        pk += j * v
        pkk += j * j * v
        if k + 1 < npts:
            p11 += v * (a[k + 1] - sh0)
            w = (a[k + 1] - a[k]) - sh1
            q1 += w
            q2 += w * w
            if k + 2 < npts:
                q11 += w * ((a[k + 2] - a[k + 1]) - sh1)
                if third and k + 3 < npts:
                    d = a[k + 3] - 3.0 * a[k + 2] + 3.0 * a[k + 1] - a[k]
                    h += d * d
    acc[0] += p1
    acc[1] += p2
    acc[2] += p11
    acc[3] += q1
    acc[4] += q2
    acc[5] += q11
    acc[6] += h
    acc[7] += pk
    acc[8] += pkk


@numba.njit(cache=True, nogil=True)
def _rows_store(a: NDArray, npts: int, sh0: float, sh1: float, acc: NDArray,
                state: NDArray) -> None:
    """Rows 0-1 (``LAG1_FIELDS`` each) of ``a[:npts]`` from the sums of :func:`_rows_range`."""
    _store_rows(state, npts, sh0, sh1, a[npts - 1], a[npts - 2], acc[0], acc[1], acc[2],
                acc[3], acc[4], acc[5], acc[7], acc[8])


@numba.njit(cache=True, nogil=True)
def integrate_fused(y: NDArray, mean: float, tau0: float, out: NDArray, quarter: NDArray,
                    rows: NDArray, third: bool) -> tuple[float, float]:
    """:func:`integrate` from 0, with the m = 1 noise-type rows (and HDEV sums) on the way.

    ``out`` (``len(y) + 1``) receives the phase, summed tile by tile: the running sum of each
    tile of :data:`TILE` samples starts from 0 and is added to the sum of the tiles
    before, so its rounding does not pile up over the record (the level ``mean`` removed may
    be an estimate, leaving a line of phase: see ``deviations._level``). While each tile is in
    cache: ``rows[0]`` gets rows 0-1 of :func:`lag1_first_two` at m = 1; with
    ``third``, the sum of squared third differences of ``x`` (non-overlapping Hadamard at m = 1)
    is returned first. With a non-empty ``quarter`` (``len(y) // 4 + 1`` points), ``rows[1]``
    and the second value returned are the same quantities for ``x[::2]`` (Hadamard at m = 2),
    and ``quarter`` receives ``x[::4]`` (where the decimations for m = 4, 8, ... start). The
    sums differ from the separate kernels by round-off only.
    """
    nx = y.shape[0] + 1
    acc1 = np.zeros(9)
    acc2 = np.zeros(9)
    nq = quarter.shape[0]
    nh = (nx + 1) // 2 if nq > 0 else 0  # points of x[::2]
    tile = TILE
    # x[::2] a tile at a time: hb[k] = x[2 (hbase + k)] for k < hlen (a copy of half the
    # record would cost its page faults and its writes)
    hb = np.empty(tile // 2 + 8)
    hbase = 0
    hlen = 0
    base = 0.0  # the running sum before this tile
    out[0] = 0.0
    sh0 = out[0]
    sh1 = 0.0
    sh1h = 0.0
    done1 = 0  # indices of x already summed
    done2 = 0  # indices of x[::2] already summed
    for t0 in range(0, nx - 1, tile):
        t1 = min(nx - 1, t0 + tile)
        yt = y[t0:t1]  # slices: the loops index from 0, with no wraparound checks
        ot = out[t0 + 1 : t1 + 1]
        c = 0.0  # the running sum within the tile: its rounding does not pile up over tiles
        for k in range(t1 - t0):
            c += yt[k] - mean
            ot[k] = tau0 * (base + c)
        base += c
        if t0 == 0:
            sh1 = out[1] - out[0]
        avail = t1 + 1  # x[0 : avail] is known
        k1 = avail - 3 if avail < nx else nx
        if k1 > done1:
            _rows_range(out, done1, k1, nx, sh0, sh1, acc1, third, 0)
            done1 = k1
        if nq == 0:
            continue
        hav = min(nh, (avail + 1) // 2)  # x[0 : 2 hav : 2] is known
        lo = hbase + hlen
        if hav > lo:
            dst = hb[hlen : hlen + hav - lo]
            src = out[2 * lo : 2 * hav : 2]
            for k in range(hav - lo):
                dst[k] = src[k]
            hlen = hav - hbase
        if hav >= 2:
            if done2 == 0:
                sh1h = out[2] - out[0]
            k2 = hav - 3 if avail < nx else nh
            if k2 > done2:
                _rows_range(hb, done2 - hbase, k2 - hbase, nh - hbase, sh0, sh1h, acc2, third,
                            hbase)
                done2 = k2
                keep = hav - done2  # the points the next terms still read
                for k in range(keep):
                    hb[k] = hb[done2 - hbase + k]
                hbase = done2
                hlen = keep
        qav = min(nq, (avail + 3) // 4)  # quarter[0 : qav] = x[0 : 4 qav : 4]
        lo = (t0 + 3) // 4
        if qav > lo:
            qs = quarter[lo:qav]
            xs = out[4 * lo : 4 * qav : 4]
            for k in range(qav - lo):
                qs[k] = xs[k]
    _rows_store(out, nx, sh0, sh1, acc1, rows[0])
    if nh >= 3:
        _rows_store(out[::2], nh, sh0, sh1h, acc2, rows[1])
    return acc1[6], acc2[6]


@numba.njit(cache=True, nogil=True)
def hadamard_from(x: NDArray, ms: NDArray, terms: NDArray, scratch: NDArray,
                  have: int) -> tuple[NDArray, NDArray]:
    """:func:`hadamard_decimated` starting from ``scratch``, ``x`` decimated by ``have``.

    ``scratch`` (its full length in use) is overwritten in place by the decimations of
    ``ms`` (ascending; from ``scratch`` where ``m`` is a multiple of ``have``, else from ``x``
    while they fit; ``have = 0``: nothing there yet).
    """
    out = np.empty(ms.size)
    rows = np.zeros((ms.size, 2, LAG1_FIELDS))
    for k in range(ms.size):
        m = ms[k]
        n = terms[k]
        if _decimate_into(x, m, n + 2, scratch, have):
            out[k] = _lag1_two(scratch[: n + 3], rows[k], True)  # one pass for both
            have = m
        else:
            out[k] = _lag1_two_strided(x, m, n + 2, rows[k], True)
    return out, rows


@numba.njit(cache=True, nogil=True)
def modified_allan_pair(x: NDArray, m: int, n_mod: int, n_oa: int) -> tuple[float, float]:
    """MDEV and OADEV sums of squares at one ``m`` in one pass (the R(n) ratio, SP 1065 5.6.3).

    The modified sum is that of :func:`modified_sums` digit for digit (same runs, same steps);
    the overlapping Allan sum (``n_oa`` terms) takes the second differences the steps are
    made of, so the record is read once for both.
    """
    n = n_mod
    if n < 64:
        one = np.array([m])
        return (modified_sums(x, one, np.array([n]))[0],
                allan_sums(x, one, np.array([n_oa]), False)[0])
    q = n // 4
    mod, oa = _modified_group(x, m, 0, q, n - 3 * q, np.empty((5, _MOD_TILE)), True)
    if n_oa > n:
        oa += _ssq2(x[n:n_oa], x[n + m : n_oa + m], x[n + 2 * m : n_oa + 2 * m])
    return mod, oa


@numba.njit(cache=True, nogil=True)
def rn_block_sums(blocks: NDArray, points: NDArray, w: int) -> tuple[float, float, int, int]:
    """Sums for R(n) = MVAR/AVAR from block sums (``deviations._rn_strided``).

    ``blocks[k]``: sum of the phase points ``x[k b : (k+1) b]``; ``points[k] = x[k b]``; a
    window is ``w`` blocks (``m = w b`` points). Returns the sum of squared second differences
    of the window sums at lag ``w`` over every block start, the same of ``points``, and the
    two term counts. Each window sum is summed afresh from its blocks every 64 starts, so the
    running sum does not drift.
    """
    nb = blocks.shape[0]
    nw = nb - w + 1  # window starts
    win = np.empty(max(nw, 0))
    s = 0.0
    for k in range(nw):
        if k % 64 == 0:
            s = 0.0
            for j in range(k, k + w):
                s += blocks[j]
        else:
            s += blocks[k + w - 1] - blocks[k - 1]
        win[k] = s
    n_mod = max(nw - 2 * w, 0)
    msum = 0.0
    for k in range(n_mod):
        d = win[k + 2 * w] - 2.0 * win[k + w] + win[k]
        msum += d * d
    n_oa = max(points.shape[0] - 2 * w, 0)
    asum = 0.0
    for k in range(n_oa):
        d = points[k + 2 * w] - 2.0 * points[k + w] + points[k]
        asum += d * d
    return msum, asum, n_mod, n_oa


@numba.njit(cache=True, nogil=True)
def block_sums(x: NDArray, b: int) -> tuple[NDArray, NDArray]:
    """Sums of ``x`` over blocks of ``b`` points (whole blocks only) and ``x[::b]``."""
    nb = x.shape[0] // b
    sums = np.empty(nb)
    for k in range(nb):
        s = 0.0
        for j in range(k * b, (k + 1) * b):
            s += x[j]
        sums[k] = s
    npts = (x.shape[0] + b - 1) // b
    pts = np.empty(npts)
    for k in range(npts):
        pts[k] = x[k * b]
    return sums, pts


@numba.njit(cache=True, nogil=True)
def largest_second_diff(x: NDArray, m: int) -> tuple[float, int]:
    """Largest ``|x[i+2m] - 2 x[i+m] + x[i]|`` over every ``i`` and its ``i`` (one pass)."""
    best = -1.0
    at = 0
    for i in range(x.shape[0] - 2 * m):
        d = abs(x[i + 2 * m] - 2.0 * x[i + m] + x[i])
        if d > best:
            best = d
            at = i
    return best, at
