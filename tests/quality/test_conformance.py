"""Specification limits and verdicts: ILAC-G8:09/2019 decision rules at the limits, spec files."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

import inertest
from inertest.quality.budget import UncertaintyBudget, combine, uncertainty_budget
from inertest.quality.conformance import SpecError, decide, read_spec, spec_from_mapping, verdicts

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(("value", "guarded", "simple"), [
    (0.5, "pass", "pass"),                    # inside by 0.5 >= U
    (0.75, "pass", "pass"),                   # inside by exactly U
    (0.875, "conditional pass", "pass"),      # inside by less than U
    (1.0, "conditional pass", "pass"),        # on the limit
    (1.125, "conditional fail", "fail"),      # outside by less than U
    (1.25, "conditional fail", "fail"),       # outside by exactly U
    (1.5, "fail", "fail"),                    # outside by more than U
])
def test_ilac_g8_upper_limit(value, guarded, simple):
    # limit x <= 1, U = 0.25 (binary fractions: the comparisons at the limits are exact)
    assert decide(value, 0.25, upper=1.0, rule="guarded") == guarded
    assert decide(value, 0.25, upper=1.0, rule="simple") == simple
    # the mirror image against a lower limit x >= -1
    assert decide(-value, 0.25, lower=-1.0, rule="guarded") == guarded
    assert decide(-value, 0.25, lower=-1.0, rule="simple") == simple


def test_range_takes_the_worse_side():
    assert decide(0.0, 0.25, lower=-1.0, upper=0.125) == "conditional pass"
    assert decide(0.0, 0.25, lower=-0.125, upper=0.125, rule="guarded") == "conditional pass"
    assert decide(0.5, 0.25, lower=-0.125, upper=0.125, rule="guarded") == "fail"


def _result():
    plan = inertest.load_plan(EXAMPLES / "polar_tumble" / "plan.toml")
    truth = EXAMPLES / "polar_tumble" / "truth.toml"
    return plan, inertest.fit(plan, inertest.simulate(plan, truth, noise=0.002, rng=1))


def _spec(**limit):
    lim = {"quantity": "DI", "unit": "deg/h/g", "clause": "IEEE Std 517-1974", **limit}
    return {"spec": {"name": "t", "decision_rule": "guarded"}, "limit": [lim]}


def test_verdicts_convert_units_and_use_budget_U():
    plan, result = _result()
    di = result.coefficients["DI"]
    budget = uncertainty_budget(plan, result)
    U = budget.quantities["DI"].expanded
    # limit in deg/s/g: DI = 0.85 deg/h/g; a limit 1.5 U above the value passes ...
    lim = (abs(di.value) + 1.5 * U) / 3600.0
    c = verdicts(result, spec_from_mapping(_spec(max_abs=lim, unit="deg/s/g")), budget)
    (v,) = c.verdicts
    assert v.verdict == "pass" and v.expanded == U and v.unit == "deg/h/g"
    # ... half a U above it is a conditional pass, half a U below a conditional fail
    for shift, want in ((0.5, "conditional pass"), (-0.5, "conditional fail"), (-2, "fail")):
        s = spec_from_mapping(_spec(max_abs=abs(di.value) + shift * U))
        assert verdicts(result, s, budget).verdicts[0].verdict == want
    # without a budget: U = 2 x the Type-A std, said so
    v = verdicts(result, spec_from_mapping(_spec(max=1.0))).verdicts[0]
    assert v.expanded == pytest.approx(2 * di.std) and "type A only" in v.u_source
    assert "ILAC-G8:09/2019" in c.to_dict()["rule"]


def test_bad_spec_files(tmp_path):
    _, result = _result()
    with pytest.raises(SpecError,
                       match=r'"DIx" is not a quantity of polar-tumble \(did you mean "DI"'):
        verdicts(result, spec_from_mapping(_spec(quantity="DIx", max_abs=1.0)))
    with pytest.raises(SpecError, match='"deg/h" but the result gives it in "deg/h/g"'):
        verdicts(result, spec_from_mapping(_spec(unit="deg/h", max_abs=1.0)))
    with pytest.raises(SpecError, match="has no limit; give max_abs, or min and/or max"):
        spec_from_mapping(_spec())
    with pytest.raises(SpecError, match='unknown unit symbol "furlong"'):
        spec_from_mapping(_spec(unit="furlong/h", max_abs=1.0))
    with pytest.raises(SpecError, match="decision_rule"):
        spec_from_mapping({**_spec(max_abs=1.0), "spec": {"decision_rule": "lenient"}})
    with pytest.raises(SpecError, match=r"max_abs must be >= 0, got -1.0$"):
        spec_from_mapping(_spec(max_abs=-1.0))     # the bound in words, no Python None
    with pytest.raises(SpecError, match="either max_abs or min/max"):
        spec_from_mapping(_spec(max_abs=1.0, max=2.0))
    with pytest.raises(SpecError, match="does not exist"):
        read_spec(tmp_path / "missing.toml")
    bad = tmp_path / "spec.toml"
    bad.write_text('[spec]\nname = "x"\n[[limit]]\nquantity = "DI"\nunit = "deg/h/g"\n'
                   'clause = "c"\nmax_abs = 1.0\nmaxx = 2\n')
    with pytest.raises(SpecError, match="maxx"):
        read_spec(bad, result)


@pytest.mark.parametrize(("spec", "plan"), [
    ("floated_gyro", "polar_tumble"), ("floated_gyro", "local_level_tumble"),
    ("floated_gyro", "servo_table"), ("accelerometer", "accelerometer_multipoint"),
    ("accelerometer_triad", "triad_multiposition"), ("fog", "gyro_rate_table"),
    ("fog_triad", "gyro_triad_rotation"),
])
def test_example_specs_fit_their_example_results(spec, plan):
    demo = {t["plan"].split("/")[0]: t for t in
            tomllib.loads((EXAMPLES / "demo.toml").read_text())["test"]}[plan]
    p = inertest.load_plan(EXAMPLES / demo["plan"])
    truth = (EXAMPLES / demo["plan"]).parent / demo["truth"]
    result = inertest.fit(p, inertest.simulate(p, truth, noise=demo.get("noise", 0.0),
                                               rng=demo.get("seed")))
    s = read_spec(EXAMPLES / "specs" / f"{spec}.toml", result)
    c = verdicts(result, s)
    assert all(v.clause.startswith("IEEE Std") for v in c.verdicts)


def test_a_model_coefficient_the_test_cannot_separate_is_not_determined():
    # A polar tumble determines DF only in DF + (g/g0)^2 DII: a limit on DF is "not determined"
    # (with the reason and the combination), the limit on DI is still judged.
    _, result = _result()
    spec = spec_from_mapping({"spec": {"name": "t"}, "limit": [
        {"quantity": "DF", "max_abs": 2.0, "unit": "deg/h", "clause": "c"},
        {"quantity": "DI", "max_abs": 1.0, "unit": "deg/h/g", "clause": "c"}]})
    c = verdicts(result, spec)
    df, di = c.verdicts
    assert df.verdict == "not determined" and df.value is None and df.expanded is None
    assert "not separable" in df.note and "determined instead: DF + 0.99" in df.note
    assert "DII" in df.note
    assert di.verdict == "pass"                   # truth DI = 0.85, U ~ 0.005 deg/h/g
    assert c.overall == "not determined"          # a pass needs every limit judged
    d = c.to_dict()
    assert json.loads(json.dumps(d, allow_nan=False))["verdicts"][0]["value"] is None


def test_rule_text_states_the_coverage_factor_used():
    # One quantity with u_A = 1 at 10 dof and no Type B: nu_eff = 10, and GUM table G.2 gives
    # t_95.45(10) = 2.28: the guarded rule says k = 2.28, not k = 2.
    _, result = _result()
    di = result.coefficients["DI"]
    q = combine("DI", di.value, di.unit, 1.0, 10, ())
    budget = UncertaintyBudget({"DI": q}, (), (), ())
    c = verdicts(result, spec_from_mapping(_spec(max_abs=100.0)), budget)
    assert "guard band w = U (expanded uncertainty, k = 2.28)" in c.rule
    assert c.verdicts[0].coverage_factor == pytest.approx(2.28, abs=0.005)
