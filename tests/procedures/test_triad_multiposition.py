"""Static multi-position calibration of an accelerometer triad (seed 003 sec. 1.1)."""

import warnings

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.equipment import multiposition as mp
from inertest.errors import (
    DataError,
    IdentifiabilityError,
    InertestWarning,
    InputError,
    PlanError,
)
from inertest.models.triad import TriadCalibration
from inertest.plan import Instrument, Plan
from inertest.procedures import triad_multiposition as tm
from noise_generators import noise as noise_for

TRUTH = {"K_x": 1671.2, "K_y": 1669.8, "K_z": 1672.5, "M_xy": 850.0, "M_xz": -420.0,
         "M_yx": 310.0, "M_yz": 1200.0, "M_zx": -640.0, "M_zy": 95.0, "B_x": 12.5,
         "B_y": -8.3, "B_z": 21.0}


def make_plan(positions="12", spp=1, unit="count", kind="accelerometer-triad", nominal=None,
              noise_model="auto"):
    params = {"positions": positions, "samples_per_position": spp, "noise_model": noise_model}
    if nominal is not None:
        params["nominal_scale_factor"] = nominal
    spec = tm.TriadMultipositionSpec.from_mapping(params)
    return Plan(Site.at(34.246), Instrument(kind=kind, output_unit=unit), spec)


@pytest.mark.parametrize("scheme", ["6", "12", "24"])
def test_exact_recovery(scheme):
    plan = make_plan(scheme)
    r = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1.0)
    for k, e in r.coefficients.items():
        assert e.value == pytest.approx(TRUTH[k], rel=1e-10, abs=1e-8), k
    assert r.coefficients["M_xy"].unit == "urad" and r.coefficients["B_x"].unit == "mg"


def test_calibration_inverts_the_simulated_triad():
    plan = make_plan("12")
    data = inertest.simulate(plan, TRUTH)
    r = inertest.fit(plan, data, sigma=1.0)
    raw = np.column_stack([data[c] for c in tm.OUTPUT_COLUMNS])
    f = mp.attitudes(data["position"])[:, 2, :] * plan.site.gravity_m_s2  # C^T (0, 0, g)
    cal = TriadCalibration.from_dict(r.to_dict()["result"]["calibration"]["accelerometer"])
    np.testing.assert_allclose(cal.apply(raw), f, atol=1e-9)


def test_physical_output_unit_gives_ppm_against_nominal_one():
    truth = {"K_x": 1.0002, "K_y": 0.9995, "K_z": 1.0, "M_yz": 100.0, "B_z": 2.0}
    plan = make_plan("6", unit="g")
    r = inertest.fit(plan, inertest.simulate(plan, truth), sigma=1e-6)
    ppm = r.triads[0].scale_ppm
    assert ppm["K_x"].value == pytest.approx(200.0, abs=1e-6)
    assert ppm["K_y"].value == pytest.approx(-500.0, abs=1e-6)
    cal = r.calibration.accelerometer
    # calibrated [m/s^2] = matrix @ (raw [g] - offset [g])
    raw_up_z = np.array([0.0, 0.9995 * 100e-6, 1.0]) * plan.site.gravity_g
    raw_up_z = raw_up_z + np.array([0.0, 0.9995 * 100e-6 * 2e-3, 2e-3])
    np.testing.assert_allclose(cal.apply(raw_up_z)[0], [0, 0, plan.site.gravity_m_s2], atol=1e-9)


def test_six_position_closed_form_equals_least_squares_and_textbook_formula():
    plan = make_plan("6", spp=4)
    data = inertest.simulate(plan, TRUTH, noise=3.0, rng=7)
    r = inertest.fit(plan, data)
    g = plan.site.gravity_m_s2
    cf = r.six_position
    raw = np.column_stack([data[c] for c in tm.OUTPUT_COLUMNS])
    up = raw[data["position"] == "UEN"].mean(axis=0)
    down = raw[data["position"] == "DWN"].mean(axis=0)
    # textbook: column x of S = (f_up - f_down) / (2 g)
    np.testing.assert_allclose(np.array(cf["S"])[:, 0], (up - down) / (2 * g), rtol=1e-12)
    S_ls = r.calibration.accelerometer.forward
    np.testing.assert_allclose(np.array(cf["S"]), S_ls, rtol=1e-10)
    np.testing.assert_allclose(cf["bias"], r.calibration.accelerometer.offset, rtol=1e-10)


