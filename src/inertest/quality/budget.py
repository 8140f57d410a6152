"""Uncertainty budget of a test result: Type A from the fit, Type B of the equipment and site.

For each quantity of a result (its identifiable coefficients and combinations) the budget lists
the Type-A standard uncertainty of the fit and one Type-B contribution per error source of the
test equipment named in the plan's ``[test] equipment`` (lab file ``type_b``, see
:mod:`inertest.quality.lab`) and of the site's local gravity, then combines them (JCGM 100:2008, GUM
5.1.2, uncorrelated input quantities: root sum of squares) and expands the combined standard
uncertainty with ``k = t_95.45(nu_eff)`` from the Welch-Satterthwaite effective degrees of
freedom (GUM G.4.1, eq. G.2b; the Type-B inputs taken as exactly known, ``nu = inf``, GUM G.4.3),
which is k = 2 once the fit has many degrees of freedom (GUM G.6.6). A noise level given to the
fit (``--sigma``) is a known standard deviation, not one estimated from the residuals (GUM G.3.2
applies the t-distribution to an estimated one): the Type-A part then has ``nu = inf`` too, so
``nu_eff = inf`` and ``k = 2`` (GUM G.1.3, table G.1: p = 95.45 %).

Propagation through the procedure's own model (GUM 5.1.3, sensitivity coefficient as a change
of the output estimate per change of an input estimate, evaluated numerically as GUM 5.1.3 note
2 allows): the test is simulated, noise-free, from the fitted coefficients on a machine carrying
one standard uncertainty of one error source (the procedure's motion with that Type-B error,
:meth:`inertest.procedures.base.Procedure.motion`; gravity by scaling the site's ``g``) and
fitted with the nominal machine; the change of each estimate is that source's contribution
``c_i u_i``. The least-squares estimates are linear in the data and the data in a small error,
so one evaluation per source is exact to first order.

Which sources apply to which procedure: each equipment module declares its ``TYPE_B`` sources
(angle, tilt, rate, radius) and each procedure names the equipment its motion is built from
(:attr:`inertest.procedures.base.Procedure.machines`); a lab-file key no machine of the
procedure accepts is listed as not applicable, never silently dropped; a source a machine
accepts but no listed item states is named in the assumptions as not included. A source
declared with components (the two directions of a table axis' tilt) gets the lab file's
standard uncertainty in each component, as independent sources.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from scipy import stats

from inertest.earth import Site, normal_gravity
from inertest.equipment.type_b import TypeBSource
from inertest.plan import Plan
from inertest.procedures import procedure
from inertest.quality.lab import Equipment

#: Coverage probability of the expanded uncertainty (k = 2 for a normal distribution, GUM G.6.6).
COVERAGE_PROBABILITY = 0.9545

#: Standard uncertainty of WGS-84 normal gravity as the local gravity of a lab when the plan gives
#: no measured value [m/s^2]: the normal formula is at the ellipsoid (the free-air gradient is
#: 3.086e-6 m/s^2 per m of height) and ignores the local anomaly (tens of mGal); 100 mGal assumed.
NORMAL_GRAVITY_U_M_S2 = 1e-3

_GRAVITY_SOURCE = "site gravity"


@dataclass(frozen=True)
class Contribution:
    """One Type-B source's contribution to one quantity.

    Attributes
    ----------
    source : str
        ``"<equipment id> <key>"`` (``"RT-02 angle_arcsec"``) or ``"site gravity"``.
    u : float
        Standard uncertainty of the source as stated [u_unit].
    u_unit : str
    sensitivity : float
        Change of the quantity per unit of the source [quantity unit / u_unit] (GUM 5.1.3).
    value : float
        ``sensitivity * u``, signed [quantity unit].
    """

    source: str
    u: float
    u_unit: str
    sensitivity: float
    value: float

    def to_dict(self) -> dict[str, object]:
        """``{"source", "u", "u_unit", "sensitivity", "contribution"}``."""
        return {"source": self.source, "u": self.u, "u_unit": self.u_unit,
                "sensitivity": self.sensitivity, "contribution": self.value}


@dataclass(frozen=True)
class QuantityBudget:
    """The uncertainty budget of one quantity of a result.

    Attributes
    ----------
    name, unit : str
    value : float
        The estimate [unit].
    type_a : float
        Standard uncertainty from the fit [unit].
    type_a_dof : float
        Its degrees of freedom: the fit's residual dof, ``inf`` when the noise level was given
        (a known standard deviation).
    contributions : tuple of Contribution
        Type-B contributions.
    combined : float
        Combined standard uncertainty ``sqrt(type_a^2 + sum c_i^2)`` [unit] (GUM 5.1.2).
    effective_dof : float
        Welch-Satterthwaite ``nu_eff = u_c^4 / (u_A^4 / nu_A)`` (GUM G.4.1); ``inf`` when the
        Type-A part vanishes.
    coverage_factor : float
        ``k = t_p(nu_eff)``, p = 95.45 % (GUM G.3.2, table G.2; 2 for ``nu_eff = inf``).
    expanded : float
        ``U = k u_c`` [unit].
    """

    name: str
    value: float
    unit: str
    type_a: float
    type_a_dof: float
    contributions: tuple[Contribution, ...]
    combined: float
    effective_dof: float
    coverage_factor: float
    expanded: float

    @property
    def type_b(self) -> float:
        """Root sum of squares of the Type-B contributions [unit]."""
        return float(math.sqrt(sum(c.value**2 for c in self.contributions)))

    def to_dict(self) -> dict[str, object]:
        """JSON form; every number with its unit."""
        return {
            "value": self.value, "unit": self.unit,
            "type_a": {"std": self.type_a,
                       "dof": None if not math.isfinite(self.type_a_dof) else self.type_a_dof},
            "type_b": [c.to_dict() for c in self.contributions],
            "combined_std": self.combined,
            "effective_dof": None if not math.isfinite(self.effective_dof)
            else self.effective_dof,
            "coverage_factor": self.coverage_factor,
            "expanded": self.expanded,
        }


@dataclass(frozen=True)
class UncertaintyBudget:
    """Uncertainty budgets of every quantity of a result.

    Attributes
    ----------
    quantities : dict of str to QuantityBudget
        By coefficient or combination name, in result order.
    sources : tuple of str
        The Type-B sources applied.
    not_applicable : tuple of str
        Lab-file keys of the plan's equipment that no machine of the procedure accepts.
    assumptions : tuple of str
        What the combination assumes, in plain language.
    """

    quantities: dict[str, QuantityBudget]
    sources: tuple[str, ...]
    not_applicable: tuple[str, ...]
    assumptions: tuple[str, ...]

    def to_dict(self) -> dict[str, object]:
        """The ``uncertainty_budget`` block of the result envelope."""
        return {
            "coverage_probability": COVERAGE_PROBABILITY,
            "quantities": {k: q.to_dict() for k, q in self.quantities.items()},
            "sources": list(self.sources),
            "not_applicable": list(self.not_applicable),
            "assumptions": list(self.assumptions),
        }


@dataclass(frozen=True)
class _Source:
    label: str
    u: float           # as written
    u_unit: str
    si: float          # standard uncertainty in SI
    name: str          # machine error name, or "gravity"
    relative: bool     # gravity given as a ratio (ppm) rather than m/s^2


def quantities_of(result: Any) -> dict[str, tuple[float, float, str]]:
    """``{name: (value, std, unit)}`` of a result's coefficients and combinations."""
    out = {k: (e.value, e.std, e.unit) for k, e in result.coefficients.items()}
    for c in result.combinations:
        out[c.name] = (c.value, c.std, c.unit)
    return out


