"""Monte Carlo of the noise type behind each tau's EDF (issue 28 item 1).

Records of the five power-law noises (white PM, flicker PM, white FM, flicker FM, random-walk
FM) of several lengths, each with its exact expected Allan variance at every m:

* white PM: phase ``x`` white (sigma 1): AVAR = 3 / m^2 (tau0 = 1);
* white FM: rate white (sigma 1): AVAR = 1 / m;
* random-walk FM: each rate sample the mean over its interval of a Brownian motion of unit
  diffusion (``(W_k + W_k+1) / 2`` plus the bridge term of variance 1/12): AVAR = m / 3
  (IEEE Std 952-1997 Annex C: K^2 tau / 3), the continuous model of Greenhall's EDF;
* flicker PM and flicker FM: circulant (FFT) synthesis of ``1/f`` lines over ``2 (n + 1)``
  points, first points kept (Kasdin 1995); the covariance of the lines is known, so the
  Allan variance is exact: ``(6 c0 - 8 c_m + 2 c_2m) / (2 m^2)`` for phase,
  ``(4 D(m) - D(2m)) / (2 m^2)`` for rate, ``D(m) = sum_|j|<m (m - |j|) c_j``.

The reference EDF of the true type is allantools' ``edf_greenhall`` (independent code, NIST SP
1065 / Greenhall & Riley 2003); where it has no formula (white PM with one or two averages
left) ours is used. Coverage is that of the 68.3 % interval of the overlapping Allan
deviation. "Oracle" is the coverage of the interval built on the same records with the true
type's EDF: at 3-7 averages the chi-squared law itself over-covers (0.72-0.78).
"""

from __future__ import annotations

import functools
import math

import allantools.ci as atci
import numpy as np
import pytest
from scipy.stats import chi2

from inertest.noise.confidence import NOISE_RULES, ONE_SIGMA, edf_greenhall
from inertest.noise.deviations import oadev

ALPHA = {"white PM": 2, "flicker PM": 1, "white FM": 0, "flicker FM": -1, "random-walk FM": -2}
LENGTHS = (1000, 8192, 32768)
REPS = 600


def _records(kind: str, rng: np.random.Generator, reps: int, n: int):
    """``reps`` rate records of ``n`` samples (tau0 = 1 s) and AVAR(m) of the process."""
    if kind == "white PM":
        return np.diff(rng.standard_normal((reps, n + 1)), axis=1), lambda m: 3.0 / m**2
    if kind == "white FM":
        return rng.standard_normal((reps, n)), lambda m: 1.0 / m
    if kind == "random-walk FM":
        w = np.cumsum(rng.standard_normal((reps, n + 1)), axis=1)
        bridge = math.sqrt(1.0 / 12.0) * rng.standard_normal((reps, n))
        return 0.5 * (w[:, :-1] + w[:, 1:]) + bridge, lambda m: m / 3.0
    size = 2 * (n + 1)
    f = np.fft.rfftfreq(size)
    amp = np.zeros(f.size)
    amp[1:-1] = 1.0 / np.sqrt(f[1:-1])
    lines = rng.standard_normal((reps, f.size)) + 1j * rng.standard_normal((reps, f.size))
    s = np.fft.irfft(lines * amp, size)[:, : n + 1]
    c = (2.0 / size) * np.fft.irfft(amp * amp, size)  # covariance at lags 0, 1, ...
    if kind == "flicker PM":
        return np.diff(s, axis=1), lambda m: (6 * c[0] - 8 * c[m] + 2 * c[2 * m]) / (2.0 * m * m)

    def d(m: int) -> float:
        j = np.arange(1, m)
        return m * c[0] + 2.0 * float(np.sum((m - j) * c[j]))

    return s[:, :n], lambda m: (4 * d(m) - d(2 * m)) / (2.0 * m * m)


