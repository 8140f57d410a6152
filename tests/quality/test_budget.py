"""Uncertainty budget: closed-form sensitivities derived by hand, Welch-Satterthwaite, and an
independent Monte Carlo of the equipment errors (GUM Supplement 1 style)."""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import inertest
from inertest.earth import Site
from inertest.errors import InertestWarning
from inertest.procedures import procedure
from inertest.quality.budget import Contribution, combine, uncertainty_budget
from inertest.quality.lab import Equipment, TypeB
from inertest.units import ARCSEC_TO_RAD, PPM_TO_RATIO

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TRUTH = {"DF": 1.2, "DI": 0.85, "DO": -0.62, "DS": 0.31, "DIO": 0.12, "DOS": -0.08,
         "DSI": 0.05, "DII": 0.04, "DOO": -0.03, "DSS": 0.02}


def _plan(**procedure):
    plan = inertest.load_plan(EXAMPLES / "polar_tumble" / "plan.toml")
    spec = dataclasses.replace(plan.procedure, noise_model="white", **procedure)
    return dataclasses.replace(plan, procedure=spec)


def _table(angle_arcsec=0.0, gravity_ppm=0.0, rate_ppm=0.0):
    items = [("angle_arcsec", "angle", angle_arcsec, "arcsec", angle_arcsec * ARCSEC_TO_RAD),
             ("gravity_ppm", "gravity", gravity_ppm, "ppm", gravity_ppm * PPM_TO_RATIO),
             ("rate_ppm", "rate", rate_ppm, "ppm", rate_ppm * PPM_TO_RATIO)]
    return Equipment(id="PT-01", type_b=tuple(TypeB(*t) for t in items if t[2]))


def test_polar_tumble_angle_and_gravity_sensitivity_closed_form():
    # O mountings only, drift DF + DI fI. An encoder zero error d turns every table angle:
    # fI = g cosL sin(theta + d), fS = g cosL cos(theta + d), so the drift
    # DI g cosL (sin theta cos d + cos theta sin d) has C1 = g cosL DI sin d and the fit
    # reads DS = DI sin d ~ DI d (sensitivity dDS/dd = DI per rad), DI cos d ~ DI.
    # A gravity error g(1 + e) read as g scales every fI: DI -> DI (1 + e), dDI/de = DI.
    plan = _plan(mountings=("O-Np", "O-Sp"))
    data = inertest.simulate(plan, {"DF": 1.2, "DI": 0.85}, noise=1e-4, rng=3)
    result = inertest.fit(plan, data)
    di = result.coefficients["DI"].value
    u_angle, u_g = 2.0, 10.0          # arcsec, ppm
    budget = uncertainty_budget(plan, result, [_table(angle_arcsec=u_angle,
                                                      gravity_ppm=u_g)])
    c = {x.source: x for x in budget.quantities["DS"].contributions}
    assert c["PT-01 angle_arcsec"].value == pytest.approx(di * u_angle * ARCSEC_TO_RAD,
                                                          rel=1e-4)
    assert c["PT-01 angle_arcsec"].sensitivity == pytest.approx(di * ARCSEC_TO_RAD, rel=1e-4)
    c = {x.source: x for x in budget.quantities["DI"].contributions}
    assert c["PT-01 gravity_ppm"].value == pytest.approx(di * u_g * PPM_TO_RATIO, rel=1e-4)
    # with the fitted DS (noise) also present: DI -> DI cos d - DS sin d, whose second-order
    # part DI (cos d - 1) is as large as the first here (DS ~ 1e-4 deg/h/g)
    ds, d = result.coefficients["DS"].value, u_angle * ARCSEC_TO_RAD
    assert c["PT-01 angle_arcsec"].value == pytest.approx(
        di * (math.cos(d) - 1) - ds * math.sin(d), rel=1e-3, abs=1e-14)


def test_inapplicable_key_listed_and_gravity_default():
    plan = _plan()
    result = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=0.002, rng=1))
    budget = uncertainty_budget(plan, result, [_table(angle_arcsec=2.0, rate_ppm=5.0)])
    assert any(s.startswith("PT-01 rate_ppm: not applicable") for s in budget.not_applicable)
    assert "PT-01 rate_ppm" not in budget.sources
    # the example plan gives no gravity: normal gravity with its assumed uncertainty
    assert "site gravity" in budget.sources
    d = budget.to_dict()
    assert set(d["quantities"]) == set(result.coefficients) | {
        c.name for c in result.combinations}


def test_welch_satterthwaite_coverage_factor_gum_table_g2():
    # u_A = 1 with 2 dof and one Type-B part with u_B^2 = sqrt(5) - 1: u_c^4 = 5, so
    # nu_eff = u_c^4 / (u_A^4 / 2) = 10, and GUM table G.2 gives t_95.45(10) = 2.28.
    ub = math.sqrt(math.sqrt(5.0) - 1.0)
    q = combine("x", 0.0, "deg/h", 1.0, 2, [Contribution("s", ub, "deg/h", 1.0, ub)])
    assert q.combined == pytest.approx(5.0**0.25)
    assert q.effective_dof == pytest.approx(10.0)
    assert q.coverage_factor == pytest.approx(2.28, abs=0.005)
    assert q.expanded == pytest.approx(q.coverage_factor * q.combined)
    # no Type A: infinite dof, k = 2 (GUM G.6.6)
    q = combine("x", 0.0, "deg/h", 0.0, 0, [Contribution("s", 1.0, "deg/h", 1.0, 1.0)])
    assert q.coverage_factor == pytest.approx(2.0, abs=0.001)


