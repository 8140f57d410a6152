"""Static-base INS error propagation (seed 002) against references nobody here wrote:
high-precision matrix exponentials (mpmath), textbook closed forms of the Schuler loop,
and the classical periods."""

import math

import mpmath
import numpy as np
import pytest

from inertest.errors import InputError
from inertest.ins.error_model import InsSite, input_matrix, system_matrix
from inertest.ins.propagation import (
    SOURCES,
    characteristic_periods,
    propagate,
    propagate_many,
    source_responses,
    transition,
)
from inertest.ins.scenario import InsScenario, seed_scenario

LAT = math.radians(39.0)
DEG_H = math.pi / 180 / 3600
RNG = np.random.default_rng(7)
X0 = np.array([0.1, -0.05, 2e-6, -3e-6, 1e-4, -8e-5, 1.5e-3])
U = np.array([1e-3, -7e-4, 0.1 * DEG_H, -0.07 * DEG_H, 0.05 * DEG_H])


def _mp_reference(site, t, x0, u, dps=40):
    """x(t) from a 40-digit expm of the augmented matrix (mpmath: independent of scipy)."""
    mpmath.mp.dps = dps
    aug = np.zeros((12, 12))
    aug[:7, :7] = system_matrix(site)
    aug[:7, 7:] = input_matrix()
    e = mpmath.expm(mpmath.matrix(aug.tolist()) * mpmath.mpf(t))
    z = e * mpmath.matrix([*x0.tolist(), *u.tolist()])
    return np.array([float(z[i]) for i in range(7)])


@pytest.mark.parametrize("coriolis", [True, False])
def test_propagate_matches_40_digit_expm_over_24h_at_1s(coriolis):
    site = InsSite(LAT, coriolis=coriolis)
    t = np.arange(0.0, 86400.0 + 1, 1.0)
    x = propagate(site, t, x0=X0, u=U)
    assert x.shape == (t.size, 7)
    for k in (1, 4999, 43210, 86400):
        ref = _mp_reference(site, t[k], X0, U)
        # relative to each state's size over the run (some cross terms pass through zero)
        scale = np.abs(x).max(axis=0)
        assert np.all(np.abs(x[k] - ref) <= 1e-12 * scale), (k, x[k] - ref)


def test_nonuniform_and_offset_grids_agree_with_uniform():
    site = InsSite(LAT)
    t = np.arange(0.0, 20000.0, 5.0)
    x = propagate(site, t, x0=X0, u=U)
    scale = np.abs(x).max(axis=0)
    idx = np.sort(RNG.choice(t.size, 300, replace=False))
    xn = propagate(site, t[idx], x0=X0, u=U)  # non-uniform
    assert np.all(np.abs(xn - x[idx]) <= 1e-11 * scale)
    xo = propagate(site, t[100:], x0=X0, u=U)  # t[0] > 0, from the state at t = 0
    assert np.all(np.abs(xo - x[100:]) <= 1e-11 * scale)
    x1 = propagate(site, [1234.0], x0=X0, u=U)
    assert np.all(np.abs(x1[0] - propagate(site, [0.0, 1234.0], x0=X0, u=U)[1]) <= 1e-12 * scale)


def test_transition_is_one_step_of_the_solution():
    site = InsSite(LAT)
    f, g = transition(site, 10.0)
    x = propagate(site, [0.0, 10.0, 20.0], x0=X0, u=U)
    np.testing.assert_allclose(f @ x[1] + g @ U, x[2], rtol=1e-12, atol=1e-18)


def test_zero_inputs_give_zero_and_defaults():
    site = InsSite(LAT)
    assert np.all(propagate(site, [0.0, 100.0]) == 0)


def test_superposition_of_sources():
    sc = InsScenario(site=InsSite(LAT), x0=X0, u=U, duration_s=6 * 3600, step_s=30)
    r = source_responses(sc)
    assert r.per_source.shape == (12, r.t.size, 7)
    assert r.sources == SOURCES and all(r.active)
    scale = np.abs(r.combined).max(axis=0)
    assert np.all(np.abs(r.per_source.sum(axis=0) - r.combined) <= 1e-12 * scale)
    # each column is one source alone
    np.testing.assert_allclose(
        r.per_source[SOURCES.index("eN")],
        propagate(sc.site, r.t, u=[0, 0, 0, U[3], 0]), rtol=0, atol=1e-15)


