"""Centrifuge error study (issue 5): closed-form checks of the error transfer and the fit."""

import math
from pathlib import Path

import numpy as np
import pytest

from inertest.earth import OMEGA_IE
from inertest.equipment import centrifuge as cf
from inertest.errors import PlanError
from inertest.io.plan_file import read_toml
from inertest.procedures.centrifuge_nine_position import fit_inputs
from inertest.studies import centrifuge_study as cs
from inertest.units import ARCMIN_TO_RAD, DEG_PER_H_TO_RAD_PER_S

EXAMPLE = Path(__file__).parents[2] / "examples" / "centrifuge" / "study.toml"
K = DEG_PER_H_TO_RAD_PER_S


def _plan(cases=(), revolutions=5, **kw):
    return cs.StudyPlan(revolutions=revolutions, cases=tuple(cases), **kw)


def test_error_free_machine_is_identified_exactly_and_std_follows_sqrt_n():
    r5 = cs.run_study(_plan(), fit_inputs, monte_carlo_runs=0)
    r20 = cs.run_study(_plan(revolutions=20), fit_inputs, monte_carlo_runs=0)
    assert r5.monte_carlo_std is None
    assert np.all(r5.std > 0)
    # four times the samples per run -> half the standard uncertainty (white noise)
    np.testing.assert_allclose(r20.std / r5.std, 0.5, rtol=0.02)


def test_constant_dgamma_error_is_the_turned_earth_rate():
    dg = 1000 * ARCMIN_TO_RAD
    case = cs.ErrorCase("dg", "dgamma 1000'", dgamma=cf.RateTracking(0.0, dg))
    res = cs.run_study(_plan([case]), fit_inputs, monte_carlo_runs=0).cases[0]
    # largest change of the Earth rate on I: I horizontal and perpendicular to north
    # (positions 4-6, I = y_P = west), turned by dgamma about the vertical
    expected = OMEGA_IE * math.cos(math.radians(45.0)) * math.sin(dg)
    assert res.max_run_rate_error_rad_s == pytest.approx(expected, rel=1e-9)
    assert np.abs(res.error).max() > 100 * K * 1e-6
    assert np.abs(res.error_compensated).max() < 1e-15  # rad/s, rounding (2e-10 deg/h)


def test_rate_tracking_puts_its_residual_rate_on_a_vertical_input_axis():
    rate = 20.7 * ARCMIN_TO_RAD
    case = cs.ErrorCase("rt", "rate tracking", dgamma=cf.RateTracking(rate))
    res = cs.run_study(_plan([case]), fit_inputs, monte_carlo_runs=0).cases[0]
    # positions 7-9 at fixture 0 have I = z_P, the azimuth axis: the gyro sees d(dgamma)/dt
    assert res.max_run_rate_error_rad_s == pytest.approx(rate, rel=1e-9)
    assert np.abs(res.error_compensated).max() < 1e-15  # rad/s


def test_eccentricity_on_a_counter_rotating_platform_costs_nothing():
    case = cs.ErrorCase("ecc", "ecc", cf.CentrifugeErrors(eccentricity_x_m=0.01,
                                                          eccentricity_y_m=-0.02))
    res = cs.run_study(_plan([case]), fit_inputs, monte_carlo_runs=0).cases[0]
    assert np.abs(res.error).max() < 1e-15  # rad/s, rounding (2e-10 deg/h)


@pytest.mark.parametrize("errors", [
    cf.CentrifugeErrors(parallelism_y_rad=5e-5),
    cf.CentrifugeErrors(radius_poly_m=(0.0, 1e-4)),
    cf.CentrifugeErrors(misalignment_y_poly_rad=(0.0, 1e-5), misalignment_z_poly_rad=(1e-5,)),
    cf.CentrifugeErrors(wobble_x_rad=5e-5, wobble_y_rad=5e-5, wobble_y_phase_rad=1.0),
])
def test_machine_errors_bias_the_ideal_fit_and_the_error_model_removes_them(errors):
    res = cs.run_study(_plan([cs.ErrorCase("e", "e", errors)]), fit_inputs,
                       monte_carlo_runs=0).cases[0]
    assert np.abs(res.error).max() > 1e-13  # rad/s
    assert np.abs(res.error_compensated).max() < 1e-15  # rad/s, rounding (2e-10 deg/h)


