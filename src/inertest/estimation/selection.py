"""The choice of a noise model (``auto``) and the uncertainty of that choice.

White noise unless a correlated model beats it by the likelihood-ratio test (restricted
likelihood, boundary corrected, :data:`AUTO_ALPHA` for the family of candidates), else the
correlated model of the highest likelihood; the models the data cannot tell from it (within
:data:`AUTO_CLOSE_AIC` per output) add the spread of their estimates to its covariance.
Written once for every procedure that offers ``auto``.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

from inertest.estimation.least_squares import LinearFit

#: ``auto``: candidate noise models within this much of the best criterion per output count as
#: "close" (the data cannot tell them apart; Burnham & Anderson 2002, sec. 2.6) and their
#: spread is added (:func:`common_noise_model`).
AUTO_CLOSE_AIC = 2.0
#: ``auto``: familywise level of the likelihood-ratio test a correlated noise model must pass
#: against white noise to be chosen (:func:`component_penalty`).
AUTO_ALPHA = 0.05


def common_noise_model(aic: Sequence[Mapping[str, float]]
                       ) -> tuple[str, dict[str, float], list[str]]:
    """The choice of ``auto`` for one or several outputs described by one noise model.

    ``aic``: per output, the AIC of each candidate model, ``white`` (no variance component)
    among them: ``2 nll`` for white and ``2 nll + 2`` for a correlated model (nll the negative
    restricted log-likelihood). The outputs' noises are independent, so the joint model's
    log-likelihood is the sum. The criterion is ``2 nll`` summed over the outputs, plus, for a
    correlated model, :func:`component_penalty` of its ``k`` components (one per output)
    instead of AIC's ``2 k``: a correlated model is chosen only when it beats white by the
    likelihood-ratio test at :data:`AUTO_ALPHA` for the family of candidates, and among those
    that do, the one of highest likelihood (as by AIC: each has one component per output).

    Returns the model of smallest criterion, the weights ``exp(-delta / 2)`` of the criterion
    (Akaike weights, with the test's penalty), and the models within :data:`AUTO_CLOSE_AIC`
    per output of the best (the best first), whose per-output estimates give each output's
    spread (:func:`selection_spread`) with those weights.

    Why not AIC alone: the variance component is on the boundary of its space under white
    noise, so the likelihood-ratio statistic of each candidate is ``0.5 chi2_0 + 0.5 chi2_1``
    (Self & Liang, JASA 82(398), 1987, doi:10.1080/01621459.1987.10478472), and AIC takes
    one of three candidates on about one white record in eight: the gyro rate table's bias
    came out 1.27x conservative under white noise (a random walk's variance of the bias
    includes the walk's level), 1.10 with the test. Why the close set grows with the outputs:
    the pooled criterion's differences add up over them; a cut at 2 for three gyros left
    flicker out of the spread when a random walk was chosen under flicker, whose bias is
    then poorly estimated (gyro triad rotation: 0.78, 0.85 with 2 per output).
    """
    names = list(aic[0])
    k = len(aic)
    pen = component_penalty(k, sum(m != "white" for m in names))
    crit = {m: float(sum(a[m] for a in aic)) for m in names}
    crit = {m: c if m == "white" else c - 2 * k + pen for m, c in crit.items()}
    best = min(crit, key=lambda m: crit[m])
    near = [best, *(m for m in names
                    if m != best and crit[m] <= crit[best] + AUTO_CLOSE_AIC * k)]
    return best, akaike_weights(crit), near


@functools.lru_cache(maxsize=64)
def component_penalty(outputs: int, candidates: int, alpha: float = AUTO_ALPHA) -> float:
    """Critical value of the likelihood-ratio test of white noise against a correlated model.

    The model adds one variance component per output (``outputs`` of them, independent), each
    zero under white noise, on the boundary of its space: the statistic
    ``2 (nll_white - nll_model)`` is then chi-bar-square, ``sum_j C(k, j) 2^-k chi2_j`` over
    ``j = 0..k`` (Self & Liang, JASA 82(398), 1987, doi:10.1080/01621459.1987.10478472,
    case 6). Returned: its upper ``alpha / candidates`` point (Bonferroni over the correlated
    candidates, so that white data choose one of them with probability at most ``alpha``).
    One output, three correlated candidates (``alpha`` 0.05): 4.53, where AIC's penalty of 2 is the
    point at 0.079 for each candidate.
    """
    k = int(outputs)
    level = alpha / max(int(candidates), 1)
    p = np.array([float(scipy.special.comb(k, j)) for j in range(1, k + 1)]) / 2.0**k

    def tail(c: float) -> float:
        return float(p @ scipy.special.chdtrc(np.arange(1, k + 1), c))

    lo, hi = 0.0, 1.0
    while tail(hi) > level:
        lo, hi = hi, 2 * hi
    for _ in range(100):  # bisection: tail decreases with c
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if tail(mid) > level else (lo, mid)
    return 0.5 * (lo + hi)


def with_selection_spread(
    best: LinearFit, x: Mapping[str, NDArray[np.float64]], weights: Mapping[str, float],
) -> LinearFit:
    """The AIC-best fit with the uncertainty of the choice of noise model added (``auto``).

    ``x``: the estimates of the models the data cannot tell from the best (within
    :data:`AUTO_CLOSE_AIC` of it, the best included), ``weights`` their Akaike weights
    ``exp(-dAIC_m / 2)`` (renormalised here over them). The estimate stays the best
    model's, ``x_b``; its covariance gains the spread of the close models' estimates:
    ``C = C_b + sum w_m (x_m - x_b)(x_m - x_b)^T``, the between-model term of Buckland,
    Burnham & Augustin, Biometrics 53(2), 1997, doi:10.2307/2533961 (Burnham & Anderson,
    *Model Selection and Multimodel Inference*, 2nd ed., Springer 2002, sec. 4.3.2).

    Why not their full model average: averaging the estimates would make the reported value
    that of no model (the closed forms agree with the white fit, not with a mixture), and
    averaging the candidates' own covariances overshoots, since a wrong model's covariance is
    itself wrong (flicker fitted to position offsets is up to 2x conservative, offsets fitted to
    flicker up to 2x optimistic). Why not the largest covariance among the close models: with
    12-24 positions flicker is often within 2 AIC of true position offsets, and taking it gave
    std / scatter up to 1.54. Monte Carlo in tests/estimation/test_identify.py.
    """
    cov = best.covariance + selection_spread(best.x, x, weights, best.null_space)
    return replace(best, covariance=0.5 * (cov + cov.T))


def selection_spread(
    x_best: ArrayLike, x: Mapping[str, ArrayLike], weights: Mapping[str, float],
    null_space: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """``sum w_m (x_m - x_b)(x_m - x_b)^T``, the weights renormalised over ``x``'s models.

    The between-model term of ``auto`` (:func:`with_selection_spread`), also for procedures
    with their own noise models; ``null_space`` (orthonormal columns): directions the data do
    not determine, removed from the differences.
    """
    names = list(x)
    w = np.array([weights[m] for m in names])
    w /= w.sum()
    D = np.array([np.asarray(x[m], dtype=float) for m in names]) - np.asarray(x_best, float)
    if null_space is not None and np.shape(null_space)[1]:
        N = np.asarray(null_space, dtype=float)
        D = D - (D @ N) @ N.T  # only identifiable directions carry the spread
    S: NDArray[np.float64] = (D.T * w) @ D
    return 0.5 * (S + S.T)


def akaike_weights(aic: Mapping[str, float]) -> dict[str, float]:
    """``exp(-dAIC / 2)`` normalised over the candidates."""
    lo = min(aic.values())
    w = {m: float(np.exp(-0.5 * (a - lo))) for m, a in aic.items()}
    total = sum(w.values())
    return {m: v / total for m, v in w.items()}