@functools.cache
def _true_edf(alpha: int, m: int, nx: int) -> float:
    try:
        return float(atci.edf_greenhall(alpha=alpha, d=2, m=m, N=nx, overlapping=True,
                                        modified=False))
    except NotImplementedError:  # white PM, r <= d: no formula in allantools
        return edf_greenhall(alpha, 2, m, nx - 2 * m, modified=False, overlapping=True)


def _cells(kind: str, n: int):
    rng = np.random.default_rng([28, n, ALPHA[kind] + 2])
    ys, avar = _records(kind, rng, REPS, n)
    rs = [oadev(y, 1.0) for y in ys]
    ms = np.rint(rs[0].taus).astype(int)
    true_var = np.array([avar(int(m)) for m in ms])
    lo = np.array([r.dev_lo for r in rs]) ** 2
    hi = np.array([r.dev_hi for r in rs]) ** 2
    edf = np.array([r.edf for r in rs])
    var = np.array([r.var for r in rs])
    ref = np.array([_true_edf(ALPHA[kind], int(m), n + 1) for m in ms])
    cover = np.mean((lo <= true_var) & (true_var <= hi), axis=0)
    z = var / true_var * ref
    oracle = np.mean((z >= chi2.ppf(0.5 - ONE_SIGMA / 2, ref))
                     & (z <= chi2.ppf(0.5 + ONE_SIGMA / 2, ref)), axis=0)
    excess = np.mean(edf > 2.0 * ref, axis=0)
    return ms, n // ms, cover, oracle, excess


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(ALPHA))
def test_intervals_cover_and_edf_is_never_far_too_large(kind):
    """Coverage and EDF excess at every octave tau of records of 1000, 8192, 32768 samples.

    * at most 1 % of the intervals of any tau rest on an EDF above twice the true type's;
    * coverage at least 0.60 at every tau; at most 0.76 at every tau of 8 or more averages
      where the true type's own interval (the oracle) covers at most 0.74;
    * elsewhere (3-7 averages, or an oracle above 0.74: there the variance is not
      chi-squared, oracle 0.65-0.79) at most 0.07 above the oracle. Only flicker PM gets near
      that: at 3-7 averages R(n) alone tells it from white FM and the smaller EDF is taken
      where R(n) points to frequency noise (9-18 % of the records; seed 28: 0.80-0.82 against
      0.75-0.79).

    Before (commit 9b03c44, the lag-1 type of each tau alone, as Stable32; 1000 records per
    type and length 1000, 8192, 65536): flicker PM intervals at 32-4096 averages rested on an
    EDF above twice flicker PM's in 33-97 % of records (coverage 0.11-0.62), white FM at 3-128
    averages in 2-26 % (coverage down to 0.58).
    """
    for n in LENGTHS:
        ms, averages, cover, oracle, excess = _cells(kind, n)
        where = f"{kind}, {n} samples, m = {ms.tolist()}"
        assert np.all(excess <= 0.01), (where, excess)
        assert np.all(cover >= 0.60), (where, cover)
        upper = np.where((averages >= 8) & (oracle <= 0.74), 0.76,
                         np.maximum(0.76, oracle + 0.07))
        assert np.all(cover <= upper), (where, cover, oracle)


def test_rule_of_every_tau_is_recorded_and_streaming_agrees():
    """Flicker PM: lag-1 says white PM from m = 32 on, R(n) overrules it; a record streamed
    in chunks gets the same types and rules (R(n) from one more pass)."""
    ys, _ = _records("flicker PM", np.random.default_rng(5), 1, 1 << 16)
    mem = oadev(ys[0], 1.0)
    streamed = oadev(ys[0], 1.0, stream=True)
    assert set(mem.alpha_rule) <= set(NOISE_RULES)
    assert "lag1|rn" in mem.alpha_rule
    assert mem.alpha.tolist() == streamed.alpha.tolist()
    assert mem.alpha_rule == streamed.alpha_rule
    assert mem.to_dict()["alpha_rule"] == list(mem.alpha_rule)
    few = (len(ys[0]) // np.rint(mem.taus).astype(int)) < 30
    assert np.all(mem.alpha[~few][3:] == 1)  # flicker PM wherever lag-1 decides
