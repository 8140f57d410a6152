"""Lot statistics: many units of one type, per quantity, against the specification's limits.

A production lot (or a fleet) of instruments of one type, each with its result envelope (the
``to_dict()`` of a fit, a campaign's run, or a stored :class:`~inertest.store.RunRecord`'s
``result``): per procedure and quantity, over the units,

* the lot **mean** (with its std ``s / sqrt(n)``) and the **observed spread** ``s``, the sample
  standard deviation of the units' values, with its chi-squared 95 % interval;
* the **measurement part** of that spread, the RMS of the units' own standard uncertainties
  ``u_rms``, and the **unit-to-unit spread with the measurement removed**: the between-unit
  standard deviation ``tau`` of the one-way random-effects model ``x_i = mu + u_i + e_i``
  (``e_i`` of variance ``u_i^2``), by REML with its Q-profile interval
  (:mod:`inertest.estimation.random_effects`), and the F test of whether the units differ at
  all beyond their measurement: ``s`` overstates the lot's real spread whenever the
  measurements are not much better than the units are alike;
* **process capability** against each limit of the specification on the quantity
  (ISO 22514-2; Montgomery, *Introduction to Statistical Quality Control*, ch. 8):
  ``Cp = (USL - LSL) / (6 sigma)`` (two-sided limits) and ``Cpk = min(USL - mu, mu - LSL) /
  (3 sigma)``, with ``sigma`` the observed spread (the capability the lot shows, measurement
  included) and, beside it, with ``tau`` (the capability of the process alone); 95 %
  intervals: ``Cp`` by the chi-squared distribution of ``s^2``, ``Cpk`` by Bissell's
  approximation ``Cpk +- z sqrt(1 / (9 n) + Cpk^2 / (2 (n - 1)))`` (Bissell, The Statistician
  39(2), 1990, doi:10.2307/2348566); ``max_abs`` limits are the two-sided ``[-L, L]``;
* **units that stand out**: each unit against the others (leave-one-out), ``t = (x_i -
  mean_others) / (s_others sqrt(1 + 1 / (n - 1)))``, Student's ``t`` with ``n - 2`` degrees of
  freedom for a normal lot, flagged beyond the Bonferroni bound ``t_{n-2}(1 - level / (2 n))``
  (so a lot of good units flags any at most at ``level``).

Several runs of one unit and procedure: the latest (by test date) stands for the unit, and the
others are counted in the notes. :func:`lot_statistics` is a pure function on the envelopes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from inertest.errors import InputError, UnitError
from inertest.estimation.random_effects import random_effects
from inertest.quality.conformance import Limit, Spec
from inertest.units import convert

#: Level at which units are said to stand out, for the lot (Bonferroni over the units).
DEFAULT_LEVEL = 0.01
#: Confidence of the intervals.
CONFIDENCE = 0.95


@dataclass(frozen=True)
class UnitValue:
    """One unit's value of a quantity: serial, value and standard uncertainty [unit], date."""

    serial: str
    value: float
    std: float
    tested_at: str | None = None


@dataclass(frozen=True)
class Capability:
    """Process capability of a lot against one limit.

    Attributes
    ----------
    clause_id, limit, clause : str
    lower, upper : float or None
        The limits in the quantity's unit (``max_abs`` as ``[-L, L]``).
    cp, cpk : float or None
        With the observed spread (``cp`` None for a one-sided limit).
    cp_interval, cpk_interval : (float, float) or None
        95 % intervals.
    cpk_process : float or None
        ``Cpk`` with the unit-to-unit spread ``tau`` (measurement removed); None when ``tau`` is
        0.
    cpk_process_lower : float or None
        Its lower confidence bound: ``Cpk`` at the upper end of ``tau``'s interval (the mean
        taken as known). A ``tau`` whose interval reaches 0 makes ``cpk_process`` unbounded
        above, so the point value alone overstates what the lot shows.
    outside : int
        Units whose value lies outside the limit.
    """

    clause_id: str
    limit: str
    clause: str
    lower: float | None
    upper: float | None
    cp: float | None
    cp_interval: tuple[float, float] | None
    cpk: float | None
    cpk_interval: tuple[float, float] | None
    cpk_process: float | None
    outside: int
    cpk_process_lower: float | None = None

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        return {"clause": self.clause_id, "limit": self.limit, "reference": self.clause,
                "lower": self.lower, "upper": self.upper, "cp": self.cp,
                "cp_interval_95": None if self.cp_interval is None else list(self.cp_interval),
                "cpk": self.cpk,
                "cpk_interval_95": None if self.cpk_interval is None
                else list(self.cpk_interval),
                "cpk_process": self.cpk_process,
                "cpk_process_lower": self.cpk_process_lower, "units_outside": self.outside}