def test_noise_free_bias_and_scale_by_hand():
    truth = {"K_x": 1000.0, "K_y": 2000.0, "K_z": 500.0, "B_x": 1.0, "B_y": -2.0, "B_z": 3.0}
    plan = make_plan("6")
    r = inertest.fit(plan, inertest.simulate(plan, truth), sigma=1.0)
    g, mg = plan.site.gravity_m_s2, 9.80665e-3
    # f_up = K (g + B), f_down = K (-g + B): bias = K B, scale = (f_up - f_down) / (2 g)
    np.testing.assert_allclose(r.six_position["bias"], [1000 * mg, 2000 * -2 * mg, 500 * 3 * mg],
                               rtol=1e-12)
    np.testing.assert_allclose(np.diag(r.six_position["S"]), [1000, 2000, 500], rtol=1e-12)
    assert g > 9.79


def test_axis_never_excited_names_the_lost_coefficients_and_the_fix():
    plan = make_plan(["UEN", "DWN", "NUE", "SDE"])
    with pytest.raises(IdentifiabilityError, match=r"K_z and the misalignments.*no position puts "
                       r"specific force along z.*ENU and WND"):
        inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1.0)


def test_axis_only_up_cannot_separate_scale_from_bias():
    # z tilted 45 deg from up in every position: f_z = g/sqrt(2) always, so z's column of S
    # acts like a bias
    plan = make_plan(["ENU/x+45", "ENU/x-45", "ENU/y+45", "ENU/y-45"], spp=2)
    with pytest.raises(IdentifiabilityError, match=r"K_z .*cannot be separated from the biases"
                       r".*ENU and WND"):
        inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1.0)


def test_duplicate_positions_only():
    plan = make_plan(["UEN"], spp=10)
    with pytest.raises(IdentifiabilityError, match=r"1 distinct position\(s\) \(UEN\)"):
        inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=1.0, rng=1))


def test_too_few_readings_for_the_noise():
    plan = make_plan(["UEN/z+45", "NUE/x+45", "ENU/y+45", "DWN/z-45"])
    data = inertest.simulate(plan, TRUTH)
    with pytest.raises(IdentifiabilityError, match="no degree of freedom"):
        inertest.fit(plan, data)
    r = inertest.fit(plan, data, sigma=1.0)  # four well-chosen positions suffice with a known noise
    assert r.coefficients["K_z"].value == pytest.approx(TRUTH["K_z"], rel=1e-10)


def test_swapped_output_columns_are_reported_as_mislabelled():
    plan = make_plan("12")
    data = inertest.simulate(plan, TRUTH, noise=1.0, rng=3)
    data["output_x"], data["output_y"] = data["output_y"], data["output_x"]
    with pytest.raises(DataError, match="output_x responds mostly to specific force along y.*"
                       "swap output_x and output_y"):
        inertest.fit(plan, data)


def test_negated_output_is_reported_as_sign_flip():
    plan = make_plan("12")
    data = inertest.simulate(plan, TRUTH, noise=1.0, rng=3)
    data["output_z"] = -data["output_z"]
    with pytest.warns(InertestWarning, match="output_z: negative scale factor"):
        r = inertest.fit(plan, data)
    assert r.coefficients["K_z"].value == pytest.approx(-TRUTH["K_z"], rel=1e-3)
    assert any("output_z: negative scale factor" in m for m in r.messages)


def test_plan_errors():
    with pytest.raises(InputError, match='unknown multi-position scheme "8"'):
        make_plan("8")
    with pytest.raises(InputError, match="left-handed"):
        make_plan(["UNE"])
    with pytest.raises(PlanError, match='kind = "accelerometer-triad"'):
        inertest.simulate(make_plan(kind="gyro-triad"), TRUTH)
    with pytest.raises(PlanError, match="needs the scale factors K_x"):
        inertest.simulate(make_plan(), {"B_x": 1.0})
    with pytest.raises(PlanError, match="unknown name.*K1"):
        inertest.simulate(make_plan(), {**TRUTH, "K1": 1.0})
    plan = make_plan()
    data = inertest.simulate(plan, TRUTH)
    data["position"] = data["position"].astype("<U12")
    data["position"][0] = "UEX"
    with pytest.raises(DataError, match="column position"):
        inertest.fit(plan, data)