def test_example_plan_loads_with_the_source_settings():
    plan = cs.plan_from_mapping(read_toml(EXAMPLE, "plan"), source="study.toml")
    assert plan.radius_m == 2.5 and plan.omegas_rad_s == (4.43, 8.85)
    assert plan.sample_rate_hz == 50.0 and plan.revolutions == 100
    assert plan.noise_sigma_rad_s == pytest.approx(1e-7 / 3)
    assert {c.key for c in plan.cases} >= {"parallelism", "dgamma_200", "dgamma_1000",
                                           "phase_tracking", "rate_tracking"}


@pytest.mark.parametrize("doc, match", [
    ({"machine": {"radius": 2.5}}, "unknown key.*known: .*radius_m"),
    ({"machine": {"omega_rad_s": 4.43}}, "must be a list"),
    ({"truth": {"DXX": 1.0}}, "unknown key"),
    ({"errors": {"a": {"dgamma_offset_arcmin": 1.0, "rate_tracking_arcmin_per_s": 2.0}}},
     "give one non-synchronisation"),
    ({"errors": {"a": {"phase_tracking_arcmin": 2.0}}}, "needs phase_tracking_hz"),
    ({"errors": {"a": {"parallelism_y_radians": 2.0}}}, "known: .*parallelism_y_rad"),
    ({"machine": {"revolutions": 0}}, "at least 1"),
    ({"bogus": {}}, "unknown table"),
])
def test_bad_plans_name_the_problem_and_the_fix(doc, match):
    with pytest.raises(PlanError, match=match):
        cs.plan_from_mapping(doc)


@pytest.mark.slow
def test_monte_carlo_scatter_confirms_the_analytic_uncertainty():
    plan = _plan(revolutions=10)
    res = cs.run_study(plan, fit_inputs, monte_carlo_runs=300)
    ratio = res.monte_carlo_std / res.std
    assert np.all(np.abs(ratio - 1) < 0.2), ratio


def test_seed004_parallelism_example_compared_at_position_2_and_4_42_rad_s():
    # The paper's 7.11e-6 rad/s is for its second attitude (position 2) at 4.42 rad/s. There the
    # tilted azimuth axis leaves the relative rate w (z - z'), horizontal, of size w dth, turning
    # with the arm; I of position 2 is 45 deg from the vertical: amplitude w dth cos 45.
    dth = 5e-6
    case = cs.ErrorCase("par", "par", cf.CentrifugeErrors(parallelism_y_rad=dth))
    res = cs.run_study(_plan([case], revolutions=4), fit_inputs, monte_carlo_runs=0).cases[0]
    assert res.example_first_harmonic_rad_s == pytest.approx(4.42 * dth * math.sqrt(0.5),
                                                             rel=1e-4)
    # With the fit's weights the first harmonic averages out; what is left is the second-order
    # vertical rate w (1 - cos dth) ~ w dth^2 / 2 (largest at 8.85 rad/s, I vertical)
    assert res.max_run_rate_error_rad_s == pytest.approx(8.85 * dth**2 / 2, rel=1e-3)
    notes = cs.run_study(_plan([case], revolutions=4), fit_inputs, monte_carlo_runs=0).notes
    note = next(n for n in notes if "7.11e-6" in n)
    assert "position 2) at 4.42 rad/s" in note and "1.563e-05 rad/s" in note


def test_report_cites_the_paper_not_the_seed_file():
    from inertest.report.centrifuge_study import study_page

    plan = cs.plan_from_mapping(read_toml(EXAMPLE, "plan"), source="study.toml")
    small = cs.StudyPlan(revolutions=2, cases=plan.cases[:1], name=plan.name)
    html = study_page(cs.run_study(small, fit_inputs, monte_carlo_runs=0))
    assert "seed 004" not in html.lower() and "[centrifuge paper]" not in html
    assert "Sun, Ren &amp; Wang" in html
    assert "Sun Yingbo, Ren Shunqing, Wang Changhong" in html
    assert "Coriolis part (Ak)" in html and "simplification" in html


def test_example_wobble_case_is_not_a_static_parallelism():
    plan = cs.plan_from_mapping(read_toml(EXAMPLE, "plan"), source="study.toml")
    e = next(c for c in plan.cases if c.key == "wobble").errors
    assert e.wobble_x_rad == e.wobble_y_rad
    # phase difference +90 deg would be a static tilt (tests/equipment); the example uses -90
    assert math.remainder(e.wobble_y_phase_rad - e.wobble_x_phase_rad + math.pi / 2,
                          2 * math.pi) == pytest.approx(0.0)