def accepted_sources(kind: str) -> dict[str, str]:
    """``{source name: effect}`` the machines of procedure ``kind`` accept (gravity always)."""
    out = {"gravity": "local gravity: the site's g scaled by (1 + error)"}
    for name, s in _declared(kind).items():
        out.setdefault(name, s.effect)
    return out


def _declared(kind: str) -> dict[str, TypeBSource]:
    """``{source name: declaration}`` of the machines of procedure ``kind`` (first one wins)."""
    out: dict[str, TypeBSource] = {}
    for module in procedure(kind).machines:
        for s in module.TYPE_B:
            out.setdefault(s.name, s)
    return out


#: A lab-file key suggested for a source's SI unit (in the not-included assumption); angles of
#: an encoder or dividing head in arcsec.
_KEY_SUFFIX = {"rad": "_urad", "1": "_ppm", "m": "_um"}
_KEY_SUFFIX_OF = {"angle": "_arcsec"}


def uncertainty_budget(
    plan: Plan,
    result: Any,
    equipment: Sequence[Equipment] = (),
) -> UncertaintyBudget:
    """Type-A and Type-B uncertainty of every quantity of ``result``, combined and expanded.

    Parameters
    ----------
    plan : Plan
        The plan the result was fitted with.
    result : procedure result
        From :func:`inertest.fit` (``coefficients``, ``combinations``, ``identification.dof``).
    equipment : sequence of Equipment
        The lab records of the plan's ``[test] equipment``
        (:func:`inertest.quality.lab.select_equipment`).

    Returns
    -------
    UncertaintyBudget

    Notes
    -----
    The sources are taken as independent (GUM 5.1.2): one systematic error per source, common to
    the whole test. The site's gravity uncertainty is a lab-file ``gravity_mgal`` or
    ``gravity_ppm`` of a listed item when there is one; otherwise :data:`NORMAL_GRAVITY_U_M_S2`
    when the plan's gravity is the normal formula, and none when the plan gives a measured value.
    """
    accepted = accepted_sources(plan.kind)
    sources, not_applicable, assumptions = _sources(plan, equipment, accepted)
    quantities = quantities_of(result)
    deltas = _deltas(plan, result, sources) if sources else {}
    ident = result.identification
    # A given noise level is a known standard deviation: no Type-A degrees of freedom to count
    # (under a white noise model; other models estimate their components from the data).
    known = (not ident.sigma_from_residuals
             and getattr(ident, "noise_model", "white") == "white")
    dof: float = math.inf if known else int(ident.dof)
    out: dict[str, QuantityBudget] = {}
    for name, (value, std, unit) in quantities.items():
        contributions = []
        for s in sources:
            d = deltas.get(s.label, {}).get(name, 0.0)
            contributions.append(Contribution(
                source=s.label, u=s.u, u_unit=s.u_unit,
                sensitivity=d / s.u if s.u else 0.0, value=d))
        out[name] = combine(name, value, unit, std, dof, contributions)
    assumptions.insert(0, "sources independent: combined std = root sum of squares "
                          "(JCGM 100:2008, GUM 5.1.2); each Type-B source one systematic error "
                          "common to the whole test, propagated through the procedure's model")
    if known:
        assumptions.append("Type A: the noise level was given (a known standard deviation): "
                           "infinite degrees of freedom, so nu_eff = inf and k = 2 "
                           "(GUM G.4.1, table G.1)")
    return UncertaintyBudget(out, tuple(s.label for s in sources), tuple(not_applicable),
                             tuple(assumptions))


