"""inertest.quality.plan_check: predicted uncertainty of a plan before testing (issue 20).

References: the Monte Carlo scatter of simulated-and-fitted tests with noise from
tests/noise_generators.py (written apart from the library), the 1/sqrt(n) law of a mean of n
white readings, and the variance of a position mean, sigma^2 / n + sigma_pos^2, derived by hand.
"""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest

from inertest.api import fit, load_plan, simulate
from inertest.cli import main
from inertest.errors import InertestWarning
from inertest.quality.conformance import SpecError, spec_from_mapping, verdicts
from inertest.quality.plan_check import NoiseModel, check_plan, predict_std
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
    # the same wording as a fit's verdict on the same limit
    fitted = fit(plan, simulate(plan, {"DI": 0.85}, noise=SIGMA, rng=1))
    assert verdicts(fitted, spec).verdicts[0].note == df.note
    assert "determined instead: DF + 0.99" in df.note
    # a name that is no quantity of the procedure at all is an error, with did-you-mean
    bad = spec_from_mapping({"limit": [{"quantity": "DFF", "max_abs": 0.1, "unit": "deg/h",
                                        "clause": "c"}]})
    with pytest.raises(SpecError, match=r'"DFF" is not a quantity of polar-tumble \(did you '
                                        r'mean "DF"'):
        check_plan(plan, bad, NoiseModel(sigma=SIGMA, unit="mA"))


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


# --- plans whose simulation needs a scale factor (triads, dividing head) ---------------------


