import numpy as np
import pytest

import inertest
from inertest.earth import OMEGA_IE, Site
from inertest.errors import InertestWarning, InputError, PlanError
from inertest.plan import Instrument, Plan
from inertest.procedures import local_level_tumble as ll
from inertest.units import DEG_PER_H_TO_RAD_PER_S

TRUTH = dict(DF=1.2, DI=0.85, DO=-0.62, DS=0.31, DIO=0.12, DOS=-0.08, DSI=0.05, DII=0.04,
             DOO=-0.03, DSS=0.02)


def make_plan(positions=None, spp=1, lat=34.246):
    params = {"samples_per_position": spp}
    if positions is not None:
        params["positions"] = positions
    return Plan(Site.at(lat), Instrument(output_unit="deg/h"),
                ll.LocalLevelTumbleSpec.from_mapping(params))


def test_seed000_readings_written_out_with_earth_rate():
    # I up (UNW): reading = W sinL + DF + g DI + g^2 DII; I north (NUE): W cosL + DF + g DO + ...
    plan = make_plan(["UNW", "NUE"])
    d = inertest.simulate(plan, TRUTH)
    L, gm = plan.site.latitude_rad, plan.site.gravity_g
    w = OMEGA_IE / DEG_PER_H_TO_RAD_PER_S
    np.testing.assert_allclose(d["output"], [
        w * np.sin(L) + TRUTH["DF"] + gm * TRUTH["DI"] + gm**2 * TRUTH["DII"],
        w * np.cos(L) + TRUTH["DF"] + gm * TRUTH["DO"] + gm**2 * TRUTH["DOO"],
    ], rtol=1e-13)


def test_exact_recovery_and_what_cannot_be_found():
    plan = make_plan()
    res = inertest.fit(plan, inertest.simulate(plan, TRUTH), sigma=1e-3)
    assert set(res.coefficients) == {"DI", "DO", "DS"}
    for n, e in res.coefficients.items():
        assert e.value == pytest.approx(TRUTH[n], abs=1e-10)
    gm2 = plan.site.gravity_g ** 2
    got = {c.name: c for c in res.combinations}
    assert set(got) == {f"DF + {gm2:.6g}*{s}" for s in ("DII", "DOO", "DSS")}
    for c in res.combinations:
        assert c.unit == "deg/h" and c.value == pytest.approx(c.evaluate(TRUTH), abs=1e-10)
    text = " ".join(res.identification.not_separable)
    assert "DIO, DOS, DSI" in text and "two axes" in text


def test_unbalanced_plan_warns_and_left_handed_rejected():
    plan = make_plan(["UNW", "USE", "NUE", "NDW", "ENU", "ESD"])
    d = inertest.simulate(plan, TRUTH)
    with pytest.warns(InertestWarning, match="I axis is never both up and down"):
        res = inertest.fit(plan, d, sigma=1e-3)
    assert "DI" not in res.coefficients
    with pytest.raises(InputError, match="left-handed"):
        make_plan(["WNU"])
    bad = dict(d, S_dir=np.where(d["S_dir"] == "W", "E", d["S_dir"]))
    with pytest.raises(InputError, match="left-handed"):
        inertest.fit(plan, bad)


@pytest.mark.slow
def test_monte_carlo_reported_std_matches_scatter():
    plan = make_plan(spp=2)
    c = TRUTH
    rng = np.random.default_rng(11)
    vals, stds = [], []
    for _ in range(400):
        res = inertest.fit(plan, inertest.simulate(plan, c, noise=0.02, rng=rng))
        vals.append([e.value for e in res.coefficients.values()]
                    + [k.value for k in res.combinations])
        stds.append([e.std for e in res.coefficients.values()]
                    + [k.std for k in res.combinations])
    vals, stds = np.array(vals), np.array(stds)
    ratio = vals.std(axis=0, ddof=1) / np.sqrt(np.mean(stds**2, axis=0))
    assert np.all(np.abs(ratio - 1) < 0.2), ratio


@pytest.mark.parametrize(("params", "message"), [
    ({"samples_per_position": True}, "samples_per_position must be a whole number"),
    ({"samples_per_position": 0}, "samples_per_position must be positive"),
    ({"positon": ["UNW"]}, 'unknown key.*did you mean "positions"'),
    ({"noise_model": "flicer"}, 'did you mean "flicker"'),
    ({"positions": "UNW"}, "positions must be a non-empty list"),
    ({"positions": ["UN"]}, "must give three directions"),
    ({"positions": [[1, 2, 3]]}, "must give three directions"),
])
def test_plan_parameters_are_read_strictly(params, message):
    with pytest.raises(PlanError, match=message):
        ll.LocalLevelTumbleSpec.from_mapping({"kind": "local-level-tumble", **params})


def test_plan_defaults():
    spec = ll.LocalLevelTumbleSpec.from_mapping({"kind": "local-level-tumble"})
    assert len(spec.positions) == 24 and spec.samples_per_position == 1
    spec = ll.LocalLevelTumbleSpec.from_mapping({"positions": ["unw", ["D", "N", "E"]]})
    assert spec.positions == (("U", "N", "W"), ("D", "N", "E"))