@dataclass(frozen=True)
class StandOut:
    """A unit that stands out from the others: serial, value, its ``t`` and the bound."""

    serial: str
    value: float
    t: float

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        return {"serial": self.serial, "value": self.value, "t": self.t}


@dataclass(frozen=True)
class QuantityLot:
    """One quantity of one procedure over the lot (module docstring for each number)."""

    procedure: str
    quantity: str
    unit: str
    values: tuple[UnitValue, ...]
    mean: float
    mean_std: float | None
    observed_std: float | None
    observed_interval: tuple[float, float] | None
    measurement_rms: float
    unit_to_unit: float | None
    unit_to_unit_interval: tuple[float, float] | None
    differ_p_value: float | None
    capability: tuple[Capability, ...]
    stand_out: tuple[StandOut, ...]
    stand_out_bound: float | None

    @property
    def n(self) -> int:
        """Units."""
        return len(self.values)

    def to_dict(self) -> dict[str, object]:
        """JSON form, every number with its unit."""
        def pair(x: tuple[float, float] | None) -> list[float] | None:
            return None if x is None else [float(x[0]), float(x[1])]

        return {
            "procedure": self.procedure, "quantity": self.quantity, "unit": self.unit,
            "units": self.n, "mean": self.mean, "mean_std": self.mean_std,
            "observed_std": self.observed_std,
            "observed_std_interval_95": pair(self.observed_interval),
            "measurement_std_rms": self.measurement_rms,
            "unit_to_unit_std": self.unit_to_unit,
            "unit_to_unit_std_interval_95": pair(self.unit_to_unit_interval),
            "units_differ_p_value": self.differ_p_value,
            "capability": [c.to_dict() for c in self.capability],
            "stand_out": [s.to_dict() for s in self.stand_out],
            "stand_out_bound_t": self.stand_out_bound,
            "values": [{"serial": v.serial, "value": v.value, "std": v.std,
                        "tested_at": v.tested_at} for v in self.values],
        }


@dataclass(frozen=True)
class LotStatistics:
    """Lot statistics of many units (:func:`lot_statistics`).

    Attributes
    ----------
    quantities : tuple of QuantityLot
        Per (procedure, quantity), in the order first met.
    serials : tuple of str
        The units.
    spec_name : str or None
    level, confidence : float
    notes : tuple of str
    """

    quantities: tuple[QuantityLot, ...]
    serials: tuple[str, ...]
    spec_name: str | None
    level: float
    confidence: float
    notes: tuple[str, ...] = field(default=())

    def quantity(self, name: str, procedure: str | None = None) -> QuantityLot:
        """The statistics of ``name`` (of ``procedure`` when several procedures report it)."""
        for q in self.quantities:
            if q.quantity == name and procedure in (None, q.procedure):
                return q
        raise InputError(f"the lot has no quantity {name!r}"
                         + (f" of {procedure}" if procedure else ""))

    def to_dict(self) -> dict[str, object]:
        """The JSON block of the lot (``result`` of ``inertest lot --json``)."""
        return {
            "units": list(self.serials), "specification": self.spec_name,
            "stand_out_level": self.level, "confidence": self.confidence,
            "method": {
                "observed_std": "sample standard deviation of the units' values (measurement "
                                "noise included)",
                "unit_to_unit_std": "between-unit std of the one-way random-effects model with "
                                    "each unit's own standard uncertainty removed (REML, "
                                    "Q-profile interval)",
                "capability": "Cp = (USL - LSL) / 6 s, Cpk = min(USL - mean, mean - LSL) / 3 s "
                              "with the observed s (cpk_process: with the unit-to-unit std); "
                              "intervals: chi-squared (Cp), Bissell 1990 (Cpk)",
                "stand_out": "leave-one-out t with n - 2 dof, Bonferroni over the units at "
                             "stand_out_level"},
            "quantities": [q.to_dict() for q in self.quantities],
            "notes": list(self.notes),
        }


