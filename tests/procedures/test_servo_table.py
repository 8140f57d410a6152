"""Servo-table drift test: what the mountings identify (derived by hand), exact recovery, honest
std (Monte Carlo), long-term stability series, bad input."""

import dataclasses
import warnings

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import DataError, PlanError
from inertest.plan import Instrument, Plan
from inertest.procedures import servo_table as st

TRUTH = dict(DF=1.2, DI=0.85, DO=-0.62, DS=0.31, DIO=0.12, DOS=-0.08, DSI=0.05, DII=0.04,
             DOO=-0.03, DSS=0.02)
NAMES = ("DF", "DI", "DO", "DS", "DIO", "DOS", "DSI", "DII", "DOO", "DSS")


def _plan(lat=45.0, **params):
    return Plan(Site.at(lat), Instrument(kind="sdf-gyro", serial="T", output_unit="deg/h"),
                st.ServoTableSpec.from_mapping({"kind": "servo-table", **params}))


def _quiet_fit(plan, data, **kw):
    # Noise-free data: residuals are rounding, not white noise; the model checks say so.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return inertest.fit(plan, data, **kw)


def _vec(terms):
    return np.array([terms.get(n, 0.0) for n in NAMES])


def _same_span(rows_a, rows_b):
    a, b = np.array(rows_a, float), np.array(rows_b, float)
    ra = np.linalg.matrix_rank(a, tol=1e-6)
    return ra == np.linalg.matrix_rank(b, tol=1e-6) == np.linalg.matrix_rank(
        np.vstack([a, b]), tol=1e-6)


def test_seed000_polar_servo_I_plus_minus_identifies_by_hand():
    # By hand (module docstring of inertest.procedures.servo_table): with I along +-a the
    # harmonics are B0 = DF + s g sL DI + g^2 sL^2 DII + g^2 cL^2 (DOO + DSS)/2,
    # C1 = g cL (DO + s g sL DIO), S1 = -g cL (s DS + g sL DSI), S2 = -s g^2 cL^2 DOS/2,
    # C2 = g^2 cL^2 (DOO - DSS)/2: sums and differences over s give the seven below, and
    # the two combinations.
    plan = _plan(mountings=["I+H", "I-H"], duration_h=24.0, sample_interval_s=30.0)
    r = _quiet_fit(plan, inertest.simulate(plan, TRUTH))
    assert set(r.coefficients) == {"DI", "DO", "DS", "DIO", "DSI", "DOS"}
    for n, e in r.coefficients.items():
        assert e.value == pytest.approx(TRUTH[n], abs=1e-8)
    g, L = plan.site.gravity_g, np.radians(45.0)
    hand = [
        _vec({"DF": 1.0, "DII": g**2 * np.sin(L) ** 2, "DOO": g**2 * np.cos(L) ** 2 / 2,
              "DSS": g**2 * np.cos(L) ** 2 / 2}),
        _vec({"DOO": 1.0, "DSS": -1.0}),
    ]
    assert len(r.combinations) == 2
    assert _same_span([_vec(c.terms) for c in r.combinations], hand)
    for c in r.combinations:
        assert c.value == pytest.approx(_vec(c.terms) @ _vec(TRUTH), abs=1e-8)
    assert "DOO - DSS" in {c.name for c in r.combinations}
    assert any("fI = +-(g/g0) sinL" in s for s in r.identification.not_separable)


def test_seed000_polar_harmonics_and_curve_match_closed_form():
    plan = _plan(mountings=["I+E", "I-H"], duration_h=24.0, sample_interval_s=30.0)
    r = _quiet_fit(plan, inertest.simulate(plan, TRUTH))
    g, L = plan.site.gravity_g, np.radians(45.0)
    sL, cL = np.sin(L), np.cos(L)
    c = TRUTH
    # psi = theta + phi, phi = 90 deg for O to E at theta = 0 (a x H = E)
    for m, s, phi in (("I+E", 1, np.pi / 2), ("I-H", -1, 0.0)):
        th = np.linspace(0, 2 * np.pi, 13)
        psi = th + phi
        ref = (c["DF"] + s * g * sL * c["DI"] + g**2 * sL**2 * c["DII"]
               + g**2 * cL**2 * (c["DOO"] + c["DSS"]) / 2
               + g * cL * (c["DO"] + s * g * sL * c["DIO"]) * np.cos(psi)
               - g * cL * (s * c["DS"] + g * sL * c["DSI"]) * np.sin(psi)
               - s * g**2 * cL**2 * c["DOS"] / 2 * np.sin(2 * psi)
               + g**2 * cL**2 * (c["DOO"] - c["DSS"]) / 2 * np.cos(2 * psi))
        h = np.array([t.value for t in r.harmonics[m]])
        got = (h[0] + h[1] * np.sin(th) + h[2] * np.cos(th) + h[3] * np.sin(2 * th)
               + h[4] * np.cos(2 * th))
        assert np.allclose(got, ref, atol=1e-8)
        # block drift from the encoder angle lies on the curve (1e-4 deg/h: 10-min blocks)
        cur = r.curves[m]
        assert np.max(np.abs(cur.drift_deg_h - cur.fitted_deg_h)) < 1e-3