def test_json_has_calibration_block_and_engineering_units():
    plan = make_plan("12", spp=3, nominal=1670.7)
    # Seed 5: at seed 4 the pair check alarms (p = 0.00088), one of the 1 in 200 seeds it does.
    d = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=2.0, rng=5)).to_dict()
    acc = d["result"]["calibration"]["accelerometer"]
    assert np.shape(acc["matrix"]) == (3, 3) and len(acc["offset"]) == 3
    assert acc["unit"] == "m/s^2" and acc["raw_unit"] == "count"
    t = d["result"]["triads"]["accelerometer"]
    assert t["scale_factor_ppm"]["K_x"]["unit"] == "ppm"
    assert t["misalignment"]["M_xy"]["unit"] == "urad" and "misalignment_arcsec" not in t
    assert set(d["result"]["noise_per_axis"]) == {"output_x", "output_y", "output_z"}
    cov = d["result"]["triads"]["accelerometer"]["covariance"]
    i = cov["names"].index("M_xy")
    assert np.sqrt(cov["matrix"][i][i]) == pytest.approx(t["misalignment"]["M_xy"]["std"])


@pytest.mark.slow
def test_monte_carlo_reported_std_matches_scatter():
    plan = make_plan("12", spp=2, noise_model="white")
    rng = np.random.default_rng(11)
    names = ("K_x", "M_xy", "M_zx", "B_y", "B_z")
    est, std = [], []
    for _ in range(400):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertestWarning)  # model-check false alarms at 1e-3
            r = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=2.0, rng=rng))
        est.append([r.coefficients[n].value for n in names])
        std.append([r.coefficients[n].std for n in names])
    ratio = np.std(est, axis=0, ddof=1) / np.mean(std, axis=0)
    assert np.all(np.abs(ratio - 1) < 0.2), dict(zip(names, ratio, strict=True))
    z = (np.mean(est, axis=0) - [TRUTH[n] for n in names]) / (np.mean(std, axis=0) / 20)
    assert np.all(np.abs(z) < 4)


def test_convention_misalignment_scale_bias_by_hand():
    """Readings written by hand from raw = K (I + M) f + K B (numpy, not the model), with only
    M_xy = 300 urad (sensor x sees specific force along reference y) and a positive B_x: the fit
    reports M_xy = 300 urad, M_yx = 0, K in count/(m/s^2) and B_x = +2 mg."""
    plan = make_plan("12")
    labels = np.array(plan.procedure.positions)
    f = mp.attitudes(labels)[:, 2, :] * plan.site.gravity_m_s2  # m/s^2, fixture axes
    K = np.diag([1000.0, 1100.0, 900.0])  # count/(m/s^2)
    M = np.zeros((3, 3))
    M[0, 1] = 300e-6
    B = np.array([2.0, 0.0, 0.0]) * 9.80665e-3  # +2 mg on x
    raw = f @ (K @ (np.eye(3) + M)).T + K @ (np.eye(3) + M) @ B
    data = {"position": labels, **{c: raw[:, i] for i, c in enumerate(tm.OUTPUT_COLUMNS)}}
    r = inertest.fit(plan, data, sigma=1e-3)
    c = r.coefficients
    assert c["M_xy"].value == pytest.approx(300.0, abs=1e-6) and c["M_xy"].unit == "urad"
    assert abs(c["M_yx"].value) < 1e-6
    assert c["K_y"].value == pytest.approx(1100.0, rel=1e-12)
    assert c["K_y"].unit == "count/(m/s^2)"
    assert c["B_x"].value == pytest.approx(2.0, rel=1e-9) and c["B_x"].unit == "mg"


@pytest.mark.parametrize(("params", "msg"), [
    ({"nominal_scale_factor": True}, "nominal_scale_factor must be a number"),
    ({"nominal_scale_factor": -2.0}, "nominal_scale_factor must be positive"),
    ({"samples_per_position": 2.5}, "samples_per_position must be a whole number"),
    ({"positions": True}, 'positions must be "6", "12", "24" or a list'),
    ({"postions": "6"}, 'unknown key.*postions .*did you mean "positions"'),
])
def test_plan_fields_refuse_wrong_types_and_misspelt_keys(params, msg):
    with pytest.raises(PlanError, match=msg):
        tm.TriadMultipositionSpec.from_mapping(params)


# --- Monte Carlo under each noise model (issue 15) ---------------------------------------------
# Noise from tests/noise_generators.py (not the library): white; white + an offset per position
# visit as large as the sample noise (the fixture re-settles); white + a random walk that
# wanders ~3 sigma over the test; flicker (1/f) by FFT shaping of white noise (power 1/f from
# 1/(2n) up), scaled to the sample noise.