def combine(
    name: str, value: float, unit: str, type_a: float, type_a_dof: float,
    contributions: Sequence[Contribution],
) -> QuantityBudget:
    """Combined and expanded uncertainty of one quantity (GUM 5.1.2, G.4.1, G.3.2).

    Parameters
    ----------
    type_a : float
        Type-A standard uncertainty [unit], with ``type_a_dof`` degrees of freedom (``inf`` for
        a known standard deviation).
    contributions : sequence of Contribution
        Type-B contributions, each with infinite degrees of freedom.
    """
    ua = float(type_a) if math.isfinite(type_a) else 0.0
    uc = math.sqrt(ua**2 + sum(c.value**2 for c in contributions))
    if ua > 0 and math.isinf(type_a_dof):
        nu = math.inf
    elif ua > 0 and type_a_dof > 0:
        nu = uc**4 / (ua**4 / type_a_dof)
    elif ua > 0:
        nu = 1.0   # a Type-A std without degrees of freedom: the most cautious t
    else:
        nu = math.inf
    # nu_eff = inf: the normal distribution, k = 2 for p = 95.45 % (GUM G.1.3, table G.1)
    k = 2.0 if math.isinf(nu) else float(stats.t.ppf(0.5 + COVERAGE_PROBABILITY / 2, nu))
    dof = float(type_a_dof) if math.isinf(type_a_dof) else int(type_a_dof)
    return QuantityBudget(name=name, value=float(value), unit=unit, type_a=ua,
                          type_a_dof=dof, contributions=tuple(contributions),
                          combined=uc, effective_dof=float(nu), coverage_factor=k,
                          expanded=k * uc)