def test_schuler_loop_closed_forms_without_earth_rate():
    """With W = 0 the channels are textbook Schuler oscillators (Titterton & Weston 2004,
    sec. 12.3.2): bE -> dVE = bE sin(ws t)/ws, phiN = bE (1 - cos ws t)/g,
    dlambda = bE (1 - cos ws t)/(g cos L); an east gyro output error eE (entering phi' as
    -eE) -> phiE = -eE sin(ws t)/ws, dVN = -R eE (1 - cos ws t), dL = -eE (t - sin(ws t)/ws)."""
    site = InsSite(LAT, earth_rate_rad_s=0.0)
    g, r = site.gravity_m_s2, site.radius_m
    ws = math.sqrt(g / r)
    t = np.linspace(0, 30000, 601)
    be, ee = 2e-4 * 9.8, 0.02 * DEG_H
    x = propagate(site, t, u=[be, 0, 0, 0, 0])
    np.testing.assert_allclose(x[:, 0], be * np.sin(ws * t) / ws, rtol=0, atol=1e-12 * be / ws)
    np.testing.assert_allclose(x[:, 5], be * (1 - np.cos(ws * t)) / g, rtol=0, atol=1e-12 * be / g)
    np.testing.assert_allclose(x[:, 3], be * (1 - np.cos(ws * t)) / (g * math.cos(LAT)),
                               rtol=0, atol=1e-11 * be / g)
    x = propagate(site, t, u=[0, 0, ee, 0, 0])
    np.testing.assert_allclose(x[:, 4], -ee * np.sin(ws * t) / ws, rtol=0,
                               atol=1e-12 * ee / ws)
    np.testing.assert_allclose(x[:, 1], -r * ee * (1 - np.cos(ws * t)), rtol=0,
                               atol=1e-11 * r * ee)
    np.testing.assert_allclose(x[:, 2], -ee * (t - np.sin(ws * t) / ws), rtol=0,
                               atol=1e-10 * ee * t[-1])


def test_periods_lead_check_and_closed_forms_at_39_deg():
    site = InsSite(LAT)
    p = characteristic_periods(site)
    w, ws2 = site.earth_rate_rad_s, site.gravity_m_s2 / site.radius_m
    wf = w * math.sin(LAT)
    # the check given with the model: 81.41 / 87.66 min (Schuler -+ Foucault), 1436 min
    m = [x / 60 for x in p.modes_s]
    assert [round(v, 2) for v in m[:2]] == [81.41, 87.66]
    assert round(m[2]) == 1436
    # roots i(sqrt(ws^2 + wf^2) +- wf) of (s^2 + ws^2)^2 + 4 s^2 wf^2 (Titterton & Weston 12.3.4)
    assert p.foucault_s == pytest.approx(2 * math.pi / wf, rel=1e-9)
    assert p.schuler_s == pytest.approx(2 * math.pi / math.sqrt(ws2 + wf**2), rel=1e-9)
    assert p.schuler_s == pytest.approx(2 * math.pi * math.sqrt(site.radius_m /
                                                                site.gravity_m_s2), rel=2e-3)
    assert p.earth_s == pytest.approx(2 * math.pi / w, rel=1e-9)  # sidereal day
    assert p.earth_s == pytest.approx(86164.1, abs=0.01)
    assert 37.9 < p.foucault_s / 3600 < 38.1


def test_periods_without_coriolis_and_seed_value():
    p = characteristic_periods(InsSite(LAT, coriolis=False))
    assert p.foucault_s is None
    site = InsSite(LAT, coriolis=False)
    assert p.schuler_s == pytest.approx(2 * math.pi * math.sqrt(site.radius_m /
                                                                site.gravity_m_s2), rel=1e-9)
    # the source chose R so that the Schuler period is 84.4 min and W = 2 pi / 24 h
    ps = characteristic_periods(seed_scenario().site)
    assert ps.schuler_s == pytest.approx(84.4 * 60, rel=1e-9)
    assert ps.earth_s == pytest.approx(86400.0, rel=1e-9)


@pytest.mark.parametrize("lat_deg", [89.0, 95.0, -90.0, float("nan")])
def test_latitude_near_or_beyond_pole_rejected_only_at_90(lat_deg):
    if abs(lat_deg) < 90:
        assert characteristic_periods(InsSite(math.radians(lat_deg))).foucault_s > 0
    else:
        with pytest.raises(InputError, match="latitude"):
            InsSite(math.radians(lat_deg))


def test_bad_inputs():
    site = InsSite(LAT)
    with pytest.raises(InputError, match="x0"):
        propagate(site, [0, 1], x0=[1, 2, 3])
    with pytest.raises(InputError, match="times"):
        propagate(site, [0, float("nan")])
    with pytest.raises(InputError, match="times"):
        propagate(site, [])
    with pytest.raises(InputError, match="same m"):
        propagate_many(site, [0, 1], x0=np.zeros((2, 7)), u=np.zeros((3, 5)))
