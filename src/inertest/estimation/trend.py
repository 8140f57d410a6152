"""Run-to-run behaviour of a coefficient over an instrument's calibration history.

For one quantity measured in successive runs (value ``x_i`` with standard uncertainty ``s_i`` at
time ``t_i``):

* mean and **repeatability**: the sample standard deviation of the run values (turn-on to
  turn-on repeatability, IEEE Std 528 "repeatability"), defined from two runs on;
* **trend**: ordinary least-squares slope of value against time with its standard uncertainty
  (from the residual scatter), defined from three runs at distinct times on;
* **flags**: a run is flagged when it lies more than ``k`` predicted standard deviations from
  the mean of the *other* runs: ``z = (x - m_o) / (spread sqrt(1 + 1/n_o))`` with ``spread`` the
  larger of the others' repeatability and their rms reported uncertainty (leave-one-out
  prediction interval; with one other run this is ``(x - x_o) / sqrt(2) s_o``).

Quantities the history cannot determine (repeatability from one run, trend from two) are None,
with a message saying what is needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.estimation.least_squares import weighted_least_squares


@dataclass(frozen=True)
class QuantityHistory:
    """Summary of one quantity over the runs (times in days since the first run)."""

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

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary (None where the history cannot determine a number)."""
        return {
            "name": self.name,
            "unit": self.unit,
            "runs": int(self.values.size),
            "mean": self.mean,
            "repeatability": self.repeatability,
            "trend_per_day": self.trend_per_day,
            "trend_std_per_day": self.trend_std_per_day,
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
) -> QuantityHistory:
    """Mean, repeatability, trend and outlier flags of one quantity's history.

    Parameters
    ----------
    name, unit : str
        Quantity name and engineering unit.
    t_days : array_like, shape (n,)
        Run times [days], in time order.
    values, stds : array_like, shape (n,)
        Estimates and their standard uncertainties [unit].
    k : float
        Flag threshold in predicted standard deviations.
    """
    t = np.asarray(t_days, dtype=float)
    x = np.asarray(values, dtype=float)
    s = np.asarray(stds, dtype=float)
    if not (t.shape == x.shape == s.shape) or x.ndim != 1 or x.size == 0:
        raise InputError("history needs equally long, non-empty time, value and std series")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(x)) and np.all(np.isfinite(s))):
        raise InputError(f"history of {name} holds NaN or inf")
    if k <= 0:
        raise InputError(f"flag threshold k must be positive, got {k}")
    n = x.size
    messages = []
    repeat = float(np.std(x, ddof=1)) if n >= 2 else None
    if repeat is None:
        messages.append("repeatability needs at least 2 runs")
    slope = slope_std = None
    if n >= 3 and np.ptp(t) > 0:
        fit = weighted_least_squares(np.column_stack([np.ones(n), t - t.mean()]), x)
        if fit.rank == 2:
            slope, slope_std = float(fit.x[1]), float(fit.std[1])
    if slope is None:
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
        name=name, unit=unit, t_days=t, values=x, stds=s, mean=float(x.mean()),
        repeatability=repeat, trend_per_day=slope, trend_std_per_day=slope_std,
        z=z, flagged=flagged, k=float(k), messages=tuple(messages),
    )
