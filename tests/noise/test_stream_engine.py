"""The one-pass streaming engine and the SIMD kernels against the sequential definitions.

The streamed path (NIST SP 1065 sums, every tau in one pass: a chunk buffer for short lags,
one lagging integrator per long lag, several passes when the long lags are many) and the
in-memory kernels (four-lane modified-Allan recursion, three-octave Allan pass, tiled lag-1
sums of Riley & Greenhall 2004) must give the numbers of the plain sequential sums.
"""

from __future__ import annotations

import numpy as np
import pytest

from inertest.noise import deviations as dv
from inertest.noise import kernels
from inertest.noise.confidence import r1_of_state
from inertest.noise.deviations import STATISTICS, deviations


def _record(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return 1e-3 + 1e-6 * rng.standard_normal(n) + np.cumsum(1e-9 * rng.standard_normal(n))


@pytest.mark.parametrize("data_type", ["rate", "angle"])
@pytest.mark.parametrize("taus", ["octave", "decade", [0.01, 0.07, 3.0, 55.0]])
def test_streamed_long_lags_and_several_passes_equal_memory(monkeypatch, data_type, taus):
    y = _record(30_001, 4).astype(np.float32)
    mem = deviations(y, 100.0, list(STATISTICS), taus, data_type, stream=False)
    monkeypatch.setattr(dv, "CHUNK", 1000)  # lags beyond one chunk: lagging integrators
    monkeypatch.setattr(dv, "_MAX_CURSORS", 3)  # more long lags than that: several passes
    st = deviations(y, 100.0, list(STATISTICS), taus, data_type, stream=True)
    for k in STATISTICS:
        np.testing.assert_allclose(st[k].dev, mem[k].dev, rtol=1e-12, atol=0)
        np.testing.assert_array_equal(st[k].alpha, mem[k].alpha)
        np.testing.assert_array_equal(st[k].n, mem[k].n)


def test_streamed_progress_reaches_total(monkeypatch):
    monkeypatch.setattr(dv, "CHUNK", 512)
    calls = []
    deviations(_record(5000, 5), 1.0, ["oadev", "mdev", "tdev"], stream=True,
               progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1][0] == calls[-1][1]
    assert all(b >= a for (a, _), (b, _) in zip(calls, calls[1:], strict=False))


def test_modified_lanes_equal_sequential_recursion():
    x = np.cumsum(np.random.default_rng(6).standard_normal(20_001))
    for m in (1, 2, 3, 7, 64, 400, 1500, 6000):
        n = x.size - 3 * m + 1
        s0 = kernels.second_diff_sum(x[:m], x[m : 2 * m], x[2 * m : 3 * m])
        ref = 0.0
        s = s0
        for j in range(n):  # SP 1065 eq. 14 by its recursion, term by term
            ref += s * s
            if j < n - 1:
                s += ((x[j + 3 * m] - 2 * x[j + 2 * m] + x[j + m])
                      - (x[j + 2 * m] - 2 * x[j + m] + x[j]))
        got = kernels.modified_sums(x, np.array([m]), np.array([n]))[0]
        assert got == pytest.approx(ref, rel=1e-12)


def test_octave_allan_pass_equals_one_tau_at_a_time():
    x = np.cumsum(np.random.default_rng(7).standard_normal(50_001))
    ms = np.array([1, 2, 4, 8, 16, 32, 100, 200, 400, 3000])
    ns = x.size - 2 * ms
    got = kernels.allan_sums(x, ms, ns, False)
    for m, n, g in zip(ms, ns, got, strict=True):
        d = x[2 * m : 2 * m + n] - 2 * x[m : m + n] + x[:n]
        assert g == pytest.approx(float(np.sum(d * d)), rel=1e-12)


@pytest.mark.parametrize("m", [1, 2, 3, 50, 997])
def test_lag1_tiles_equal_sequential_sums(m):
    x = np.cumsum(np.random.default_rng(8).standard_normal(30_001))
    count = (x.size - 1) // m
    ref = kernels.lag1_state_of(x, m, count, 4)
    for got in (kernels.lag1_sums(x, m, count, 4), kernels.lag1_first_two(x, m, count)):
        k = got.shape[0]
        np.testing.assert_array_equal(got[:, [0, 1, 5]], ref[:k, [0, 1, 5]])
        np.testing.assert_allclose(got[:, 2:7], ref[:k, 2:7], rtol=1e-11, atol=0)
        for d in range(k):
            assert r1_of_state(got[d]) == pytest.approx(r1_of_state(ref[d]), abs=1e-10)


@pytest.mark.parametrize("block", [1, 5, 999, 100_000])
def test_lag1_extend_in_blocks_equals_sequential_update(block):
    z = np.cumsum(np.random.default_rng(9).standard_normal(20_000))
    ref = np.zeros((4, kernels.LAG1_FIELDS))
    kernels.lag1_update(z, ref)
    got = np.zeros((4, kernels.LAG1_FIELDS))
    for a in range(0, z.size, block):
        kernels.lag1_extend(z[a : a + block], got)
    np.testing.assert_array_equal(got[:, [0, 1, 5]], ref[:, [0, 1, 5]])
    np.testing.assert_allclose(got[:, 2:8], ref[:, 2:8], rtol=1e-11, atol=0)
    for d in range(4):
        assert r1_of_state(got[d]) == pytest.approx(r1_of_state(ref[d]), abs=1e-10)


def test_decimated_series_taken_from_each_other_equal_direct():
    x = np.cumsum(np.random.default_rng(10).standard_normal(40_001))
    ms = np.array([1, 2, 4, 8, 12, 24, 100, 1000])
    count = (x.size - 1) // ms
    h, rows = kernels.hadamard_decimated(x, ms, count - 2)
    many = kernels.lag1_rows_many(x, ms, np.empty(0), 0)
    for k, m in enumerate(ms):
        span = (count[k] - 3) * m + 1
        ref = kernels.sum_third_diff(x[:span], x[m : m + span], x[2 * m : 2 * m + span],
                                     x[3 * m : 3 * m + span], m)
        assert h[k] == pytest.approx(ref, rel=1e-12)
        seq = kernels.lag1_state_of(x, m, count[k], 2)
        for got in (rows[k], many[k]):
            np.testing.assert_allclose(got[:, 2:7], seq[:, 2:7], rtol=1e-11, atol=0)
            for d in range(2):
                assert r1_of_state(got[d]) == pytest.approx(r1_of_state(seq[d]), abs=1e-10)
