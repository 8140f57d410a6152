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

import numpy as np
import pytest

from inertest.noise.deviations import oadev
from inertest.noise.identification import identify_noise
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
    for _ in range(REPS):
        model = identify_noise(oadev(_record(rng), RATE_HZ), instrument=None)
        assert model.fits, model.verdict
        assert all(model.terms[t].resolved for t in TRUTH), {
            t: model.terms[t].note for t in TRUTH}
        vals.append([model.terms[t].value for t in TRUTH])
        stds.append([model.terms[t].std for t in TRUTH])
    vals, stds = np.asarray(vals), np.asarray(stds)
    scatter = vals.std(axis=0, ddof=1)
    ratio = np.sqrt(np.mean(stds**2, axis=0)) / scatter
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    bias = vals.mean(axis=0) - np.array(list(TRUTH.values()))
    assert np.all(np.abs(bias) < 3.0 * scatter / math.sqrt(REPS)), bias / scatter
    assert np.all(np.abs(bias) < 0.3 * stds.mean(axis=0)), bias / stds.mean(axis=0)
