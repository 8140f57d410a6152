"""Every procedure of the registry, through the one fit and simulate (Procedure.fit/.simulate).

For each registered kind: its example plan and truth are simulated with noise, fitted through
the same front, and every identifiable coefficient (and combination) recovers the truth within
its reported standard uncertainty (4.5 sigma, Bonferroni over the quantities of all kinds). And
the uncertainty budget propagates each Type-B source through the procedure's motion: the
contribution it reports equals the change of the estimates when the test is simulated on the
perturbed machine (``proc.motion(plan, type_b=...)``) and fitted on the nominal one.
"""

from __future__ import annotations

import warnings

import pytest

import inertest
from inertest.errors import InertestWarning
from inertest.io.plan_file import load_truth
from inertest.procedures import REGISTRY, procedure
from inertest.procedures.base import Procedure
from inertest.quality.budget import quantities_of, uncertainty_budget
from inertest.quality.lab import TYPE_B_UNITS, Equipment, TypeB
from procedure_examples import EXAMPLES


def test_the_registry_finds_every_procedure_module_and_only_those():
    assert set(REGISTRY) == set(EXAMPLES)
    for kind in REGISTRY:
        proc = procedure(kind)
        assert isinstance(proc, Procedure) and proc.kind == kind
        assert proc.__module__ == "inertest.procedures." + kind.replace("-", "_")
    for helper in ("base", "spec", "sdf-drift", "thermal-triad", "navigation-calibration"):
        assert helper not in REGISTRY


#: Modules of procedures/ that are not procedures: the type, the spec reader, shared pieces.
HELPERS = {"__init__", "base", "spec", "sdf_drift", "static_record"}


def test_the_no_procedure_imports_another_contract_lists_every_procedure_module():
    """pyproject's import-linter contract names each procedure module: a new one left off it
    would escape the rule silently (found by an independent review of the architecture page)."""
    import tomllib
    from pathlib import Path

    import inertest.procedures as package

    root = Path(package.__file__).parent
    doc = tomllib.loads((root.parents[2] / "pyproject.toml").read_text(encoding="utf-8"))
    contract = next(c for c in doc["tool"]["importlinter"]["contracts"]
                    if c["type"] == "independence")
    listed = {m.removeprefix("inertest.procedures.") for m in contract["modules"]}
    on_disk = {p.stem for p in root.glob("*.py")} - HELPERS
    assert listed == on_disk
    assert {k.replace("-", "_") for k in REGISTRY} <= on_disk


def _example(kind, examples_dir):
    folder, truth, noise = EXAMPLES[kind]
    plan = inertest.load_plan(examples_dir / folder / "plan.toml")
    return plan, load_truth(examples_dir / folder / truth), noise


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_round_trip_through_the_one_fit_and_simulate(kind, examples_dir):
    plan, truth, noise = _example(kind, examples_dir)
    proc = procedure(kind)
    data = proc.simulate(plan, truth, noise=noise, rng=7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)
        res = proc.fit(plan, data)
    assert res.instrument == plan.instrument  # the one fit puts the instrument on the result
    true = proc.truth_quantities(truth)
    checked = 0
    for name, e in res.coefficients.items():
        if name in true:
            assert abs(e.value - true[name]) <= 4.5 * e.std + 1e-9 * abs(true[name]), (
                kind, name, e.value, true[name], e.std)
            checked += 1
    for c in res.combinations:
        value = c.evaluate(true)
        assert abs(c.value - value) <= 4.5 * c.std + 1e-9 * abs(value), (kind, c.name)
        checked += 1
    assert checked >= 3, kind


def _lab_item(proc: Procedure) -> Equipment | None:
    """One lab item stating each Type-B source the procedure's machines accept."""
    keys = {"angle": ("angle_arcsec", 5.0), "tilt": ("tilt_urad", 20.0),
            "rate": ("rate_ppm", 10.0), "radius": ("radius_um", 20.0),
            "squareness": ("squareness_urad", 10.0)}
    names = {s.name for m in proc.machines for s in m.TYPE_B}
    if not names:
        return None
    def type_b(key: str, value: float) -> TypeB:
        suffix = next(s for s in TYPE_B_UNITS if key.endswith(s))
        unit, factor = TYPE_B_UNITS[suffix]
        return TypeB(key=key, name=key[: -len(suffix)], value=value, unit=unit, si=value * factor)

    return Equipment(id="EQ-1", name="test machine",
                     type_b=tuple(type_b(*keys[n]) for n in sorted(names)))


@pytest.mark.parametrize("kind", sorted(k for k in EXAMPLES if procedure(k).machines))
def test_budget_propagates_type_b_through_the_procedures_motion(kind, examples_dir):
    plan, truth, _ = _example(kind, examples_dir)
    proc = procedure(kind)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)
        res = proc.fit(plan, proc.simulate(plan, truth, noise=0.0, rng=0), sigma=1.0)
        item = _lab_item(proc)
        budget = uncertainty_budget(plan, res, [item])
    white = "white" if "white" in proc.noise_models else None
    fitted_truth = {k: v for k, v in ((n, e.value) for n, e in res.coefficients.items())}
    for c in res.combinations:
        lead = next((k for k, w in c.terms.items() if w == 1.0 and k not in fitted_truth), None)
        if lead is not None:
            fitted_truth[lead] = c.value
    for k in list(fitted_truth):  # what the procedure derives from the rest (K_pos from K)
        rest = {n: v for n, v in fitted_truth.items() if n != k}
        if k in proc.truth_quantities(rest):
            fitted_truth = rest
    nominal = quantities_of(proc.fit(plan, proc.simulate(plan, fitted_truth, noise=0.0, rng=0),
                                     sigma=1.0, noise_model=white))
    seen = 0
    for t in item.type_b:
        declared = next(s for m in proc.machines for s in m.TYPE_B if s.name == t.name)
        for error, component, _ in declared.error_names():
            label = f"EQ-1 {t.key}" + (f" ({component})" if component else "")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", InertestWarning)
                motion = proc.motion(plan, type_b={error: t.si})
                data = proc.simulate(plan, fitted_truth, noise=0.0, rng=0, motion=motion)
                moved = quantities_of(proc.fit(plan, data, sigma=1.0, noise_model=white))
            for name, q in budget.quantities.items():
                got = next(c.value for c in q.contributions if c.source == label)
                want = moved[name][0] - nominal[name][0]
                assert got == pytest.approx(want, rel=1e-9, abs=1e-12 * (abs(q.value) + 1)), (
                    kind, label, name)
                seen += abs(want) > 0
    assert seen > 0, f"{kind}: no Type-B source moved any estimate"
