"""Run-to-run variation of a quantity measured once per run, with each run's own uncertainty.

A bias measured at each power-on, a scale factor measured on each day: ``x_r`` with an in-run
variance ``v_r`` (from the run's own noise). The one-way random-effects model

    x_r = mu + u_r + e_r,    u_r ~ N(0, tau^2),    e_r ~ N(0, v_r)

separates the variation added between runs (``tau``: a new bias at each turn-on, a new scale
factor each day) from what the noise within a run alone makes the run values scatter by. Written
once here for every repeatability test:

* ``tau^2`` by restricted maximum likelihood (Patterson & Thompson, Biometrika 58(3), 1971,
  doi:10.1093/biomet/58.3.545), with its interval by the Q-profile method (Viechtbauer, Stat.
  Med. 26(1), 2007, doi:10.1002/sim.2514): ``Q(tau^2) = sum w_r (x_r - mu_w)^2`` with ``w_r =
  1 / (tau^2 + v_r)`` between the chi-squared quantiles of ``R - 1`` degrees of freedom,
  ``v_r`` taken as known;
* ``mu`` as the ``w``-weighted mean, its std by Hartung-Knapp (``q / ((R - 1) sum w)``, exactly
  ``s^2 / R`` for equal runs; Hartung & Knapp, Stat. Med. 20(24), 2001, doi:10.1002/sim.1009),
  with ``R - 1`` degrees of freedom;
* the within-run vs between-run F test of ``tau = 0`` (the "operating vs shutdown" comparison):
  ``F = Q(0) / (R - 1)`` against ``F(R - 1, nu)``, ``nu`` the degrees of freedom of the in-run
  variances (infinite: chi-squared).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from inertest.errors import InputError
from inertest.estimation.reml import bounded_minimum


@dataclass(frozen=True)
class RandomEffects:
    """One-way random effects of run values with known in-run variances.

    Attributes
    ----------
    mu, mu_std : float
        Weighted mean and its Hartung-Knapp std (``R - 1`` degrees of freedom).
    tau2 : float
        Between-run variance (REML, >= 0).
    tau2_interval : (float, float)
        Its Q-profile interval at ``confidence``.
    confidence : float
    F, dof, p_value : float, (int, float), float
        The F test of ``tau = 0``: statistic, (numerator, denominator) degrees of freedom
        (``inf`` denominator: chi-squared), p-value.
    """

    mu: float
    mu_std: float
    tau2: float
    tau2_interval: tuple[float, float]
    confidence: float
    F: float
    dof: tuple[int, float]
    p_value: float


def random_effects(x: ArrayLike, v: ArrayLike, *, within_dof: float = math.inf,
                   confidence: float = 0.95) -> RandomEffects:
    """Between-run variance, weighted mean and the F test of run values ``x`` (module docstring).

    Parameters
    ----------
    x : array_like, shape (R,)
        One value per run.
    v : array_like, shape (R,)
        Its in-run variance (same unit squared), positive.
    within_dof : float
        Degrees of freedom of the in-run variances (``inf`` when known).
    confidence : float
        Level of the interval of ``tau^2``.
    """
    xx = np.asarray(x, dtype=float)
    vv = np.asarray(v, dtype=float)
    R = xx.size
    if R < 2 or vv.shape != xx.shape or not np.all(np.isfinite(xx)) or np.any(~(vv > 0)):
        raise InputError("random effects need two or more runs, each with a finite value and a "
                         "positive in-run variance")
    tau2 = _reml_tau2(xx, vv)
    w = 1.0 / (tau2 + vv)
    mu = float(w @ xx / w.sum())
    mu_std = math.sqrt(float(w @ (xx - mu) ** 2) / ((R - 1) * w.sum()))
    interval = _q_profile(xx, vv, confidence)
    q0 = _q(0.0, xx, vv)
    F = q0 / (R - 1)
    p = float(special.fdtrc(R - 1, within_dof, F) if math.isfinite(within_dof)
              else special.chdtrc(R - 1, q0))
    return RandomEffects(mu=mu, mu_std=mu_std, tau2=tau2, tau2_interval=interval,
                         confidence=confidence, F=F, dof=(R - 1, float(within_dof)), p_value=p)


def _q(t: float, x: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    w = 1.0 / (t + v)
    mu = w @ x / w.sum()
    return float(w @ (x - mu) ** 2)


def _reml_tau2(x: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    """REML of ``tau^2 >= 0``: grid on a log scale, then Brent's method; 0 when best there."""
    def nll(t: float) -> float:
        w = 1.0 / (t + v)
        mu = w @ x / w.sum()
        return float(0.5 * (np.sum(np.log(t + v)) + math.log(w.sum()) + w @ (x - mu) ** 2))

    hi = max(10.0 * float(np.var(x, ddof=1)), float(v.max()))
    grid = np.geomspace(max(hi * 1e-8, 1e-300), hi, 41)
    vals = np.array([nll(float(t)) for t in grid])
    i = int(np.argmin(vals))
    lo_t, hi_t = np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, grid.size - 1)])
    xm, fx = bounded_minimum(lambda lt: nll(float(np.exp(lt))), lo_t, hi_t, xatol=1e-4)
    return 0.0 if nll(0.0) <= fx else float(np.exp(xm))


def _q_profile(x: NDArray[np.float64], v: NDArray[np.float64], confidence: float
               ) -> tuple[float, float]:
    """Q-profile interval of ``tau^2``: ``Q`` is decreasing in ``tau^2``."""
    from scipy.optimize import brentq

    dof = x.size - 1
    a = 1.0 - confidence
    top = max(100.0 * float(np.var(x, ddof=1)), float(v.max()), 1e-300)

    def root(level: float) -> float:
        if _q(0.0, x, v) <= level:
            return 0.0
        hi = top
        while _q(hi, x, v) > level:
            hi *= 10.0
        return float(brentq(lambda t: _q(t, x, v) - level, 0.0, hi, xtol=1e-14 * hi,
                            maxiter=200))

    return (root(float(special.chdtri(dof, a / 2.0))),
            root(float(special.chdtri(dof, 1.0 - a / 2.0))))
