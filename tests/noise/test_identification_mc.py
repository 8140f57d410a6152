"""Monte Carlo of the five-term fit on records with known N, B and K (issue 15 item 8).

The records come from tests/noise_generators.py, not from the library's ``simulate_noise``:
white rate noise of PSD ``N^2`` (IEEE Std 952-1997 Annex C: S = N^2), flicker rate noise of
one-sided PSD ``h / f`` with ``h = B^2 / pi``, so that the Allan variance is
``(2 ln2 / pi) B^2`` and the flat floor ``sigma_min = B sqrt(2 ln2 / pi) ~ 0.664 B`` (Annex C,
C.1.3; NIST SP 1065 Table 5: AVAR = 2 ln2 h_-1), and a rate random walk of PSD
``K^2 / (2 pi f)^2`` (steps ``K sqrt(tau0)``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from inertest.noise.deviations import oadev
from inertest.noise.identification import NoiseFitWarning, identify_noise
from noise_generators import flicker_rate

#: 1 Hz records of 2^14 s; N, B, K in SI of a dimensionless rate. The floor 0.664 B meets the
#: N line at tau = (N / 0.664 B)^2 = 10 s and the K line at tau = 3 (0.664 B / K)^2 = 132 s,
#: so each term is the largest over more than a decade of the 13 octaves.
TRUTH = {"N": 2.1, "B": 1.0, "K": 0.1}
N_SAMPLES, RATE_HZ, REPS = 2**14, 1.0, 80


def _record(rng: np.random.Generator) -> np.ndarray:
    tau0 = 1.0 / RATE_HZ
    n, b, k = TRUTH["N"], TRUTH["B"], TRUTH["K"]
    white = (n / math.sqrt(tau0)) * rng.standard_normal(N_SAMPLES)
    walk = np.cumsum(k * math.sqrt(tau0) * rng.standard_normal(N_SAMPLES))
    return white + walk + flicker_rate(rng, N_SAMPLES, h=b * b / math.pi)


def test_generator_has_the_annex_c_flat_floor():
    """The flicker generator alone: OADEV 0.664 B at every tau (Annex C), within its scatter."""
    rng = np.random.default_rng(3)
    devs = np.array([oadev(flicker_rate(rng, 2**12, h=1.0 / math.pi), 1.0, [1, 4, 16, 64]).dev
                     for _ in range(20)])
    floor = math.sqrt(2 * math.log(2) / math.pi)
    np.testing.assert_allclose(np.sqrt(np.mean(devs**2, axis=0)), floor, rtol=0.06)


@pytest.mark.slow
def test_reported_std_of_n_b_k_matches_scatter_and_estimates_are_unbiased():
    """Reported std / scatter within 0.8-1.25 for N, B and K over 80 records, every term
    resolved, and the mean estimate within 3 standard errors of the truth (so the bias is far
    below one reported std). Seed 11: std / scatter N 1.08, B 1.13, K 0.98; bias / std 0.01,
    0.00, -0.19 (octaves up to 2048 s). With point samples of flicker band-limited at Nyquist
    (no block average) N came out 1 % (1.6 std) high.

    The default octaves, up to 8192 s (one average): before, the ninth record was declared a
    misfit (chi2/dof 17): its one-average deviation at 8192 s, 1/1370 of the model, bounded
    the flat floor (B held at zero, K 2.9x too large), and its Gaussian residual counted in
    chi2/dof. Now points of EDF < 3 neither bound B nor enter chi2/dof (each is judged by its
    own chi-squared distribution): every record fits (chi2/dof at most 2.6); std / scatter N
    1.08, B 1.13, K 0.98, bias / std 0.01, 0.00, -0.19.
    """
    rng = np.random.default_rng(11)
    vals, stds = [], []
    flagged = 0
    for _ in range(REPS):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NoiseFitWarning)
            model = identify_noise(oadev(_record(rng), RATE_HZ), instrument=None)
        if not model.fits:  # the check's false alarms, at its level (1 %)
            flagged += 1
            continue
        assert all(model.terms[t].resolved for t in TRUTH), {
            t: model.terms[t].note for t in TRUTH}
        vals.append([model.terms[t].value for t in TRUTH])
        stds.append([model.terms[t].std for t in TRUTH])
    assert flagged <= 3, flagged
    vals, stds = np.asarray(vals), np.asarray(stds)
    scatter = vals.std(axis=0, ddof=1)
    ratio = np.sqrt(np.mean(stds**2, axis=0)) / scatter
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    bias = vals.mean(axis=0) - np.array(list(TRUTH.values()))
    assert np.all(np.abs(bias) < 3.0 * scatter / math.sqrt(len(vals))), bias / scatter
    assert np.all(np.abs(bias) < 0.3 * stds.mean(axis=0)), bias / stds.mean(axis=0)


def _clean(rng: np.random.Generator, seconds: float, crossover_s: float,
           rate_hz: float = 100.0) -> np.ndarray:
    """White rate noise (N = 1e-3 per sqrt(s)) plus rate random walk whose Allan variance
    meets N's at ``crossover_s`` (N^2 / tau = K^2 tau / 3): the five-term model exactly."""
    n = int(seconds * rate_hz)
    n_rw = 1e-3
    k = n_rw * math.sqrt(3.0) / crossover_s
    return (n_rw * math.sqrt(rate_hz) * rng.standard_normal(n)
            + np.cumsum(k / math.sqrt(rate_hz) * rng.standard_normal(n)))


