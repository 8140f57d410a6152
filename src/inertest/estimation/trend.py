"""Run-to-run behaviour of a coefficient over an instrument's calibration history.

For one quantity measured in successive runs (value ``x_i`` with standard uncertainty ``s_i`` at
time ``t_i``), every number is weighted by the runs' own stds (generalised least squares with
weights ``w_i = 1 / s_i^2``):

* **mean**: the weighted mean ``m = sum w x / sum w`` with std ``1 / sqrt(sum w)``;
* **repeatability** (turn-on to turn-on, IEEE Std 528): the weighted standard deviation of the
  run values, ``sqrt(sum w (x - m)^2 / (V1 - V2 / V1))`` with ``V1 = sum w``, ``V2 = sum w^2``
  (the sample standard deviation when all stds are equal), from two runs on;
* **scatter test**: ``chi2 = sum w (x - m)^2`` with ``n - 1`` degrees of freedom against the
  chi-square distribution: does the run-to-run scatter agree with the runs' stated stds?
  (p-value, Birge ratio ``R_B = sqrt(chi2 / dof)``, verdict at the level ``alpha``);
* **trend**: GLS slope of value against time with the std that the run stds give, from three
  runs at distinct times on; the residuals about the line are tested the same way (``n - 2``
  degrees of freedom) and, when they exceed the stated stds (p < ``alpha``), the slope std is
  inflated by their Birge ratio (the mean's std likewise by the Birge ratio of the scatter
  about the mean) and a message says so (R. T. Birge, Phys. Rev.
  40, 207 (1932), doi:10.1103/PhysRev.40.207; the scale factor of the Particle Data Group,
  Rev. Part. Phys., "Introduction: averaging"). Without inflation the trend's z-score
  ``slope / std`` of a stable instrument is N(0, 1) (tested by Monte Carlo);
* **flags**: a run is flagged when it lies more than ``k`` predicted standard deviations from
  the mean of the *other* runs: ``z = (x - m_o) / (spread sqrt(1 + 1/n_o))`` with ``spread`` the
  larger of the others' repeatability and their rms reported uncertainty (leave-one-out
  prediction interval; with one other run this is ``(x - x_o) / sqrt(2) s_o``).

When some run has no std (zero), the weights are undefined: the history then falls back to the
unweighted mean, sample standard deviation and ordinary least-squares trend (std from the
residual scatter) and says so. Quantities the history cannot determine (repeatability from one
run, trend from two) are None, with a message saying what is needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from inertest.errors import InputError
from inertest.estimation.least_squares import weighted_least_squares

#: Default significance level of the chi-square scatter tests.
DEFAULT_ALPHA = 0.01


@dataclass(frozen=True)
class ScatterTest:
    """Chi-square test of run-to-run scatter against the runs' stated stds.

    Attributes
    ----------
    chi2 : float
        ``sum ((x - model) / s)^2`` over the runs [-].
    dof : int
        Degrees of freedom: runs minus fitted parameters (1 for the mean, 2 for the trend).
    p : float
        Probability of a chi-square at least this large if the stds are right (upper tail).
    birge_ratio : float
        ``sqrt(chi2 / dof)``: the factor by which the scatter exceeds the stated stds.
    alpha : float
        Significance level of the verdict.
    """

    chi2: float
    dof: int
    p: float
    birge_ratio: float
    alpha: float

    @property
    def consistent(self) -> bool:
        """True unless the scatter is significantly larger than the stds (``p < alpha``)."""
        return self.p >= self.alpha

    @property
    def verdict(self) -> str:
        """One-line verdict in words."""
        if self.consistent:
            return "consistent with the run stds"
        return f"scatter exceeds the run stds (Birge ratio {self.birge_ratio:.3g})"

    def to_dict(self) -> dict[str, object]:
        """JSON-ready test result."""
        return {"chi2": self.chi2, "dof": self.dof, "p": self.p,
                "birge_ratio": self.birge_ratio, "alpha": self.alpha,
                "verdict": self.verdict, "consistent": self.consistent}


def scatter_test(residuals: ArrayLike, stds: ArrayLike, dof: int, *,
                 alpha: float = DEFAULT_ALPHA) -> ScatterTest:
    """Chi-square test of ``residuals`` against ``stds`` with ``dof`` degrees of freedom.

    ``chi2 = sum (r / s)^2`` is chi-square distributed with ``dof`` degrees of freedom when the
    stds are right and the model (mean or line) holds; ``p`` is its upper tail.
    """
    r = np.asarray(residuals, dtype=float)
    sd = np.asarray(stds, dtype=float)
    if dof < 1:
        raise InputError(f"a scatter test needs at least 1 degree of freedom, got {dof}")
    chi2 = float(np.sum((r / sd) ** 2))
    return ScatterTest(chi2=chi2, dof=int(dof), p=float(stats.chi2.sf(chi2, dof)),
                       birge_ratio=math.sqrt(chi2 / dof), alpha=float(alpha))


@dataclass(frozen=True)
class QuantityHistory:
    """Summary of one quantity over the runs (times in days since the first run).

    ``mean``, ``repeatability`` and the trend are weighted by the run stds (module docstring)
    when ``weighted``; ``mean_std`` and ``trend_std_per_day`` include the Birge-ratio
    inflation (``mean_inflation``, ``trend_inflation``, 1 when none) when the scatter tests
    reject the stated stds.

    The trend line is ``trend_level + trend_per_day * (t - trend_t0_days)``: centred at the
    weighted mean time ``trend_t0_days`` its level and slope are uncorrelated, so the line's
    standard uncertainty at ``t`` is ``sqrt(trend_level_std^2 + (t - t0)^2
    trend_std_per_day^2)`` (:meth:`trend_line`).
    """

    name: str
    unit: str
    t_days: NDArray[np.float64]
    values: NDArray[np.float64]
    stds: NDArray[np.float64]
    mean: float
    repeatability: float | None
    trend_per_day: float | None
    trend_std_per_day: float | None
    z: NDArray[np.float64]
    flagged: NDArray[np.bool_]
    k: float
    messages: tuple[str, ...]
    mean_std: float | None = None
    weighted: bool = True
    scatter: ScatterTest | None = None
    trend_test: ScatterTest | None = None
    mean_inflation: float = 1.0
    trend_inflation: float = 1.0
    trend_t0_days: float | None = None
    trend_level: float | None = None
    trend_level_std: float | None = None

    def trend_line(self, t_days: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The trend line at ``t_days`` [days since the first run] and its standard uncertainty.

        Raises
        ------
        InputError
            The history has no trend (fewer than 3 runs at different times).
        """
        if (self.trend_per_day is None or self.trend_std_per_day is None
                or self.trend_level is None or self.trend_level_std is None
                or self.trend_t0_days is None):
            raise InputError(f"{self.name}: no trend; it needs at least 3 runs at different "
                             "times")
        dt = np.asarray(t_days, dtype=float) - self.trend_t0_days
        line = self.trend_level + self.trend_per_day * dt
        std = np.sqrt(self.trend_level_std**2 + (dt * self.trend_std_per_day) ** 2)
        return line, std

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary (None where the history cannot determine a number)."""
        return {
            "name": self.name,
            "unit": self.unit,
            "runs": int(self.values.size),
            "weighted": self.weighted,
            "mean": self.mean,
            "mean_std": self.mean_std,
            "repeatability": self.repeatability,
            "scatter_test": None if self.scatter is None else self.scatter.to_dict(),
            "trend_per_day": self.trend_per_day,
            "trend_std_per_day": self.trend_std_per_day,
            "trend_test": None if self.trend_test is None else self.trend_test.to_dict(),
            "trend_t0_days": self.trend_t0_days,
            "trend_level": self.trend_level,
            "trend_level_std": self.trend_level_std,
            "mean_std_inflation": self.mean_inflation,
            "trend_std_inflation": self.trend_inflation,
            "values": self.values.tolist(),
            "stds": self.stds.tolist(),
            "t_days": self.t_days.tolist(),
            "z": [None if not np.isfinite(v) else float(v) for v in self.z],
            "flagged": self.flagged.tolist(),
            "k": self.k,
            "messages": list(self.messages),
        }


def summarize(
    name: str,
    unit: str,
    t_days: ArrayLike,
    values: ArrayLike,
    stds: ArrayLike,
    *,
    k: float = 3.0,
    alpha: float = DEFAULT_ALPHA,
) -> QuantityHistory:
    """Weighted mean, repeatability, scatter test, trend and outlier flags of one history.

    Parameters
    ----------
    name, unit : str
        Quantity name and engineering unit.
    t_days : array_like, shape (n,)
        Run times [days], in time order.
    values, stds : array_like, shape (n,)
        Estimates and their standard uncertainties [unit] (stds >= 0; all > 0 for the
        weighted analysis).
    k : float
        Flag threshold in predicted standard deviations.
    alpha : float
        Significance level of the chi-square scatter tests (0 < alpha < 1).
    """
    t = np.asarray(t_days, dtype=float)
    x = np.asarray(values, dtype=float)
    s = np.asarray(stds, dtype=float)
    if not (t.shape == x.shape == s.shape) or x.ndim != 1 or x.size == 0:
        raise InputError("history needs equally long, non-empty time, value and std series")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(x)) and np.all(np.isfinite(s))):
        raise InputError(f"history of {name} holds NaN or inf")
    if np.any(s < 0):
        raise InputError(f"history of {name} holds a negative std; stds must be >= 0")
    if k <= 0:
        raise InputError(f"flag threshold k must be positive, got {k}")
    if not 0 < alpha < 1:
        raise InputError(f"significance level alpha must lie in (0, 1), got {alpha}")
    n = x.size
    messages: list[str] = []
    weighted = bool(np.all(s > 0))
    if not weighted:
        messages.append(f"{name}: a run has no std (0), so the runs cannot be weighted: "
                        "unweighted mean and trend, trend std from the residual scatter")
    w = 1.0 / s**2 if weighted else np.ones(n)
    mean = float(np.sum(w * x) / np.sum(w))
    mean_std: float | None = float(1.0 / math.sqrt(np.sum(w))) if weighted else None
    scatter = None
    mean_inflation = 1.0
    repeat = None
    if n >= 2:
        v1, v2 = float(np.sum(w)), float(np.sum(w**2))
        repeat = float(math.sqrt(np.sum(w * (x - mean) ** 2) / (v1 - v2 / v1)))
        if weighted:
            scatter = scatter_test(x - mean, s, n - 1, alpha=alpha)
            if not scatter.consistent:
                mean_inflation = scatter.birge_ratio
                mean_std = (mean_std or 0.0) * mean_inflation
                messages.append(
                    f"{name}: run-to-run scatter exceeds the run stds (chi2 = {scatter.chi2:.3g}, "
                    f"dof = {scatter.dof}, p = {scatter.p:.2g}); mean std inflated by the Birge "
                    f"ratio {scatter.birge_ratio:.3g}")
        else:
            mean_std = repeat / math.sqrt(n)
    else:
        messages.append("repeatability needs at least 2 runs")
    slope = slope_std = level = level_std = t0 = None
    trend_test = None
    trend_inflation = 1.0
    if n >= 3 and np.ptp(t) > 0:
        t0 = float(np.sum(w * t) / np.sum(w))
        design = np.column_stack([np.ones(n), t - t0])
        fit = weighted_least_squares(design, x, sigma=s if weighted else None)
        if fit.rank == 2:
            slope, slope_std = float(fit.x[1]), float(fit.std[1])
            level, level_std = float(fit.x[0]), float(fit.std[0])
            if weighted:
                trend_test = scatter_test(fit.residuals, s, n - 2, alpha=alpha)
                if not trend_test.consistent:
                    trend_inflation = trend_test.birge_ratio
                    slope_std *= trend_inflation
                    level_std *= trend_inflation
                    messages.append(
                        f"{name}: scatter about the trend exceeds the run stds (chi2 = "
                        f"{trend_test.chi2:.3g}, dof = {trend_test.dof}, p = {trend_test.p:.2g});"
                        f" trend std inflated by the Birge ratio {trend_inflation:.3g}")
    if slope is None:
        t0 = None
        messages.append("trend needs at least 3 runs at different times")
    z = np.full(n, np.nan)
    if n >= 2:
        for i in range(n):
            others = np.delete(x, i)
            o_std = np.delete(s, i)
            spread_sq = float(np.mean(o_std**2))
            if others.size >= 2:
                spread_sq = max(spread_sq, float(np.var(others, ddof=1)))
            denom = np.sqrt(spread_sq * (1 + 1 / others.size))
            z[i] = (x[i] - others.mean()) / denom if denom > 0 else np.nan
    else:
        messages.append("flags need at least 2 runs")
    flagged = np.abs(np.nan_to_num(z)) > k
    return QuantityHistory(
        name=name, unit=unit, t_days=t, values=x, stds=s, mean=mean,
        repeatability=repeat, trend_per_day=slope, trend_std_per_day=slope_std,
        z=z, flagged=flagged, k=float(k), messages=tuple(messages), mean_std=mean_std,
        weighted=weighted, scatter=scatter, trend_test=trend_test,
        mean_inflation=mean_inflation, trend_inflation=trend_inflation,
        trend_t0_days=t0, trend_level=level, trend_level_std=level_std,
    )
