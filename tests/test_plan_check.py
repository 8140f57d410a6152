"""inertest.plan_check: predicted uncertainty of a plan before testing (issue 20).

References: the Monte Carlo scatter of simulated-and-fitted tests with noise from
tests/noise_generators.py (written apart from the library), the 1/sqrt(n) law of a mean of n
white readings, and the variance of a position mean, sigma^2 / n + sigma_pos^2, derived by hand.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from inertest.api import fit, load_plan, simulate
from inertest.cli import main
from inertest.conformance import spec_from_mapping
from inertest.plan_check import NoiseModel, check_plan, predict_std
from noise_generators import noise as mc_noise

SIGMA = 0.002  # mA per reading (S_T = 12.5 deg/h/mA: 0.025 deg/h)


@pytest.fixture
def plan(examples_dir):
    return load_plan(examples_dir / "polar_tumble" / "plan.toml")


def _with(plan, **changes):
    return dataclasses.replace(plan, procedure=dataclasses.replace(plan.procedure, **changes))


def _spec(max_abs_di: float):
    return spec_from_mapping({"spec": {"name": "test"}, "limit": [
        {"quantity": "DI", "max_abs": max_abs_di, "unit": "deg/h/g",
         "clause": "IEEE Std 517-1974"}]})


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["white", "position-offsets"])
def test_predicted_std_matches_monte_carlo_scatter_of_fitted_tests(plan, kind):
    noise = NoiseModel(sigma=SIGMA, position_offset=SIGMA if kind != "white" else 0.0,
                       unit="mA")
    predicted, method, _, _ = predict_std(plan, noise)
    assert method.startswith("closed form")
    p = _with(plan, noise_model=kind)
    clean = simulate(p, {}, noise=0.0, rng=0)
    spp = plan.procedure.samples_per_position
    unit_of_row = np.arange(len(clean["output"])) // spp  # 5 readings per table position
    rng = np.random.default_rng(20)
    draws = mc_noise(kind, rng, 150, unit_of_row, SIGMA)
    est = {k: [] for k in predicted}
    for e in draws:
        r = fit(p, {**clean, "output": clean["output"] + e})
        for k, v in {**{n: x.value for n, x in r.coefficients.items()},
                     **{c.name: c.value for c in r.combinations}}.items():
            est[k].append(v)
    for k, (std, _) in predicted.items():
        ratio = std / np.std(est[k], ddof=1)
        assert 0.8 < ratio < 1.25, (k, ratio)


def test_quadrupled_dwell_halves_the_white_part_but_not_the_offset_part(plan):
    n = plan.procedure.samples_per_position
    white = NoiseModel(sigma=SIGMA, unit="mA")
    offsets = NoiseModel(sigma=SIGMA, position_offset=1.5 * SIGMA, unit="mA")
    long_plan = _with(plan, samples_per_position=4 * n)
    w1, _, _, n1 = predict_std(plan, white)
    w4, _, _, n4 = predict_std(long_plan, white)
    o1, _, _, _ = predict_std(plan, offsets)
    o4, _, _, _ = predict_std(long_plan, offsets)
    assert n4 == 4 * n1
    for k in w1:
        # mean of 4n white readings: std / sqrt(4) (closed form 1/sqrt(n))
        assert w4[k][0] == pytest.approx(w1[k][0] / 2, rel=1e-9)
        # a position mean has variance sigma^2/n + sigma_pos^2: the offset part,
        # var - white var = c sigma_pos^2, does not depend on the dwell
        off1 = o1[k][0] ** 2 - w1[k][0] ** 2
        off4 = o4[k][0] ** 2 - w4[k][0] ** 2
        assert off4 == pytest.approx(off1, rel=1e-9)
        assert off1 == pytest.approx(w1[k][0] ** 2 * n * 1.5**2, rel=1e-9)


def test_plan_that_cannot_verify_says_so_and_the_suggestion_does(plan):
    noise = NoiseModel(sigma=SIGMA, unit="mA")
    std_di = predict_std(plan, noise)[0]["DI"][0]
    # U = 2 std_di (no Type B without equipment): marginal at 3:1, verifiable with 2x dwell
    spec = _spec(0.85 * 3 * 2 * std_di)  # U / sqrt(2) < tolerance / 3 < U
    out = check_plan(plan, spec, noise)
    (di,) = out.plan.limits
    assert di.status == "marginal" and not out.ok
    assert di.expanded == pytest.approx(2 * std_di, rel=1e-6)
    s = out.suggestion
    assert s is not None and s.readings == 2 * out.plan.readings
    assert s.label.startswith("dwell x2")
    # the suggested plan, checked on its own, verifies the limit, with the U printed
    again = check_plan(s.plan, spec, noise)
    assert again.ok and again.plan.limits[0].expanded == pytest.approx(s.limits[0].expanded)
    assert s.limits[0].expanded == pytest.approx(2 * std_di / np.sqrt(2), rel=1e-6)


def test_quantity_the_plan_cannot_determine_is_reported(plan):
    spec = spec_from_mapping({"limit": [{"quantity": "DF", "max_abs": 0.1, "unit": "deg/h",
                                         "clause": "IEEE Std 517-1974"}]})
    out = check_plan(plan, spec, NoiseModel(sigma=SIGMA, unit="mA"))
    (df,) = out.plan.limits
    assert df.status == "not determined" and "not separable" in df.note
    assert out.suggestion is None and not out.ok


# --- command line ----------------------------------------------------------------------------


def test_cli_exit_status_json_and_suggestion(examples_dir, tmp_path, capsys):
    plan_file = examples_dir / "polar_tumble" / "plan.toml"
    noise = tmp_path / "noise.toml"
    noise.write_text(f"sigma = {SIGMA}\n")
    loose = examples_dir / "specs" / "floated_gyro.toml"
    assert main(["plan-check", str(plan_file), "--spec", str(loose), "--noise", str(noise),
                 "--equipment", str(examples_dir / "lab" / "equipment.toml"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["all_verifiable"] and {c["status"] for c in doc["plan"]["limits"]} == {
        "verifiable"}
    assert all(c["predicted_std_type_b"] > 0 for c in doc["plan"]["limits"])  # RT-02 tilt
    tight = tmp_path / "tight.toml"
    tight.write_text('[[limit]]\nquantity = "DI"\nmax_abs = 0.013\nunit = "deg/h/g"\n'
                     'clause = "IEEE Std 517-1974"\n')
    assert main(["plan-check", str(plan_file), "--spec", str(tight), "--noise",
                 str(noise)]) == 1
    out = capsys.readouterr().out
    assert "marginal" in out and "cheapest change: dwell x2" in out


def test_cli_maps_allan_json_to_white_noise_per_reading(examples_dir, tmp_path, capsys):
    # white rate noise of 0.025 deg/h at 10 Hz = 0.002 mA with S_T = 12.5 deg/h/mA
    rates = np.random.default_rng(5).normal(0.0, 0.025, 40000)
    np.save(tmp_path / "rate.npy", rates)
    assert main(["allan", str(tmp_path / "rate.npy"), "--rate", "10", "--unit", "deg/h",
                 "--json"]) == 0
    (tmp_path / "allan.json").write_text(capsys.readouterr().out)
    argv = ["plan-check", str(examples_dir / "polar_tumble" / "plan.toml"), "--spec",
            str(examples_dir / "specs" / "floated_gyro.toml"), "--noise",
            str(tmp_path / "allan.json"), "--json"]
    assert main(argv) == 2  # the plan has no sample rate: the mapping needs one
    assert "--sample-interval" in capsys.readouterr().err
    assert main([*argv, "--sample-interval", "0.1"]) == 0
    sigma = json.loads(capsys.readouterr().out)["noise"]["sigma"]
    assert sigma == pytest.approx(SIGMA, rel=0.05)


@pytest.mark.parametrize("text, message", [
    ("sigma = -1\n", "sigma must be a number >= 0"),
    ("sigam = 0.002\n", "unknown key(s) sigam"),
    ('sigma = 0.002\nunit = "m/s^2"\n', "cannot be expressed"),
    ("sigma = [\n", "neither JSON nor valid TOML"),
])
def test_cli_bad_noise_file_is_one_clean_line(examples_dir, tmp_path, capsys, text, message):
    bad = tmp_path / "noise.toml"
    bad.write_text(text)
    assert main(["plan-check", str(examples_dir / "polar_tumble" / "plan.toml"), "--spec",
                 str(examples_dir / "specs" / "floated_gyro.toml"), "--noise", str(bad)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1