def _scatter(plan, truth, kind, s, reps, seed):
    """Std of each quantity over ``reps`` simulated+fitted tests (noise_generators noise)."""
    clean = simulate(plan, truth, noise=0.0, rng=0)
    outputs = [c for c in clean if c.startswith("output")]
    rows = np.arange(len(clean[outputs[0]]))
    rng = np.random.default_rng(seed)
    draws = {c: mc_noise(kind, rng, reps, rows // plan.procedure.samples_per_position, s)
             for c in outputs}
    est: dict[str, list[float]] = {}
    for k in range(reps):
        with warnings.catch_warnings():  # a replicate's chance misfit warning (p < 0.05)
            warnings.simplefilter("ignore", InertestWarning)
            r = fit(plan, {**clean, **{c: clean[c] + draws[c][k] for c in outputs}})
        for name, v in {**{n: x.value for n, x in r.coefficients.items()},
                        **{c.name: c.value for c in r.combinations}}.items():
            est.setdefault(name, []).append(v)
    return {k: np.std(v, ddof=1) for k, v in est.items()}


@pytest.mark.parametrize("folder, spec, sigma, given_truth, reps", [
    ("triad_multiposition", "accelerometer_triad.toml", 2.0, False, 120),  # nominal K
    ("accelerometer_multipoint", "accelerometer.toml", 1e-6, True, 150),   # K1 of truth.toml
])
def test_scale_factor_plans_predict_the_scatter_of_fitted_tests(examples_dir, folder, spec,
                                                                sigma, given_truth, reps):
    from inertest.io.plan_file import load_truth
    from inertest.quality.conformance import read_spec

    plan = load_plan(examples_dir / folder / "plan.toml")
    truth = load_truth(examples_dir / folder / "truth.toml")
    out = check_plan(plan, read_spec(examples_dir / "specs" / spec),
                     NoiseModel(sigma=sigma, unit=plan.instrument.output_unit),
                     truth=truth if given_truth else None)
    assert out.plan.method.startswith("closed form")
    assert {c.status for c in out.plan.limits} == {"verifiable"}
    # the reference: tests simulated from the shipped truth (not the nominal), fitted with the
    # noise model that matches the noise (as plan-check predicts)
    scatter = _scatter(_with(plan, noise_model="white"), truth, "white", sigma, reps, 21)
    for k, (std, _) in out.plan.std_a.items():
        assert 0.8 < std / scatter[k] < 1.25, (k, std / scatter[k])


def test_cli_takes_the_truth_beside_the_plan_or_says_what_to_give(examples_dir, tmp_path,
                                                                 capsys):
    noise = tmp_path / "noise.toml"
    noise.write_text("sigma = 1e-6\n")
    plan = examples_dir / "accelerometer_multipoint" / "plan.toml"
    argv = ["--spec", str(examples_dir / "specs" / "accelerometer.toml"), "--noise", str(noise)]
    assert main(["plan-check", str(plan), *argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "accelerometer_multipoint/truth.toml beside the plan" in doc["nominal_instrument"]
    alone = tmp_path / "plan.toml"  # no truth.toml beside it
    alone.write_text(plan.read_text())
    assert main(["plan-check", str(alone), *argv]) == 2
    err = capsys.readouterr().err
    assert "needs K1" in err and "--truth FILE" in err and err.count("\n") == 1


# --- Monte Carlo for random walk / flicker: adaptive replicates ------------------------------


def test_std_relative_error_matches_the_spread_of_sample_stds():
    from inertest.quality.plan_check import std_relative_error

    rng = np.random.default_rng(3)
    for draw, n in ((lambda size: rng.normal(size=size), 60),
                    (lambda size: rng.uniform(size=size), 60),     # kurtosis 1.8
                    (lambda size: rng.laplace(size=size), 200)):   # kurtosis 6
        x = draw((4000, n))
        s = x.std(axis=1, ddof=1)
        spread = s.std() / s.mean()
        predicted = np.mean([std_relative_error(row) for row in x[:400]])
        assert predicted == pytest.approx(spread, rel=0.15)


@pytest.mark.slow  # a Monte Carlo loop: run by CI, skipped by -m 'not slow'
def test_random_walk_monte_carlo_stops_early_and_agrees_with_fitted_tests(examples_dir):
    plan = load_plan(examples_dir / "local_level_tumble" / "plan.toml")
    n = len(plan.procedure.positions) * plan.procedure.samples_per_position
    noise = NoiseModel(sigma=SIGMA, random_walk=3 * SIGMA / np.sqrt(n), unit="mA")
    predicted, method, _, _ = predict_std(plan, noise, n_mc=400)
    reps = int(method.split(":")[1].split()[0])
    assert 50 <= reps <= 100  # relative error < 10 %: about 1 / sqrt(2 n) for normal estimates
    scatter = _scatter(_with(plan, noise_model="random-walk"), {}, "random-walk", SIGMA, 200, 8)
    for k, (std, _) in predicted.items():
        # prediction 10 % and reference 5 % relative error: 0.75-1.33 is about 2.5 sigma
        assert 0.75 < std / scatter[k] < 1.33, (k, std / scatter[k])


def test_candidates_are_judged_cheapest_first_and_stop_at_the_suggestion(plan):
    noise = NoiseModel(sigma=SIGMA, unit="mA")
    std_di = predict_std(plan, noise)[0]["DI"][0]
    out = check_plan(plan, _spec(0.85 * 3 * 2 * std_di), noise)  # dwell x2 verifies
    assert out.suggestion is not None and out.candidates[-1] is out.suggestion
    assert [c.label.split(" (")[0] for c in out.candidates] == ["dwell x2"]


def test_cli_rounds_to_the_uncertainty_and_prints_round_off_as_zero(examples_dir, tmp_path,
                                                                    capsys):
    # sigma 0.002 deg/h per reading: DO's predicted std is 1.95e-4 deg/h/g, printed with two
    # significant digits "0.00020" (GUM 7.2.6), never "0.0002"; the zero nominal instrument
    # leaves DO and DS without Type B from the table (the tilt's Earth-rate harmonics cancel
    # between the O and S mountings): round-off of 1e-16 is printed as 0.
    noise = tmp_path / "noise.toml"
    noise.write_text('sigma = 0.002\nunit = "deg/h"\n')
    args = ["plan-check", str(examples_dir / "polar_tumble" / "plan.toml"), "--spec",
            str(examples_dir / "specs" / "floated_gyro.toml"), "--noise", str(noise)]
    assert main([*args, "--equipment", str(examples_dir / "lab" / "equipment.toml"),
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    do = next(c for c in doc["plan"]["limits"] if c["quantity"] == "DO")
    assert 0.000195 <= do["predicted_std_type_a"] < 0.000205
    assert main([*args, "--equipment", str(examples_dir / "lab" / "equipment.toml")]) == 0
    out = capsys.readouterr().out
    row = [c.strip() for c in next(line for line in out.splitlines()
                                    if "|DO| <= 1" in line).split("│")]
    assert row[3:5] == ["0.00020 deg/h/g", "0 deg/h/g"]
    assert "e-1" not in out
    # without --equipment the plan's ids are not checked: a warning says so
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "RT-02, GRAV-01" in err and "no lab equipment file" in err
