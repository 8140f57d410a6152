"""Specification limits and conformance verdicts with the measurement uncertainty.

An instrument specification file (TOML) gives limits per quantity of a result, each with the
clause of the standard it comes from, and the decision rule::

    [spec]
    name = "Example spec, navigation-grade floated gyro"
    decision_rule = "guarded"          # or "simple"
    [[limit]]
    quantity = "DI"                    # a coefficient or combination name of the procedure
    max_abs = 0.05                     # or min and/or max
    unit = "deg/h/g"
    clause = "IEEE Std 517-1974"
    id = "3.2.4"                       # optional: how an acceptance campaign names the clause

Decision rules (ILAC-G8:09/2019, sec. 4): ``guarded`` is guarded acceptance with a guard band
``w = U``, the expanded uncertainty (its k from the budget's effective degrees of freedom, 2 for
many), and a non-binary statement: *pass* when the value is
inside the limit by at least U, *conditional pass* when inside by less than U, *conditional
fail* when outside by at most U, *fail* when outside by more than U. ``simple`` is simple
acceptance (w = 0, binary statement): *pass* inside the limit, *fail* outside.

A limit on a coefficient of the procedure's model that the test cannot separate (DF of a polar
tumble, determined only in ``DF + (g/g0)^2 DII``) gets the verdict *not determined*, with the
reason and the combination that is determined; the other limits are judged. Only a name that is
no quantity of the procedure at all is an error.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from inertest.errors import PlanError, UnitError
from inertest.plan import Field, check_known_keys, did_you_mean, read_fields
from inertest.quality.budget import UncertaintyBudget, quantities_of
from inertest.quality.lab import read_toml_file
from inertest.units import compound_unit, convert

#: Decision rules; ``{k}`` is filled with the coverage factor(s) used (:func:`rule_text`).
DECISION_RULES: dict[str, str] = {
    "guarded": (
        "ILAC-G8:09/2019 guarded acceptance, non-binary statement, guard band w = U (expanded "
        "uncertainty, {k}): pass when the value is inside the limit by at least U; conditional "
        "pass when inside by less than U; conditional fail when outside by at most U; fail when "
        "outside by more than U"),
    "simple": (
        "ILAC-G8:09/2019 simple acceptance, binary statement, w = 0: pass when the value is "
        "inside the limit, fail otherwise (a value at the limit has up to 50 % risk of a false "
        "decision)"),
}

#: Verdicts from best to worst; *not determined* (the test cannot separate the quantity) ranks
#: below any pass, so an overall pass needs every limit judged.
VERDICTS = ("pass", "conditional pass", "not determined", "conditional fail", "fail")
NOT_DETERMINED = "not determined"


class SpecError(PlanError):
    """A specification file is missing, malformed or does not fit the result."""


@dataclass(frozen=True)
class Limit:
    """Limits on one quantity, in ``unit``.

    Attributes
    ----------
    quantity, unit, clause : str
    minimum, maximum, max_abs : float or None
        ``minimum <= x``, ``x <= maximum``, ``|x| <= max_abs`` [unit].
    id : str
        The clause's identifier in an acceptance campaign (``verifies = [...]`` of a test,
        :mod:`inertest.app.acceptance`); the quantity's name when the spec gives none.
    """

    quantity: str
    unit: str
    clause: str
    minimum: float | None = None
    maximum: float | None = None
    max_abs: float | None = None
    id: str = ""

    @property
    def clause_id(self) -> str:
        """The identifier a campaign names the clause by: ``id``, else the quantity."""
        return self.id or self.quantity

    def text(self) -> str:
        """The limit as printed: ``|DI| <= 0.05 deg/h/g``."""
        parts = []
        if self.max_abs is not None:
            parts.append(f"|{self.quantity}| <= {self.max_abs:g} {self.unit}")
        if self.minimum is not None and self.maximum is not None:
            parts.append(f"{self.minimum:g} <= {self.quantity} <= {self.maximum:g} {self.unit}")
        elif self.minimum is not None:
            parts.append(f"{self.quantity} >= {self.minimum:g} {self.unit}")
        elif self.maximum is not None:
            parts.append(f"{self.quantity} <= {self.maximum:g} {self.unit}")
        return ", ".join(parts)


@dataclass(frozen=True)
class Spec:
    """An instrument specification: limits and the decision rule.

    Attributes
    ----------
    name : str
    decision_rule : {"guarded", "simple"}
    limits : tuple of Limit
    source : str
        Where it came from (for messages).
    """

    name: str
    decision_rule: str
    limits: tuple[Limit, ...]
    source: str = "spec"

    def check_quantities(self, known: Iterable[str], model: Iterable[str] = (), *,
                         kind: str = "the result") -> None:
        """Every limited quantity must be a quantity of the procedure (did-you-mean otherwise).

        Parameters
        ----------
        known : iterable of str
            Quantities the result determines (coefficients and combinations).
        model : iterable of str
            Coefficients of the procedure's model, determined or not: a limit on one the test
            does not determine is judged *not determined*, not an error.
        kind : str
            The procedure, for the message.
        """
        names = list(known)
        others = [m for m in model if m not in names]
        for lim in self.limits:
            if lim.quantity not in names and lim.quantity not in others:
                extra = (f"; in its model, not determined separately: {', '.join(others)}"
                         if others else "")
                raise SpecError(
                    f'{self.source}: quantity "{lim.quantity}" is not a quantity of {kind}'
                    f'{did_you_mean(lim.quantity, names + others)}; it determines '
                    f'{", ".join(names)}{extra}')


@dataclass(frozen=True)
class Verdict:
    """Conformance of one quantity with its limit.

    Attributes
    ----------
    quantity, unit : str
    value : float or None
        Estimate [unit] (the result's unit); None when not determined.
    limit_unit : str
        The unit the limit is written in (a report shows the value in it too).
    expanded : float or None
        Expanded uncertainty U [unit]; None when not determined.
    coverage_factor : float
        The k of U (the budget's Welch-Satterthwaite k, or 2 for the Type A alone).
    u_source : str
        ``"budget"`` (Type A and B, k from the budget) or ``"type A only, k = 2"``.
    limit : str
        The limit as written in the spec, with its unit.
    clause : str
    verdict : str
        One of :data:`VERDICTS`.
    coverage_factor : float or None
        None when not determined.
    note : str
        Why a quantity is not determined, and what is (empty otherwise).
    """

    quantity: str
    value: float | None
    unit: str
    expanded: float | None
    u_source: str
    limit: str
    clause: str
    verdict: str
    coverage_factor: float | None = 2.0
    note: str = ""
    limit_unit: str = ""

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        out: dict[str, object] = {
            "quantity": self.quantity, "value": self.value, "unit": self.unit,
            "expanded_uncertainty": self.expanded, "coverage_factor": self.coverage_factor,
            "uncertainty_source": self.u_source,
            "limit": self.limit, "limit_unit": self.limit_unit or self.unit,
            "clause": self.clause, "verdict": self.verdict}
        if self.note:
            out["note"] = self.note
        return out


@dataclass(frozen=True)
class Conformance:
    """Verdicts of a result against a specification.

    Attributes
    ----------
    spec_name, decision_rule, rule : str
        The specification, its decision rule and the rule's text.
    verdicts : tuple of Verdict
    """

    spec_name: str
    decision_rule: str
    rule: str
    verdicts: tuple[Verdict, ...]

    @property
    def overall(self) -> str:
        """The worst verdict."""
        return max((v.verdict for v in self.verdicts), key=VERDICTS.index, default="pass")

    def to_dict(self) -> dict[str, object]:
        """The ``conformance`` block of the result envelope."""
        return {"spec": self.spec_name, "decision_rule": self.decision_rule, "rule": self.rule,
                "overall": self.overall, "verdicts": [v.to_dict() for v in self.verdicts]}


_SPEC_FIELDS = (
    Field("name", "text", default="specification"),
    Field("decision_rule", "text", default="guarded", choices=tuple(DECISION_RULES)),
)
_LIMIT_FIELDS = (
    Field("quantity", "text", doc='a coefficient or combination name, e.g. quantity = "DI"'),
    Field("unit", "text", doc='the unit of the limits, e.g. unit = "deg/h/g"'),
    Field("clause", "text", doc='where the limit comes from, e.g. clause = "IEEE Std 952-2020"'),
    Field("min", default=None),
    Field("max", default=None),
    Field("max_abs", default=None, minimum=0.0),
    Field("id", "text", default="", doc="the clause's identifier in an acceptance campaign"),
)


def spec_from_mapping(doc: Mapping[str, Any], *, source: str = "spec") -> Spec:
    """A :class:`Spec` from a parsed specification file; clean errors for every mistake."""
    check_known_keys(doc, {"spec", "limit"}, source, error=SpecError)
    head = doc.get("spec", {})
    if not isinstance(head, Mapping):
        raise SpecError(f"{source}: [spec] must be a table")
    h = read_fields(head, _SPEC_FIELDS, f"{source}: [spec]", error=SpecError)
    items = doc.get("limit")
    if not isinstance(items, list) or not items:
        raise SpecError(f"{source} has no [[limit]] entries; see examples/specs/")
    limits = []
    for i, t in enumerate(items):
        where = f"{source}: [[limit]] #{i + 1}"
        if not isinstance(t, Mapping):
            raise SpecError(f"{where} must be a table")
        v = read_fields(t, _LIMIT_FIELDS, where, error=SpecError)
        where = f'{source}: limit on "{v["quantity"]}"'
        if v["min"] is None and v["max"] is None and v["max_abs"] is None:
            raise SpecError(f"{where} has no limit; give max_abs, or min and/or max")
        if v["max_abs"] is not None and (v["min"] is not None or v["max"] is not None):
            raise SpecError(f"{where}: give either max_abs or min/max, not both")
        if v["min"] is not None and v["max"] is not None and v["min"] > v["max"]:
            raise SpecError(f"{where}: min {v['min']:g} is above max {v['max']:g}")
        try:
            compound_unit(v["unit"])
        except UnitError as exc:
            raise SpecError(f"{where}: {exc}") from None
        limits.append(Limit(quantity=v["quantity"], unit=v["unit"], clause=v["clause"],
                            minimum=v["min"], maximum=v["max"], max_abs=v["max_abs"],
                            id=v["id"]))
    ids = [lim.id for lim in limits if lim.id]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        raise SpecError(f"{source}: clause id {twice[0]!r} names more than one limit; give each "
                        "[[limit]] its own id")
    return Spec(name=h["name"], decision_rule=h["decision_rule"], limits=tuple(limits),
                source=source)


def read_spec(path: str | os.PathLike[str], result: Any = None) -> Spec:
    """Read a specification file (TOML; layout in the module docstring).

    Parameters
    ----------
    path : path-like
    result : procedure result, optional
        When given, every limited quantity must be one of its coefficients or combinations.

    Raises
    ------
    SpecError
        Missing or invalid file, an unknown key, a limit without a bound, an unknown unit, a
        quantity the result does not have (with did-you-mean).
    """
    source = f"spec file {os.fspath(path)}"
    doc = read_toml_file(path, source=source, error=SpecError,
                         missing="give --spec an instrument specification (see examples/specs/)")
    spec = spec_from_mapping(doc, source=source)
    if result is not None:
        spec.check_quantities(quantities_of(result))
    return spec


def decide(value: float, expanded: float, *, lower: float | None = None,
           upper: float | None = None, rule: str = "guarded") -> str:
    """Verdict of ``value`` with expanded uncertainty ``expanded`` against ``lower``/``upper``.

    Guarded (w = U): inside by at least U -> pass; inside by less -> conditional pass; outside by
    at most U -> conditional fail; outside by more -> fail. Simple (w = 0): pass / fail. A value
    exactly on a limit is inside; ``value + U`` exactly on it is a pass.
    """
    if rule not in DECISION_RULES:
        raise SpecError(f'unknown decision rule "{rule}"; use one of {", ".join(DECISION_RULES)}')
    w = expanded if rule == "guarded" else 0.0
    worst = 0
    for bound, sign in ((upper, 1.0), (lower, -1.0)):
        if bound is None:
            continue
        margin = sign * (bound - value)     # > 0: inside
        if margin >= w:
            v = 0
        elif margin >= 0:
            v = 1
        elif margin >= -w:
            v = 2
        else:
            v = 3
        worst = max(worst, v)
    if rule == "simple":
        return "pass" if worst == 0 else "fail"
    return ("pass", "conditional pass", "conditional fail", "fail")[worst]


def model_names(result: Any) -> list[str]:
    """Coefficients of the result's model, determined or not (``identification.names``)."""
    ident = getattr(result, "identification", None)
    return [str(n) for n in getattr(ident, "names", ())]


def not_determined_note(result: Any, name: str) -> str:
    """Why model coefficient ``name`` is not determined by ``result``, and what is instead.

    The identification's ``not_separable`` statement naming it, and the determined
    combinations it enters (``DF + 0.997972*DII``).
    """
    ident = getattr(result, "identification", None)
    word = re.compile(rf"(?<![A-Za-z0-9_]){re.escape(name)}(?![A-Za-z0-9_])")
    why = next((str(s) for s in getattr(ident, "not_separable", ()) if word.search(str(s))),
               "the test's positions do not separate it")
    combos = [c.name for c in getattr(result, "combinations", ())
              if c.terms.get(name, 0.0) != 0.0]
    out = f"{name} is not determined by this test: {why}"
    if combos:
        out += f"; determined instead: {', '.join(combos)}"
    return out


def rule_text(rule: str, coverage_factors: Iterable[float | None] = (), *,
              per: str | None = None) -> str:
    """The decision rule in words, with the coverage factor(s) actually used.

    ``k = 2.01`` when every verdict used one k (to two decimals), ``k = 2.00 to 2.01, each
    quantity's from its effective degrees of freedom`` otherwise, ``k = 2`` with none. With
    ``per`` (``"clause"``: a series of tests), several k are listed as each row's own: ``k per
    clause as in its row: 2.01, 2.08 and 4.53, each from its test's effective degrees of
    freedom``.
    """
    ks = sorted({round(float(k), 2) for k in coverage_factors
                 if k is not None and math.isfinite(k)})
    if not ks:
        k = "k = 2"
    elif len(ks) == 1:
        k = f"k = {ks[0]:.2f}"
    elif per is not None:
        listed = ", ".join(f"{x:.2f}" for x in ks[:-1]) + f" and {ks[-1]:.2f}"
        k = (f"k per {per} as in its row: {listed}, each from its test's effective degrees "
             "of freedom")
    else:
        k = (f"k = {ks[0]:.2f} to {ks[-1]:.2f}, each quantity's from its effective degrees of "
             "freedom")
    return DECISION_RULES[rule].replace("{k}", k)


def verdicts(result: Any, spec: Spec, budget: UncertaintyBudget | None = None) -> Conformance:
    """Verdict per limited quantity of ``result`` under the spec's decision rule.

    Parameters
    ----------
    result : procedure result
    spec : Spec
    budget : UncertaintyBudget, optional
        Its expanded uncertainty U (Type A and B) is the guard band; without it U = 2 x the
        Type-A std, and the verdict says so.

    Raises
    ------
    SpecError
        A quantity that is no quantity of the procedure, or a limit unit that cannot express the
        result's unit. A coefficient of the model the test does not determine gets the verdict
        *not determined* (:func:`not_determined_note`).
    """
    q = quantities_of(result)
    spec.check_quantities(q, model_names(result), kind=getattr(result, "kind", "the result"))
    out = []
    for lim in spec.limits:
        if lim.quantity not in q:
            out.append(Verdict(quantity=lim.quantity, value=None, unit=lim.unit, expanded=None,
                               u_source="-", limit=lim.text(), clause=lim.clause,
                               verdict=NOT_DETERMINED, coverage_factor=None,
                               note=not_determined_note(result, lim.quantity),
                               limit_unit=lim.unit))
            continue
        value, std, unit = q[lim.quantity]
        if budget is not None and lim.quantity in budget.quantities:
            b = budget.quantities[lim.quantity]
            U, k, src = b.expanded, b.coverage_factor, f"budget, k = {b.coverage_factor:.2f}"
        else:
            U, k, src = 2.0 * std, 2.0, "type A only, k = 2"
        try:
            x, u = convert(value, unit, lim.unit), convert(U, unit, lim.unit)
        except UnitError:
            raise SpecError(f'{spec.source}: limit on "{lim.quantity}" is in "{lim.unit}" but '
                            f'the result gives it in "{unit}"; write the limit in {unit} or an '
                            "equivalent unit") from None
        if not math.isfinite(u):
            u = 0.0
        if lim.max_abs is not None:
            verdict = decide(abs(x), u, upper=lim.max_abs, rule=spec.decision_rule)
        else:
            verdict = decide(x, u, lower=lim.minimum, upper=lim.maximum,
                             rule=spec.decision_rule)
        out.append(Verdict(quantity=lim.quantity, value=value, unit=unit, expanded=U,
                           u_source=src, limit=lim.text(), clause=lim.clause, verdict=verdict,
                           coverage_factor=k, limit_unit=lim.unit))
    return Conformance(spec_name=spec.name, decision_rule=spec.decision_rule,
                       rule=rule_text(spec.decision_rule, (v.coverage_factor for v in out)),
                       verdicts=tuple(out))