def test_vertical_table_identifies_DI_and_DF_plus_DII_only():
    # fI = s g, fO = fS = 0 at every angle: drift = DF + s g DI + g^2 DII.
    plan = _plan(table_axis="vertical", mountings=["I+N", "I-N"], duration_h=6.0,
                 sample_interval_s=30.0)
    r = _quiet_fit(plan, inertest.simulate(plan, TRUTH))
    g = plan.site.gravity_g
    assert set(r.coefficients) == {"DI"}
    assert r.coefficients["DI"].value == pytest.approx(TRUTH["DI"], abs=1e-8)
    assert len(r.combinations) == 1
    c = r.combinations[0]
    assert _same_span([_vec(c.terms)], [_vec({"DF": 1.0, "DII": g**2})])
    assert c.value == pytest.approx(TRUTH["DF"] + g**2 * TRUTH["DII"], abs=1e-8)
    assert any("fO = fS = 0" in s for s in r.identification.not_separable)


def test_one_sign_of_I_cannot_separate_DI_DIO_DSI():
    plan = _plan(mountings=["I+H"], duration_h=24.0, sample_interval_s=60.0)
    r = _quiet_fit(plan, inertest.simulate(plan, TRUTH))
    assert "DI" not in r.coefficients and "DIO" not in r.coefficients
    assert any("I reversed" in s for s in r.identification.not_separable)


def test_stability_series_of_white_encoder_noise():
    # Per-interval drift = -s (r_end - r_start)/T: its std is sqrt(2) sigma / T for white
    # encoder noise; no trend.
    plan = _plan(mountings=["I+H", "I-H"], duration_h=24.0, sample_interval_s=20.0,
                 encoder_noise_arcsec=2.0)
    expected = np.sqrt(2) * 2.0 / 3600.0          # arcsec/s = deg/h
    ms = []
    for seed in range(8):
        r = inertest.fit(plan, inertest.simulate(plan, TRUTH, rng=seed))
        for s in r.stability.values():
            assert s.drift_deg_h.size == 24
            assert abs(s.trend.value) < 4 * s.trend.std
            assert s.allan_tau_h[0] == pytest.approx(1.0)
            ms.append(np.mean(s.drift_deg_h**2))
    assert 0.85 < np.sqrt(np.mean(ms)) / expected < 1.15
    block = r.to_dict()["result"]
    assert set(block["stability"]) == {"I+H", "I-H"}
    assert block["stability"]["I+H"]["std"]["unit"] == "deg/h"


@pytest.mark.slow
def test_seed000_polar_day_monte_carlo_std_honest():
    # Done criterion of issue 17: day-long polar servo at 45 deg, 0.5 arcsec encoder noise.
    plan = _plan(mountings=["I+H", "I-H"], duration_h=24.0, sample_interval_s=20.0,
                 encoder_noise_arcsec=0.5)
    rng = np.random.default_rng(2017)
    z, scatter = {}, {}
    for _ in range(60):
        r = inertest.fit(plan, inertest.simulate(plan, TRUTH, rng=rng))
        items = {**{n: (e.value, e.std, TRUTH[n]) for n, e in r.coefficients.items()},
                 **{c.name: (c.value, c.std, _vec(c.terms) @ _vec(TRUTH))
                    for c in r.combinations}}
        for k, (v, s, t) in items.items():
            z.setdefault(k, []).append((v - t) / s)
            scatter.setdefault(k, []).append((v, s))
    assert len(z) == 8
    for k in z:
        v, s = np.array(scatter[k]).T
        assert 0.8 < np.std(v, ddof=1) / np.mean(s) < 1.25, k
        assert abs(np.mean(z[k])) < 4 / np.sqrt(len(z[k])), k


def test_bad_input_one_line_errors():
    plan = _plan(mountings=["I+H", "I-H"], duration_h=24.0, sample_interval_s=120.0)
    data = inertest.simulate(plan, {"DF": 1.0})
    errors = []
    with pytest.raises(PlanError, match="left-handed") as e:
        _plan(mountings=["I+HW"])
    errors.append(e)
    with pytest.raises(PlanError, match="input axis I along it") as e:
        _plan(mountings=["S+H"])
    errors.append(e)
    bad = dict(data, mounting=np.where(data["mounting"] == "I-H", "O-H", data["mounting"]))
    with pytest.raises(DataError, match="input axis I along it") as e:
        inertest.fit(plan, bad)
    errors.append(e)
    t = data["time_s"].copy()
    t[[5, 6]] = t[[6, 5]]
    with pytest.raises(DataError, match="does not increase at data row 7") as e:
        inertest.fit(plan, dict(data, time_s=t))
    errors.append(e)
    short = _plan(mountings=["I+H", "I-H"], duration_h=12.0, sample_interval_s=120.0)
    with pytest.raises(DataError, match="less than one table revolution") as e:
        inertest.simulate(short, {})
    errors.append(e)
    keep = data["time_s"] % 86520 < 12 * 3600
    with pytest.raises(DataError, match="less than one table revolution") as e:
        inertest.fit(plan, {k: v[keep] for k, v in data.items()})
    errors.append(e)
    with pytest.raises(PlanError, match="encoder_noise_arcsec") as e:
        _plan(encoder_noise_arcsec=-1.0)
    errors.append(e)
    with pytest.raises(PlanError, match='did you mean "duration_h"') as e:
        _plan(duration_hours=3.0)
    errors.append(e)
    assert all("\n" not in str(x.value) for x in errors)


def test_vertical_short_record_is_fine_and_spec_defaults():
    spec = st.ServoTableSpec.from_mapping({"kind": "servo-table", "table_axis": "vertical"})
    assert spec.mountings == ("I+N", "I-N")
    plan = _plan(table_axis="vertical", duration_h=2.0, sample_interval_s=60.0)
    assert dataclasses.asdict(plan.procedure)["duration_h"] == 2.0
    r = _quiet_fit(plan, inertest.simulate(plan, {"DF": 0.5}))
    assert r.combinations[0].value == pytest.approx(0.5, abs=1e-8)
