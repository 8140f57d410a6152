"""From stored runs to per-quantity history summaries (numerics in estimation.trend)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

from inertest.errors import InputError
from inertest.estimation.trend import DEFAULT_ALPHA, QuantityHistory, summarize
from inertest.results import envelope
from inertest.store.history import RunRecord, StoreError


def summarize_runs(
    runs: Sequence[RunRecord], *, names: Sequence[str] | None = None, k: float = 3.0,
    alpha: float = DEFAULT_ALPHA,
) -> list[tuple[QuantityHistory, list[datetime]]]:
    """Summaries of every quantity (or of ``names``) over ``runs``, with the run times.

    Each run's stored std weights it (:func:`inertest.estimation.trend.summarize`: GLS mean,
    repeatability and trend, chi-square scatter tests at level ``alpha``, Birge-ratio
    inflation). A quantity's unit must be the same in every run; runs without the quantity are
    skipped.
    """
    if not (math.isfinite(k) and k > 0):  # a NaN k compares false: no run would be flagged
        raise InputError(f"k must be a finite number > 0 (sigmas of the outlier test), got {k!r}")
    if not runs:
        return []
    t0 = runs[0].tested_at
    order: list[str] = []
    series: dict[str, list[tuple[datetime, float, float, str]]] = {}
    for r in runs:
        for e in r.estimates:
            if e.name not in series:
                order.append(e.name)
                series[e.name] = []
            series[e.name].append((r.tested_at, e.value, e.std, e.unit))
    wanted = list(names) if names else order
    missing = [n for n in wanted if n not in series]
    if missing:
        raise StoreError(
            f"no stored estimate named {', '.join(missing)}; stored: {', '.join(order)}"
        )
    out = []
    for name in wanted:
        rows = series[name]
        units = {u for *_, u in rows}
        if len(units) > 1:
            raise StoreError(f"{name} is stored in different units ({', '.join(sorted(units))})")
        times = [t for t, *_ in rows]
        t_days = [(t - t0).total_seconds() / 86400.0 for t in times]
        h = summarize(name, units.pop(), t_days, [v for _, v, _, _ in rows],
                      [s for _, _, s, _ in rows], k=k, alpha=alpha)
        out.append((h, times))
    return out


@dataclass(frozen=True)
class InstrumentHistory:
    """An instrument's stored runs and the history of each quantity (``inertest history``).

    Attributes
    ----------
    serial : str
    runs : tuple of RunRecord
        In time order.
    summaries : list of (QuantityHistory, list of datetime)
        Per quantity: its summary (:func:`summarize_runs`) and the times of its runs.
    """

    serial: str
    runs: tuple[RunRecord, ...]
    summaries: list[tuple[QuantityHistory, list[datetime]]]

    kind = "history"

    def to_dict(self) -> dict[str, object]:
        """The ``history`` result envelope: the runs and each quantity's summary."""
        return envelope(self.kind, instrument={"serial": self.serial}, result={
            "runs": [{"tested_at": r.tested_at.isoformat(),
                      "filed_at": None if r.filed_at is None else r.filed_at.isoformat(
                          timespec="seconds"),
                      "procedure": r.procedure,
                      "run_uuid": r.run_uuid, "software_version": r.software_version,
                      "data_sha256": r.data_sha256} for r in self.runs],
            "quantities": [h.to_dict() for h, _ in self.summaries],
        })


def instrument_history(runs: Sequence[RunRecord], serial: str, *,
                       names: Sequence[str] | None = None, k: float = 3.0) -> InstrumentHistory:
    """The history of ``serial`` over its stored ``runs`` (:func:`summarize_runs`)."""
    return InstrumentHistory(serial, tuple(runs), summarize_runs(runs, names=names, k=k))
