"""Stator rotation modulation (seed 001) against its closed forms."""

import numpy as np
import pytest

from inertest.errors import InputError
from inertest.studies import stator_modulation as sm

FS, F = 400.0, 2.0  # sample rate and stator frequency [Hz]
W = 2 * np.pi * F
T = np.arange(0, 10, 1 / FS)


def test_constant_drift_cancels_over_whole_periods():
    run = sm.run_modulation(T, [1e-3, -2e-3], [5e-5, -3e-5], stator_rate_rad_s=W,
                            sample_rate_hz=FS)
    # exact cancellation, to the rounding of the running sums (drift is 5e-5 rad/s)
    assert np.max(np.abs(run.residual_modulated)) < 1e-13
    np.testing.assert_allclose(run.residual_fixed, np.broadcast_to([5e-5, -3e-5], (
        run.t_out.size, 2)), rtol=1e-9)


def test_ramp_leaves_the_first_order_residual():
    slope = np.array([2e-7, -5e-7])
    run = sm.run_modulation(T, [0, 0], np.outer(T, slope), stator_rate_rad_s=W,
                            sample_rate_hz=FS)
    n = sm.samples_per_period(FS, W)
    for i in (0, 37, 150):
        t0 = T[i]
        expected = sm.ramp_residual(slope, W, window_start_s=t0)
        # the discrete window differs from the continuous integral by O(pi / n)
        np.testing.assert_allclose(run.residual_modulated[i], expected,
                                   atol=np.pi / n * np.linalg.norm(slope) / W * 1.5)
    assert np.linalg.norm(run.residual_modulated, axis=1).mean() == pytest.approx(
        np.linalg.norm(slope) / W, rel=2 * np.pi / n)


@pytest.mark.parametrize("nu", [0.0, 0.5, 1.7, F, 2.3, 3 * F])
def test_periodic_drift_gain_matches_the_two_shifted_lines(nu):
    A = 1e-5
    t = np.arange(0, 50, 1 / FS)
    eps = sm.drift_scenario(t, sine_amplitude=A, sine_hz=nu)
    run = sm.run_modulation(t, [0, 0], eps, stator_rate_rad_s=W, sample_rate_hz=FS)
    g_minus, g_plus = sm.drift_gain(nu, F)[0]
    # Peak residual magnitude is bounded by the two lines' sum and reaches at least their
    # difference; at nu = F the slow line is DC with amplitude A/2.
    peak = np.max(np.linalg.norm(run.residual_modulated, axis=1))
    assert peak <= A / 2 * (g_minus + g_plus) * (1 + 1e-2) + 1e-15
    assert peak >= A / 2 * abs(g_minus - g_plus) * (1 - 1e-2) - 1e-15
    if nu == F:
        assert peak == pytest.approx(A / 2, rel=1e-3)


def test_general_K_L_and_changing_house_rate():
    K = np.array([[1.02, 0.01], [-0.005, 0.97]])
    L = np.array([[0.9, 0.0], [0.02, 1.1]])
    f_h = 0.3
    house = np.column_stack([1e-3 * np.sin(2 * np.pi * f_h * T), np.full(T.size, 2e-3)])
    run = sm.run_modulation(T, house, [4e-5, 1e-5], stator_rate_rad_s=W, sample_rate_hz=FS,
                            K=K, L=L)
    # boxcar of one period: output = sinc(f T) * input at the window centre (closed form)
    win = 1 / F
    expected_x = 1e-3 * np.sinc(f_h * win) * np.sin(2 * np.pi * f_h * (run.t_out))
    np.testing.assert_allclose(run.estimate_modulated[:, 0], expected_x, atol=2e-6 * 1e-3 + 1e-9)
    np.testing.assert_allclose(run.estimate_modulated[:, 1], 2e-3, atol=1e-15)
    assert run.cost.delay_s == pytest.approx(win / 2)
    assert run.cost.bandwidth_hz == pytest.approx(0.4429464706894 / win)
    assert abs(np.sinc(sm.BOXCAR_3DB)) == pytest.approx(1 / np.sqrt(2), rel=1e-12)


@pytest.mark.slow
def test_monte_carlo_noise_after_the_filter():
    rng = np.random.default_rng(3)
    sigma = 1e-4
    n = sm.samples_per_period(FS, W)
    ests = []
    for _ in range(300):
        noise = rng.normal(0, sigma, size=(T.size, 2))
        u = sm.demodulate(T, sm.modulated_signal(T, [0, 0], [1e-5, 0], stator_rate_rad_s=W)
                          + noise, stator_rate_rad_s=W)
        ests.append(sm.integral_filter(u, samples_per_window=n, sliding=False)[3])
    assert np.std(ests, axis=0, ddof=1) == pytest.approx([sigma / np.sqrt(n)] * 2, rel=0.12)


def test_bad_input():
    with pytest.raises(InputError, match="non-zero stator rate"):
        sm.samples_per_period(FS, 0.0)
    with pytest.raises(InputError, match="whole number"):
        sm.samples_per_period(1000.0, 2 * np.pi * 3.0)
    with pytest.raises(InputError, match="shorter than one filter window"):
        sm.integral_filter(np.zeros((10, 2)), samples_per_window=200)
