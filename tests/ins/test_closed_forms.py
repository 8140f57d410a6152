"""Constant and secular parts (final value theorem) against the numerical solution, a literal
final-value limit in 60-digit arithmetic, and classical textbook steady states."""

import math

import mpmath
import numpy as np
import pytest
import sympy as sp

from inertest.ins.closed_forms import (
    L,
    W,
    closed_forms,
    fit_constant_and_secular,
    g,
)
from inertest.ins.error_model import STATES, InsSite, input_matrix, system_matrix
from inertest.ins.propagation import SOURCES, source_responses
from inertest.ins.scenario import InsScenario, seed_scenario

LAT = math.radians(39.0)
DEG_H = math.pi / 180 / 3600


def _balanced(site, x):
    """Velocities over sqrt(g R): every state then has the size of an angle."""
    d = np.ones(7)
    d[:2] = math.sqrt(site.gravity_m_s2 * site.radius_m)
    return x / d


@pytest.mark.parametrize("coriolis", [True, False])
def test_closed_forms_match_modal_fit_of_exact_solution(coriolis):
    seed = seed_scenario()
    sc = InsScenario(site=InsSite(LAT, coriolis=coriolis), x0=seed.x0, u=seed.u,
                     duration_s=48 * 3600, step_s=60)
    r = source_responses(sc)
    c0f, c1f = fit_constant_and_secular(sc.site, r.t, r.per_source)
    c0, c1 = closed_forms(coriolis=coriolis).evaluate(sc.site, np.r_[sc.u, sc.x0])
    for j in range(len(SOURCES)):
        scale = np.abs(_balanced(sc.site, r.per_source[j])).max()
        assert np.all(np.abs(_balanced(sc.site, c0f[j] - c0[j])) <= 1e-9 * scale), SOURCES[j]
        assert np.all(np.abs(_balanced(sc.site, c1f[j] - c1[j])) * sc.duration_s
                      <= 1e-9 * scale), SOURCES[j]


def _final_value(site, x0, u, state):
    """Literal limits: c1 = s^2 X(s), c0 = d/ds [s^2 X(s)] at s -> 0 (60 digits)."""
    mpmath.mp.dps = 60
    a = mpmath.matrix(system_matrix(site).tolist())
    b = mpmath.matrix(input_matrix().tolist()) * mpmath.matrix(list(u))
    x0m = mpmath.matrix(list(x0))

    def s2x(s):
        return (s**2 * mpmath.lu_solve(s * mpmath.eye(7) - a, x0m + b / s))[state]

    h = mpmath.mpf("1e-25")
    c1 = s2x(h)
    c0 = (s2x(2 * h) - s2x(h)) / h
    return float(c0), float(c1)


@pytest.mark.parametrize("coriolis", [True, False])
@pytest.mark.parametrize("source", ["bE", "bN", "eE", "eN", "eU", "phiU0", "dVE0"])
def test_closed_forms_equal_literal_final_value_limits(coriolis, source):
    site = InsSite(LAT, coriolis=coriolis)
    mags = np.zeros(12)
    j = SOURCES.index(source)
    mags[j] = [1e-3, 1e-3, DEG_H, DEG_H, DEG_H, 0.1, 0.1, 1e-6, 1e-6, 1e-4, 1e-4, 1e-3][j]
    c0, c1 = closed_forms(coriolis=coriolis).evaluate(site, mags)
    for i in range(7):
        r0, r1 = _final_value(site, mags[5:], mags[:5], i)
        # 1e-9 of the largest part; 1e-20 rad floor for the O(h) of the limit with h = 1e-25
        tol = 1e-9 * max(np.abs(_balanced(site, c0[j])).max(),
                         np.abs(_balanced(site, c1[j])).max() * 86400) + 1e-20
        bal = _balanced(site, np.eye(7)[i])[i]
        assert abs((c0[j, i] - r0) * bal) <= tol, (STATES[i], c0[j, i], r0)
        assert abs((c1[j, i] - r1) * bal) * 86400 <= tol, (STATES[i], c1[j, i], r1)


def test_textbook_steady_states():
    """Classical results of the static-base analysis (Britting, *Inertial Navigation Systems
    Analysis*, 1971, ch. 10; Titterton & Weston 2004, sec. 12.3), in the convention of
    Titterton & Weston (gyro error = output error, entering the attitude error equation as
    ``- C_b^n dw_ib^b``; errors computed - true): level errors cancel the accelerometer
    biases, the azimuth error settles where the east gyro drift balances the Earth-rate
    coupling (gyrocompassing, ``phiU = -eE / (W cos L)``), and the drift along the polar axis
    looks like a faster Earth, so the longitude error grows at ``+(eN cos L + eU sin L)``."""
    cf = closed_forms(coriolis=True)
    c = cf.constant
    s = cf.secular
    bE, bN, eE, eN, eU = sp.symbols("bE bN eE eN eU", real=True)
    assert sp.simplify(c[("bE", "phiN")] - bE / g) == 0
    assert sp.simplify(c[("bN", "phiE")] + bN / g) == 0
    assert sp.simplify(c[("eE", "phiU")] + eE / (W * sp.cos(L))) == 0
    assert sp.simplify(s[("eN", "dlambda")] - eN * sp.cos(L)) == 0
    assert sp.simplify(s[("eU", "dlambda")] - eU * sp.sin(L)) == 0
    # no other source makes any state grow without bound
    grow = {k for k, v in s.items() if v != 0}
    assert grow == {("eN", "dlambda"), ("eU", "dlambda")}
    # biases leave no velocity error
    assert c[("bE", "dVE")] == 0 and c[("bN", "dVN")] == 0
    # without the Coriolis terms: the north and up drifts shift the latitude by
    # (eU cos L - eN sin L) / W and the east drift the longitude by -eE tan L / W
    c0 = closed_forms(coriolis=False).constant
    assert sp.simplify(c0[("eN", "dL")] + eN * sp.sin(L) / W) == 0
    assert sp.simplify(c0[("eU", "dL")] - eU * sp.cos(L) / W) == 0
    assert sp.simplify(c0[("eE", "dlambda")] + eE * sp.tan(L) / W) == 0


def test_rows_print_only_non_zero_parts():
    rows = closed_forms(coriolis=False).rows()
    assert ("phiN", "bE", "bE/g", "0") in rows
    assert all(r[2] != "0" or r[3] != "0" for r in rows)