def lot_statistics(envelopes: Sequence[Mapping[str, object]], spec: Spec | None = None, *,
                   level: float = DEFAULT_LEVEL, confidence: float = CONFIDENCE,
                   clause_procedures: Mapping[str, Sequence[str]] | None = None
                   ) -> LotStatistics:
    """Lot statistics per (procedure, quantity) of result envelopes of many units.

    Parameters
    ----------
    envelopes : sequence of mapping
        Result envelopes (``result.to_dict()``, ``RunOutcome.to_dict()``, a stored run's
        ``result``): the serial in ``doc["instrument"]["serial"]``, the estimates in
        ``doc["identification"]["coefficients"]`` as ``{name: {"value", "std", "unit"}}`` (and
        the ``combinations``), the test date in ``doc["test"]["tested_at"]`` when known.
    spec : Spec, optional
        Capability against each limit whose quantity the lot has.
    level : float
        Level at which units are said to stand out (Bonferroni over the units).
    confidence : float
        Of the intervals.
    clause_procedures : mapping, optional
        ``{clause id: procedure kinds}``: a limit counts only for the procedures that verify
        its clause (an acceptance campaign's tests); by default for every procedure that
        reports the limited quantity.

    Raises
    ------
    InputError
        No envelope, an envelope without a serial or an identification, a level outside (0, 1).
    """
    if not envelopes:
        raise InputError("lot statistics need result envelopes of at least one unit")
    if not 0.0 < level < 1.0 or not 0.0 < confidence < 1.0:
        raise InputError(f"level and confidence must lie in (0, 1), got {level}, {confidence}")
    notes: list[str] = []
    latest: dict[tuple[str, str], tuple[str, Mapping[str, object]]] = {}
    superseded = 0
    for k, doc in enumerate(envelopes):
        kind = str(doc.get("kind") or "")
        inst = doc.get("instrument")
        serial = inst.get("serial") if isinstance(inst, Mapping) else None
        if not serial:
            raise InputError(f"envelope {k + 1} ({kind or 'no kind'}) names no instrument serial "
                             "(instrument.serial): a lot is a set of units")
        test = doc.get("test")
        when = str(test.get("tested_at") or "") if isinstance(test, Mapping) else ""
        key = (kind, str(serial))
        if key in latest:
            superseded += 1
            if when < latest[key][0]:
                continue
        latest[key] = (when, doc)
    if superseded:
        notes.append(f"{superseded} earlier run(s) of a unit and procedure left out: the latest "
                     "run (by test date) stands for each unit")
    table: dict[tuple[str, str], list[tuple[UnitValue, str]]] = {}
    for (kind, serial), (when, doc) in latest.items():
        ident = doc.get("identification")
        if not isinstance(ident, Mapping):
            raise InputError(f"the {kind} result of {serial} has no identification block")
        coeffs = ident.get("coefficients") or {}
        items = [(name, e) for name, e in coeffs.items()]
        items += [(str(c["name"]), c) for c in ident.get("combinations") or []]
        for name, e in items:
            value, std = float(e["value"]), float(e["std"])
            if not (math.isfinite(value) and math.isfinite(std)):
                continue
            table.setdefault((kind, name), []).append(
                (UnitValue(serial, value, std, when or None), str(e["unit"])))
    quantities = []
    for (kind, name), rows in table.items():
        unit = rows[0][1]
        vals = []
        for v, u in rows:
            try:
                f = convert(1.0, u, unit)
            except UnitError:
                notes.append(f"{kind} {name} of {v.serial} is in {u}, the lot's in {unit}: left "
                             "out")
                continue
            vals.append(UnitValue(v.serial, v.value * f, v.std * f, v.tested_at))
        vals.sort(key=lambda v: v.serial)
        limits = tuple(lim for lim in (spec.limits if spec is not None else ())
                       if lim.quantity == name and (
                           clause_procedures is None
                           or kind in clause_procedures.get(lim.clause_id, ())))
        quantities.append(_quantity(kind, name, unit, vals, limits, level, confidence))
    serials = tuple(sorted({s for _, s in latest}))
    return LotStatistics(tuple(quantities), serials, None if spec is None else spec.name,
                         level, confidence, tuple(notes))