def _sources(
    plan: Plan, equipment: Iterable[Equipment], accepted: Mapping[str, str]
) -> tuple[list[_Source], list[str], list[str]]:
    sources: list[_Source] = []
    not_applicable: list[str] = []
    assumptions: list[str] = []
    declared = _declared(plan.kind)
    stated: set[str] = set()
    for e in equipment:
        for t in e.type_b:
            label = f"{e.id} {t.key}"
            if t.name not in accepted:
                machines = ", ".join(sorted(set(accepted) - {"gravity"})) or "none"
                not_applicable.append(
                    f"{label}: not applicable to this procedure ({plan.kind} accepts "
                    f"{machines} and gravity)")
                continue
            if t.name == "gravity" and t.unit not in ("mGal", "ppm"):
                not_applicable.append(f"{label}: gravity needs _mgal or _ppm")
                continue
            stated.add(t.name)
            if t.name == "gravity":
                sources.append(_Source(label, t.value, t.unit, t.si, t.name, t.unit == "ppm"))
                continue
            for error, component, _ in declared[t.name].error_names():
                sources.append(_Source(f"{label} ({component})" if component else label,
                                       t.value, t.unit, t.si, error, False))
    missing = [f"{n} ({n}{_KEY_SUFFIX_OF.get(n, _KEY_SUFFIX.get(d.si_unit, ''))}: {d.effect})"
               for n, d in declared.items() if n not in stated]
    if missing:
        assumptions.append("not included, no listed equipment states it: " + "; ".join(missing))
    if not any(s.name == "gravity" for s in sources):
        g_normal = float(normal_gravity(plan.site.latitude_rad))
        if abs(plan.site.gravity_m_s2 - g_normal) < 1e-9:
            u = NORMAL_GRAVITY_U_M_S2
            sources.append(_Source(_GRAVITY_SOURCE, u / 1e-5, "mGal", u, "gravity", False))
            assumptions.append(
                "site gravity: WGS-84 normal gravity at the latitude (plan gives none), "
                f"standard uncertainty {u / 1e-5:g} mGal assumed (height and local anomaly)")
        else:
            assumptions.append(
                "site gravity: the plan's measured value, its uncertainty not stated (add a "
                "gravity_mgal entry to a listed item of the lab file)")
    return sources, not_applicable, assumptions


def _truth(result: Any) -> dict[str, float]:
    """The fitted model coefficients as a truth; a combination's value goes to its leading term.

    Derived quantities a result reports beside the model's coefficients (a rate table's
    ``K_pos``) are not part of the truth.
    """
    truth = {k: float(e.value) for k, e in result.coefficients.items()}
    for c in result.combinations:
        lead = next((k for k, w in c.terms.items() if w == 1.0 and k not in truth), None)
        if lead is not None:
            truth[lead] = float(c.value)
    return truth


def _deltas(plan: Plan, result: Any, sources: Sequence[_Source]) -> dict[str, dict[str, float]]:
    """Per source, the change of each quantity when the test carries one std of that source.

    The test is simulated, noise-free, on the machine with that source's error (the
    procedure's motion with the Type-B error, or the site's gravity changed) and fitted with
    the nominal machine under white noise of a known level (the fits are of noise-free data).
    """
    proc = procedure(plan.kind)
    white = "white" if "white" in proc.noise_models else None
    truth = _truth(result)
    for k in list(truth):  # drop what the procedure derives from the rest (K_pos from K)
        rest = {n: v for n, v in truth.items() if n != k}
        try:
            if k in proc.truth_quantities(rest):
                truth = rest
        except Exception:   # noqa: BLE001 - a coefficient the derivation needs
            pass

    def run(p: Plan, type_b: Mapping[str, float]) -> dict[str, float]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = proc.simulate(p, truth, noise=0.0, rng=0, motion=proc.motion(p, type_b=type_b))
            # a known white level, where the procedure takes one (the fits are noise-free)
            fitted = proc.fit(plan, data, sigma=None if proc.sigma_note else 1.0,
                              noise_model=white)
        return {k: v[0] for k, v in quantities_of(fitted).items()}

    base = run(plan, {})
    out: dict[str, dict[str, float]] = {}
    for s in sources:
        if s.name == "gravity":
            g = plan.site.gravity_m_s2
            g1 = g * (1.0 + s.si) if s.relative else g + s.si
            site = Site(latitude_rad=plan.site.latitude_rad, gravity_m_s2=g1)
            q = run(dataclasses.replace(plan, site=site), {})
        else:
            q = run(plan, {s.name: s.si})
        out[s.label] = {k: float(q[k] - base[k]) for k in base if k in q}
    return out


def expanded_of(budget: UncertaintyBudget | None, name: str) -> float | None:
    """``U`` of quantity ``name`` from a budget, or None."""
    if budget is None or name not in budget.quantities:
        return None
    return budget.quantities[name].expanded


__all__ = ["Contribution", "QuantityBudget", "UncertaintyBudget", "accepted_sources",
           "combine", "expanded_of", "quantities_of", "uncertainty_budget"]