@pytest.mark.slow
def test_budget_combined_std_matches_monte_carlo_of_equipment_errors():
    # Draw the encoder zero error and the gravity error, simulate the test on the perturbed
    # machine with noise, fit with the nominal plan: the scatter of the estimates is the
    # combined standard uncertainty (Type A and B) the budget predicts.
    plan = _plan()
    noise = 0.002
    u_angle, u_g = 400.0, 2000.0      # arcsec, ppm: Type B of the order of Type A
    result = inertest.fit(plan, inertest.simulate(plan, TRUTH, noise=noise, rng=1),
                          sigma=noise)
    budget = uncertainty_budget(plan, result, [_table(angle_arcsec=u_angle, gravity_ppm=u_g)])
    rng = np.random.default_rng(20)
    names = ("DI", "DS", "DO")
    draws = []
    for _ in range(300):
        d_angle = rng.normal(0.0, u_angle * ARCSEC_TO_RAD)
        e_g = rng.normal(0.0, u_g * PPM_TO_RATIO)
        site = Site(latitude_rad=plan.site.latitude_rad,
                    gravity_m_s2=plan.site.gravity_m_s2 * (1 + e_g))
        perturbed = dataclasses.replace(plan, site=site)
        proc = procedure(plan.kind)
        data = proc.simulate(perturbed, TRUTH, noise=noise, rng=rng,
                             motion=proc.motion(perturbed, type_b={"angle": d_angle}))
        with warnings.catch_warnings():     # the model checks' false alarms over 300 draws
            warnings.simplefilter("ignore", InertestWarning)
            fitted = inertest.fit(plan, data, sigma=noise)
        draws.append([fitted.coefficients[n].value for n in names])
    scatter = np.std(np.asarray(draws), axis=0, ddof=1)
    for name, s in zip(names, scatter, strict=True):
        q = budget.quantities[name]
        assert q.type_b > 0.3 * q.type_a          # the test exercises Type B
        assert 0.8 < s / q.combined < 1.25, (name, s, q.combined)


#: Earth rate W [deg/h]: 7.2921151467e-5 rad/s x (180/pi) x 3600.
W_DEG_H = 7.2921151467e-5 * 180.0 / math.pi * 3600.0


def test_polar_table_squareness_and_east_west_tilt_sensitivity_closed_form():
    # O-Np + O-Sp, a zero instrument: a tilt e of the table axis towards east puts the input
    # axis out of the equatorial plane, I . p = -e (E . I), so I senses -W e (E . I). With the
    # seed's convention (O-Np: I = E cos(theta) + ..., O-Sp: I = -E cos(theta) + ...) that is
    # a C1 of -W e (O-Np) and +W e (O-Sp) for a tilt common to both mountings, and -W e in
    # both for a squareness error (the tilt reverses with the flip for Sp). With
    # C1 = g cosL (DS +- g sinL DOS) (upper sign Np; g = g/g0 here):
    #   squareness: DS = (C1N + C1S) / (2 g cosL) = -W e / (g cosL), DOS unchanged;
    #   east-west:  DOS = (C1N - C1S) / (2 g^2 sinL cosL) = -W e / (g^2 sinL cosL), DS unchanged;
    # and a meridian tilt (about east) gives S1 = -W e in both: DI = -W e / (g cosL).
    plan = _plan(mountings=("O-Np", "O-Sp"))
    result = inertest.fit(plan, inertest.simulate(plan, {}, noise=1e-9, rng=3))
    e = 20.0   # urad
    table = Equipment(id="PT-01", type_b=(
        TypeB("tilt_urad", "tilt", e, "urad", e * 1e-6),
        TypeB("squareness_urad", "squareness", e, "urad", e * 1e-6)))
    budget = uncertainty_budget(plan, result, [table])
    g, lat = plan.site.gravity_m_s2 / 9.80665, plan.site.latitude_rad
    c = {n: {x.source: x.value for x in budget.quantities[n].contributions}
         for n in ("DI", "DS", "DOS")}
    w_e = W_DEG_H * e * 1e-6
    assert c["DS"]["PT-01 squareness_urad"] == pytest.approx(-w_e / (g * math.cos(lat)),
                                                             rel=1e-6)
    assert c["DOS"]["PT-01 squareness_urad"] == pytest.approx(0.0, abs=1e-12)
    assert c["DOS"]["PT-01 tilt_urad (east-west)"] == pytest.approx(
        -w_e / (g**2 * math.sin(lat) * math.cos(lat)), rel=1e-6)
    assert c["DS"]["PT-01 tilt_urad (east-west)"] == pytest.approx(0.0, abs=1e-12)
    assert c["DI"]["PT-01 tilt_urad (meridian)"] == pytest.approx(-w_e / (g * math.cos(lat)),
                                                                  rel=1e-6)
    # the same u in each tilt direction, each its own source
    assert {"PT-01 tilt_urad (meridian)", "PT-01 tilt_urad (east-west)",
            "PT-01 squareness_urad"} <= set(budget.sources)


def test_known_sigma_has_infinite_type_a_dof_and_k_2():
    # GUM G.4.1 / table G.1: a given (known) noise std has no degrees of freedom to count:
    # nu_eff = inf and k = 2 for p = 95.45 %. Estimated from 320 - 9 = 311 residual dof it is
    # t_95.45(311) > 2.
    plan = _plan()
    data = inertest.simulate(plan, TRUTH, noise=0.002, rng=1)
    known = uncertainty_budget(plan, inertest.fit(plan, data, sigma=0.002)).quantities["DI"]
    assert math.isinf(known.type_a_dof) and math.isinf(known.effective_dof)
    assert known.coverage_factor == 2.0
    assert known.to_dict()["type_a"]["dof"] is None
    est = uncertainty_budget(plan, inertest.fit(plan, data)).quantities["DI"]
    assert est.type_a_dof == 16 * 4 * 5 - 9 and est.coverage_factor > 2.0