def _flagged(y: np.ndarray, rate_hz: float = 100.0) -> bool:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoiseFitWarning)
        return not identify_noise(oadev(y, rate_hz), instrument=None, data=y).fits


@pytest.mark.slow
def test_model_check_false_alarm_rate_on_clean_records():
    """Issue 28: records of the model itself, 100 s to an hour at 100 Hz, crossovers of N and
    K from 1 s to 1000 s, 320 records. The check is at 1 % (chi2 of the best five-term fit)
    plus at most 1 % (single largest Allan term, Bonferroni): at most 2.5 % flagged.

    Before (the chi2 of the model after its insignificant terms were dropped, against a
    limit of chi2/dof = 10): 13 % of 200 s records flagged, chi2/dof up to 370, because a
    weak K dropped from the model left the long-tau points far above its covariance. Seed 28:
    now 0.9 % (3 of 320: 0, 0, 1, 2 by duration).
    """
    g = np.random.default_rng(28)
    crossovers = (1.0, 10.0, 30.0, 100.0, 1000.0)
    flags = [_flagged(_clean(g, seconds, crossovers[k % 5]))
             for seconds in (100.0, 200.0, 600.0, 3600.0) for k in range(80)]
    assert sum(flags) <= 8, sum(flags)


@pytest.mark.slow
def test_model_check_still_flags_a_vibration_line_and_a_step():
    """A 1 Hz line of 0.3 the white noise's sample std, and a rate step of 20 times the
    smallest Allan deviation (taus of 30 or more averages) a third into the record: every one
    of 24 records (200 s and 1200 s) is flagged. A step is rate random walk to the Allan
    variance (both grow as tau), so it is the single-event check that finds it."""
    g = np.random.default_rng(29)
    for seconds in (200.0, 1200.0):
        t = np.arange(int(seconds * 100.0)) / 100.0
        for k in range(6):
            y = _clean(g, seconds, (1.0, 30.0, 1000.0)[k % 3])
            assert _flagged(y + 0.3 * 1e-3 * 10.0 * np.sin(2.0 * math.pi * t))
            d = oadev(y, 100.0)
            floor = d.dev[y.size // np.rint(d.taus * 100.0).astype(int) >= 30].min()
            assert _flagged(y + 20.0 * floor * (t > seconds / 3.0))