def _quantity(kind: str, name: str, unit: str, vals: list[UnitValue],
              limits: Sequence[Limit], level: float, confidence: float) -> QuantityLot:
    x = np.array([v.value for v in vals])
    u = np.array([v.std for v in vals])
    n = x.size
    mean = float(x.mean())
    u_rms = float(np.sqrt(np.mean(u**2)))
    s = float(np.std(x, ddof=1)) if n >= 2 else None
    a = 1.0 - confidence
    interval = tau = tau_int = p = None
    if n >= 2 and s is not None:
        interval = (s * math.sqrt((n - 1) / special.chdtri(n - 1, a / 2)),
                    s * math.sqrt((n - 1) / special.chdtri(n - 1, 1 - a / 2)))
        if np.all(u > 0):
            re = random_effects(x, u**2, confidence=confidence)
            tau = math.sqrt(re.tau2)
            tau_int = (math.sqrt(re.tau2_interval[0]), math.sqrt(re.tau2_interval[1]))
            p = re.p_value
    caps = tuple(_capability(lim, unit, x, s, tau, confidence,
                             None if tau_int is None else tau_int[1]) for lim in limits)
    out: list[StandOut] = []
    bound = None
    if n >= 4:
        bound = float(special.stdtrit(n - 2, 1.0 - level / (2 * n)))
        for i in range(n):
            rest = np.delete(x, i)
            sd = float(np.std(rest, ddof=1))
            if sd <= 0:
                continue
            t = (x[i] - rest.mean()) / (sd * math.sqrt(1.0 + 1.0 / (n - 1)))
            if abs(t) > bound:
                out.append(StandOut(vals[i].serial, float(x[i]), float(t)))
    return QuantityLot(
        procedure=kind, quantity=name, unit=unit, values=tuple(vals), mean=mean,
        mean_std=None if s is None else s / math.sqrt(n), observed_std=s,
        observed_interval=interval, measurement_rms=u_rms, unit_to_unit=tau,
        unit_to_unit_interval=tau_int, differ_p_value=p, capability=caps,
        stand_out=tuple(out), stand_out_bound=bound)


def _capability(lim: Limit, unit: str, x: np.ndarray, s: float | None, tau: float | None,
                confidence: float, tau_hi: float | None = None) -> Capability:
    try:
        f = convert(1.0, lim.unit, unit)
    except UnitError:
        raise InputError(f'limit on "{lim.quantity}" is in {lim.unit}, the lot\'s values in '
                         f"{unit}: write the limit in {unit} or an equivalent unit") from None
    lo: float | None
    hi: float | None
    if lim.max_abs is not None:
        lo, hi = -lim.max_abs * f, lim.max_abs * f
    else:
        lo = None if lim.minimum is None else lim.minimum * f
        hi = None if lim.maximum is None else lim.maximum * f
    n = x.size
    mean = float(x.mean())
    outside = int(np.sum((x < lo) if lo is not None else 0) + np.sum(
        (x > hi) if hi is not None else 0))

    def cpk_of(sig: float) -> float:
        sides = [(hi - mean) / (3 * sig)] if hi is not None else []
        sides += [(mean - lo) / (3 * sig)] if lo is not None else []
        return float(min(sides))

    cp = cp_int = cpk = cpk_int = cpk_p = None
    if s is not None and s > 0 and n >= 2:
        a = 1.0 - confidence
        if lo is not None and hi is not None:
            cp = (hi - lo) / (6 * s)
            cp_int = (cp * math.sqrt(special.chdtri(n - 1, 1 - a / 2) / (n - 1)),
                      cp * math.sqrt(special.chdtri(n - 1, a / 2) / (n - 1)))
        cpk = cpk_of(s)
        z = float(special.ndtri(1 - a / 2))
        half = z * math.sqrt(1.0 / (9 * n) + cpk * cpk / (2 * (n - 1)))
        cpk_int = (cpk - half, cpk + half)
        if tau is not None and tau > 0:
            cpk_p = cpk_of(tau)
    cpk_p_lo = cpk_of(tau_hi) if cpk_p is not None and tau_hi is not None and tau_hi > 0 else None
    return Capability(clause_id=lim.clause_id, limit=lim.text(), clause=lim.clause, lower=lo,
                      upper=hi, cp=cp, cp_interval=cp_int, cpk=cpk, cpk_interval=cpk_int,
                      cpk_process=cpk_p, outside=outside, cpk_process_lower=cpk_p_lo)
