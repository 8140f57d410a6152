"""Dividing-head multipoint test of a pendulous accelerometer (seed 000 ch. 3; IEEE 1293)."""

import dataclasses
import warnings

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import (
    DataError,
    IdentifiabilityError,
    InertestWarning,
    InputError,
    PlanError,
)
from inertest.plan import Instrument, Plan
from inertest.procedures import accelerometer_multipoint as amp

TRUTH = {"K1": 1.2345, "K0": 150.0, "K2": 12.0, "K3": -3.5, "KIP": 20.0, "KIO": -15.0,
         "KPO": 5.0, "KPP": 8.0, "KOO": -6.0, "dO": 45.0, "dP": -30.0}


def make_plan(mountings=("IA-PA", "IA-OA"), positions=24, spp=1, gravity=None,
              kind="accelerometer"):
    spec = amp.AccelerometerMultipointSpec.from_mapping(
        {"mountings": list(mountings), "positions": positions, "samples_per_position": spp})
    return Plan(Site.at(34.246, gravity), Instrument(kind=kind, output_unit="mA"), spec)


def test_exact_recovery_all_three_mountings():
    plan = make_plan(("IA-PA", "IA-OA", "PA-OA"))
    r = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1e-7)
    assert set(r.coefficients) == {"K1", "K3", "KIP", "KIO", "KPO", "dO", "dP"}
    for k, e in r.coefficients.items():
        assert e.value == pytest.approx(TRUTH[k], rel=1e-9, abs=1e-8), k
    assert r.coefficients["K1"].unit == "mA/g" and r.coefficients["dO"].unit == "urad"
    # the 1 g field: K0 and the three square terms only in 3 combinations
    assert len(r.combinations) == 3
    for c in r.combinations:
        assert set(c.terms) <= {"K0", "K2", "KPP", "KOO"}
        assert c.value == pytest.approx(c.evaluate(TRUTH), abs=1e-7)
    assert any("aI^2 + aP^2 + aO^2" in s for s in r.identification.not_separable)


@pytest.mark.parametrize("positions", [8, 24])  # 8 readings < 11 coefficients, and plenty
@pytest.mark.parametrize("mounting, missing", [
    ("IA-PA", {"KIO", "KOO", "KPO", "dP"}), ("IA-OA", {"KIP", "KPP", "KPO", "dO"})])
def test_what_one_mounting_cannot_separate(mounting, missing, positions):
    plan = make_plan((mounting,), positions=positions)
    r = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1e-7)
    assert not missing & set(r.coefficients)
    text = " ".join(r.identification.not_separable)
    for n in missing:
        assert f"{n}: not excited" in text
    other = "PP" if mounting == "IA-PA" else "OO"
    names = {c.name: c for c in r.combinations}
    # B0 and C2 of the IEEE closed form: K0 + g^2 (K2 + Kxx)/2 and K2 - Kxx only
    terms = set(r.combinations[0].terms) | set(r.combinations[1].terms)
    assert terms == {"K0", "K2", f"K{other}"}
    expected = TRUTH["K2"] - TRUTH[f"K{other}"]
    assert names[f"K2 - K{other}"].value == pytest.approx(expected, abs=1e-6)


def test_fourier_terms_match_the_ieee_harmonic_expansion():
    # cos^2 = (1 + cos 2t)/2, sin^2 = (1 - cos 2t)/2, cos^3 = (3 cos t + cos 3t)/4,
    # cos sin = sin 2t / 2
    plan = make_plan(("IA-PA",), positions=16)
    g = plan.site.gravity_g
    r = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1e-7)
    h = r.fourier["IA-PA"]["harmonics"]
    u, k1 = 1e-6, TRUTH["K1"]
    expected = {
        "B0": k1 * (TRUTH["K0"] + g**2 * (TRUTH["K2"] + TRUTH["KPP"]) / 2) * u,
        "C1": k1 * (g + 3 * g**3 * TRUTH["K3"] * u / 4), "S1": k1 * g * TRUTH["dO"] * u,
        "C2": k1 * g**2 * (TRUTH["K2"] - TRUTH["KPP"]) / 2 * u,
        "S2": k1 * g**2 * TRUTH["KIP"] / 2 * u, "C3": k1 * g**3 * TRUTH["K3"] / 4 * u, "S3": 0.0,
    }
    for k, v in expected.items():
        assert h[k] == pytest.approx(v, rel=1e-9, abs=1e-15), k


def test_least_squares_equals_fourier_closed_form_on_noisy_equally_spaced_data():
    plan = make_plan(("IA-PA", "IA-OA"), positions=24, spp=3)
    data = inertest.simulate(plan, TRUTH, noise=2e-6, rng=5)
    for m in ("IA-PA", "IA-OA"):
        sel = data["mounting"] == m
        one = make_plan((m,), positions=24, spp=3)
        r = inertest.fit(one, {k: v[sel] for k, v in data.items()})
        cf = r.fourier[m]["coefficients"]
        for k in cf:
            assert r.coefficients[k].value == pytest.approx(cf[k]["value"], rel=1e-9, abs=1e-9)
        other = "PP" if m == "IA-PA" else "OO"
        ls = {c.name: c.value for c in r.combinations}[f"K2 - K{other}"]
        assert ls == pytest.approx(
            r.fourier[m]["combinations"][f"K2 - K{other}"]["value"], abs=1e-9)


