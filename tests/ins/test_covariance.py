"""Covariance propagation of the random sources against closed forms and a Monte Carlo run."""

import math

import numpy as np
import pytest

from inertest.errors import InputError
from inertest.ins.covariance import RandomSources, propagate_covariance
from inertest.ins.error_model import InsSite
from inertest.ins.propagation import transition

LAT = math.radians(39.0)


def test_short_time_random_walk_laws():
    """Before the Schuler loop acts (t << 84 min): sigma_phi = N sqrt(t) for angle random walk,
    sigma_v = N sqrt(t) for velocity random walk, sigma_phi = K sqrt(t^3/3) for rate random walk
    (IEEE Std 952-1997 annex C)."""
    site = InsSite(LAT)
    t = np.arange(0.0, 11.0, 1.0)
    c = propagate_covariance(site, t, RandomSources(gyro_arw=1e-5))
    np.testing.assert_allclose(c.sigma[1:, 4:7], 1e-5 * np.sqrt(t[1:, None]) * np.ones(3),
                               rtol=1e-4)
    c = propagate_covariance(site, t, RandomSources(accel_vrw=2e-4))
    np.testing.assert_allclose(c.sigma[1:, :2], 2e-4 * np.sqrt(t[1:, None]) * np.ones(2),
                               rtol=1e-4)
    c = propagate_covariance(site, t, RandomSources(gyro_rrw=3e-8))
    np.testing.assert_allclose(c.sigma[1:, 4:7],
                               3e-8 * np.sqrt(t[1:, None] ** 3 / 3) * np.ones(3), rtol=1e-4)


def test_white_noise_driven_schuler_oscillator_closed_form():
    """W = 0: dVE' = -g phiN + w, phiN' = dVE/R, so dVE(t) = int cos(ws (t - s)) w(s) ds and
    var dVE = q/2 (t + sin(2 ws t)/(2 ws)), var phiN = q/(2 g R) (t - sin(2 ws t)/(2 ws))."""
    site = InsSite(LAT, earth_rate_rad_s=0.0)
    ws = math.sqrt(site.gravity_m_s2 / site.radius_m)
    n = 1e-3
    t = np.arange(0.0, 20000.0, 50.0)
    c = propagate_covariance(site, t, RandomSources(accel_vrw=(n, 0.0)))
    var_v = n**2 / 2 * (t + np.sin(2 * ws * t) / (2 * ws))
    var_phi = n**2 / (2 * site.gravity_m_s2 * site.radius_m) * (t - np.sin(2 * ws * t) / (2 * ws))
    np.testing.assert_allclose(c.sigma[:, 0] ** 2, var_v, rtol=1e-9, atol=1e-12 * var_v.max())
    np.testing.assert_allclose(c.sigma[:, 5] ** 2, var_phi, rtol=1e-8,
                               atol=1e-12 * var_phi.max())
    assert np.all(c.sigma[:, 1] == 0)  # the north channel gets no noise


def test_initial_covariance_propagates_like_the_state():
    site = InsSite(LAT)
    t = np.array([0.0, 600.0, 1200.0])
    p0 = np.diag([0.01, 0.01, 1e-12, 1e-12, 1e-8, 1e-8, 1e-6])
    c = propagate_covariance(site, t, RandomSources(), p0=p0)
    f, _ = transition(site, 1200.0)
    np.testing.assert_allclose(c.covariance[2, :7, :7], f @ p0 @ f.T, rtol=1e-9, atol=1e-22)


def test_bad_random_inputs():
    site = InsSite(LAT)
    with pytest.raises(InputError, match="gyro_arw"):
        propagate_covariance(site, [0.0, 1.0], RandomSources(gyro_arw=-1.0))
    with pytest.raises(InputError, match="uniform"):
        propagate_covariance(site, [0.0, 1.0, 3.0], RandomSources(gyro_arw=1.0))


@pytest.mark.slow
def test_monte_carlo_scatter_matches_one_sigma():
    """Independent simulation: noise held constant over each 10 s step (zero-order hold) and
    propagated with the deterministic transition; 2000 runs over 6 h."""
    site = InsSite(LAT)
    dt = 10.0
    t = np.arange(0.0, 6 * 3600 + 1, dt)
    src = RandomSources(gyro_arw=0.01 * math.pi / 180 / 60,
                        accel_vrw=1e-3, gyro_rrw=3e-3 * math.pi / 180 / 3600 / 60)
    sigma = propagate_covariance(site, t, src).sigma
    dens = src.densities()
    f, g = transition(site, dt)
    rng = np.random.default_rng(2026)
    runs = 2000
    x = np.zeros((7, runs))
    drift = np.zeros((3, runs))
    ratios = []
    for k in range(t.size - 1):
        u = rng.standard_normal((5, runs)) * dens[:5, None] / math.sqrt(dt)
        dw = rng.standard_normal((3, runs)) * dens[5:, None] * math.sqrt(dt)
        u[2:] += drift + 0.5 * dw  # mean drift over the step
        x = f @ x + g @ u
        drift += dw
        if (k + 1) % 540 == 0:
            ratios.append(x.std(axis=1) / sigma[k + 1])
    ratios = np.array(ratios)
    # sampling scatter of a std from 2000 runs is 1.6 %; 8 % is 5 sigma
    assert np.all(np.abs(ratios - 1) < 0.08), ratios