def mc_ratio(kind, noise_model, reps=120, seed=11, spp=6, s=2.0):
    """RMS reported std / scatter of the estimates over ``reps`` tests, per coefficient."""
    plan = make_plan("12", spp=spp, noise_model=noise_model)
    clean = inertest.simulate(plan, TRUTH)
    n = clean["output_x"].size
    rng = np.random.default_rng(seed)
    noise = np.stack([noise_for(kind, rng, reps, np.arange(n) // spp, s)
                      for _ in tm.OUTPUT_COLUMNS], axis=-1)
    vals, stds, used = [], [], set()
    for k in range(reps):
        data = dict(clean, **{c: clean[c] + noise[k, :, i]
                              for i, c in enumerate(tm.OUTPUT_COLUMNS)})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertestWarning)  # rare false alarms at alpha
            r = inertest.fit(plan, data)
        vals.append([e.value for e in r.coefficients.values()])
        stds.append([e.std for e in r.coefficients.values()])
        used.add(r.identification.noise_model)
    ratio = np.sqrt(np.mean(np.square(stds), axis=0)) / np.std(vals, axis=0, ddof=1)
    return dict(zip(r.coefficients, ratio, strict=True)), used


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["white", "position-offsets", "random-walk", "flicker"])
def test_monte_carlo_reported_std_matches_scatter_under_each_noise(kind):
    """12 positions x 6 readings, the noise model named in the plan: reported std / scatter
    within 0.8-1.25 for every coefficient, and the result names the model. (Before issue 15 the
    white-noise std gave 0.46-0.55 under position offsets, 0.10-0.78 under a random walk and
    0.35-0.65 under flicker; with the former AR(1)-sum flicker kernel the biases came out
    1.17-1.40 under flicker, with the band-limited 1/f kernel 0.98-1.16.)"""
    ratio, used = mc_ratio(kind, kind)
    assert used == {kind}
    for name, r in ratio.items():
        assert 0.8 < r < 1.25, (name, r)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["white", "position-offsets", "random-walk", "flicker"])
def test_monte_carlo_auto_noise_model_is_honest_under_each_noise(kind):
    """``noise_model = "auto"`` (issue 15): one model for the three axes, the smallest AIC
    summed over them, each axis's covariance plus the spread of its estimates under the models
    within 2 of that sum, with the summed AICs' Akaike weights: reported std / scatter within
    0.8-1.25. Before (each axis by AIC, then all refitted with the model picked most often,
    no spread): 0.74 (B_z) under a random walk; that refit plus each axis's own spread: up to
    1.40 (B) under position offsets."""
    ratio, _ = mc_ratio(kind, "auto")
    for name, r in ratio.items():
        assert 0.8 < r < 1.25, (name, r)


def test_noise_model_is_named_in_the_result_and_position_offsets_are_found():
    """Offsets per position visit 10x the reading noise: auto picks position-offsets and the
    std is sqrt(5 readings per position) = 2.2x the white least-squares one (offsets dominate:
    24 independent position means, not 120 readings);
    the JSON names the model and its components; the positions are the units of the checks."""
    plan = make_plan("24", spp=5)
    clean = inertest.simulate(plan, TRUTH)
    rng = np.random.default_rng(2)
    data = dict(clean)
    for c in tm.OUTPUT_COLUMNS:
        data[c] = clean[c] + rng.normal(0, 0.2, clean[c].size) + np.repeat(
            rng.normal(0, 2.0, 24), 5)
    auto = inertest.fit(plan, data)
    with pytest.warns(InertestWarning, match='"white" noise does not fit'):
        white = inertest.fit(plan, data, noise_model="white")
    assert auto.identification.noise_model == "position-offsets"
    assert white.identification.noise_model == "white"
    ratio = auto.coefficients["B_x"].std / white.coefficients["B_x"].std
    assert ratio == pytest.approx(np.sqrt(5), rel=0.15)
    d = auto.to_dict()
    noise = d["identification"]["noise"]
    assert noise["model"] == "position-offsets"
    assert max(noise["selection"]["weights"], key=noise["selection"]["weights"].get) == (
        "position-offsets")  # the axes' common weights (summed AICs)
    assert noise["components"]["position offset"] == pytest.approx(2.0, rel=0.4)
    checks = [c for c in d["checks"] if c["name"] == "noise model fit"]
    assert checks[0]["unit"] == "position" and checks[0]["n_units"] == 24
    assert list(tm.position_visits(["UEN", "UEN", "DWN", "UEN"])) == [
        "UEN", "UEN", "DWN", "UEN (2)"]
    with pytest.raises(PlanError, match="noise_model"):
        make_plan(noise_model="pink")