def test_k1_needs_ia_in_the_vertical_plane():
    plan = make_plan(("PA-OA",))
    with pytest.raises(IdentifiabilityError, match="K1 cannot be found.*add an IA-PA or IA-OA"):
        inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1e-7)


def test_too_few_positions_alias_k3_into_k1():
    plan = make_plan(("IA-PA",), positions=8)
    angle = np.arange(5) * 72.0  # five positions: cos 3t = cos 2t, so K3 mixes with K1 and K2
    out = amp.model.output(amp.head.specific_force("IA-PA", angle, plan.site.gravity_g), TRUTH)
    data = {"mounting": np.array(["IA-PA"] * 5), "angle_deg": angle, "output": out}
    with pytest.raises(IdentifiabilityError, match="K1 cannot be separated from K3.*at least 8"):
        inertest.fit(plan, data, sigma=1e-7)


def test_plan_and_data_errors():
    with pytest.raises(PlanError, match="positions must be an integer >= 8"):
        make_plan(positions=6)
    with pytest.raises(PlanError, match="unknown dividing-head mounting"):
        make_plan(("IA-XA",))
    with pytest.raises(PlanError, match='kind = "accelerometer"'):
        inertest.simulate(make_plan(kind="rate-gyro"), TRUTH)
    plan = make_plan()
    data = inertest.simulate(plan, TRUTH)
    data["mounting"] = data["mounting"].astype("<U8")
    data["mounting"][2] = "IA-XX"
    with pytest.raises(InputError, match="column mounting"):
        inertest.fit(plan, data)
    with pytest.raises(PlanError, match="truth.*K1"):
        inertest.simulate(plan, {"K0": 1.0})


@pytest.mark.parametrize(("params", "message"), [
    ({"positions": True}, "positions must be a whole number"),
    ({"positions": 12.0}, "positions must be a whole number"),
    ({"samples_per_position": False}, "samples_per_position must be a whole number"),
    ({"mountings": "IA-PA"}, "mountings must be a non-empty list"),
    ({"mountings": ["IA-PA", 3]}, "mountings must be text"),
    ({"mounting": ["IA-PA"]}, 'unknown key.*did you mean "mountings"'),
    ({"noise_model": "positon-offsets"}, 'did you mean "position-offsets"'),
])
def test_plan_parameters_are_read_strictly(params, message):
    with pytest.raises(PlanError, match=message):
        amp.AccelerometerMultipointSpec.from_mapping({"kind": amp.KIND, **params})


def test_plan_defaults_and_canonical_mountings():
    spec = amp.AccelerometerMultipointSpec.from_mapping({"kind": amp.KIND})
    assert spec.mountings == ("IA-PA", "IA-OA") and spec.positions == 24
    spec = amp.AccelerometerMultipointSpec.from_mapping({"mountings": [" pa-oa "]})
    assert spec.mountings == ("PA-OA",)


def test_inverted_output_sign_is_reported():
    plan = make_plan()
    data = inertest.simulate(plan, TRUTH, noise=1e-6, rng=1)
    data["output"] = -data["output"]
    with pytest.raises(DataError, match="IA is mounted reversed or the output sign is inverted"):
        inertest.fit(plan, data)


def test_unequal_spacing_warns_and_skips_fourier():
    plan = make_plan(("IA-PA",))
    data = inertest.simulate(plan, TRUTH, noise=1e-6, rng=1)
    keep = data["angle_deg"] != 15.0
    data = {k: v[keep] for k, v in data.items()}
    with pytest.warns(UserWarning, match="not 8\\+ positions equally spaced"):
        r = inertest.fit(plan, data)
    assert r.fourier == {}
    assert r.coefficients["K1"].value == pytest.approx(TRUTH["K1"], rel=1e-5)


@pytest.mark.slow
def test_monte_carlo_reported_std_matches_scatter():
    plan = make_plan(("IA-PA", "IA-OA"), positions=16)
    rng = np.random.default_rng(42)
    names = ("K1", "K3", "KIP", "dP")
    est, std, combo, combo_std = [], [], [], []
    for _ in range(400):
        with warnings.catch_warnings():  # the model checks' false alarms at alpha = 1e-3
            warnings.simplefilter("ignore", InertestWarning)
            r = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=3e-6, rng=rng))
        est.append([r.coefficients[n].value for n in names])
        std.append([r.coefficients[n].std for n in names])
        combo.append(r.combinations[0].value)
        combo_std.append(r.combinations[0].std)
    ratio = np.std(est, axis=0, ddof=1) / np.mean(std, axis=0)
    assert np.all(np.abs(ratio - 1) < 0.2), dict(zip(names, ratio, strict=True))
    assert abs(np.std(combo, ddof=1) / np.mean(combo_std) - 1) < 0.2
    bias = (np.mean(est, axis=0) - [TRUTH[n] for n in names]) / (np.mean(std, axis=0) / 20)
    assert np.all(np.abs(bias) < 4)


def test_result_json_layout():
    plan = make_plan()
    r = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=1e-6, rng=2))
    d = r.to_dict()
    assert d["kind"] == "accelerometer-multipoint"
    assert set(d["result"]["fourier"]) == {"IA-PA", "IA-OA"}
    ident = d["identification"]
    assert ident["coefficients"]["K1"]["unit"] == "mA/g" and "not_separable" in ident
    assert dataclasses.is_dataclass(r)
