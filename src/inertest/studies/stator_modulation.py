"""Stator rotation modulation of a suspended (2-DOF) gyro: modulate, demodulate, integrate.

Seed ``001_844b96197456cfeb.txt`` (patent: stator rotation modulation error compensation of
suspended gyros). The bearing stator of an electrostatic, magnetic, liquid- or gas-floated gyro
rotates at rate ``W`` about the rotor's angular-momentum axis z relative to the gyro house g. In
the rotating stator frame s the two-axis signal is (seed eq. (1))::

    f(e, h) = K w_is^s + L eps,        w_is^s(xy) = R(W t)^T w_ig^g(xy)

with ``K`` the 2x2 scale matrix, ``L`` the drift-to-torque matrix and ``eps`` the drift fixed to
the stator. Demodulating by the rotation ``R(W t) = [[cos, -sin], [sin, cos]]`` into the house
frame (seed eq. (2), with ``K^-1`` applied first so that any K works)::

    u = R(W t) K^-1 f = w_ig^g + R(W t) K^-1 L eps

leaves the house rate unchanged and turns a stator-fixed drift into a sinusoid at ``W``; the
integral filter over whole periods ``T = 2 pi / W`` (seed step (3)) then cancels it. Units: SI
(rad/s, s); ``K`` and ``L`` convert rad/s to signal units.

Closed forms used by the tests
------------------------------
* over whole periods the mean of ``R(W t)`` is zero, so constant drift cancels exactly;
* a drift ramp ``eps0 + eps1 t`` leaves ``R(W t0) J eps1 / W`` over the window starting at t0,
  with ``J = [[0, 1], [-1, 0]]``: magnitude ``|eps1| / W`` whatever the window phase;
* a drift component at frequency ``nu`` (stator frame) reaches the output with the gains
  ``sinc((nu -+ F) m T)`` of the two shifted lines (``F = W / 2 pi``, ``m`` periods per window),
  so drift near ``W`` is *not* cancelled (it is shifted to near DC);
* the boxcar integral filter of length ``m T`` delays by ``m T / 2`` and has its -3 dB point at
  ``0.4429 / (m T)`` Hz (|sinc| = 1/sqrt(2)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.results import envelope
from inertest.units import DEG_PER_H_TO_RAD_PER_S

#: x with |sin(pi x) / (pi x)| = 1/sqrt(2): the -3 dB point of a boxcar, in units of 1/length.
BOXCAR_3DB = 0.442946470689452


def stator_rotation(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrices ``R(a) = [[cos a, -sin a], [sin a, cos a]]``, shape (n, 2, 2)."""
    a = np.atleast_1d(np.asarray(angle_rad, dtype=float))
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _matrix(m: ArrayLike | None, name: str) -> NDArray[np.float64]:
    if m is None:
        return np.eye(2)
    a = np.asarray(m, dtype=float)
    if a.ndim == 0:
        a = a * np.eye(2)
    if a.shape != (2, 2) or not np.all(np.isfinite(a)) or abs(np.linalg.det(a)) < 1e-300:
        raise InputError(f"{name} must be a finite, invertible scalar or 2x2 matrix")
    return a


def _series(t_s: ArrayLike, x: ArrayLike, name: str) -> tuple[NDArray, NDArray]:
    t = np.asarray(t_s, dtype=float)
    v = np.broadcast_to(np.asarray(x, dtype=float), (t.size, 2))
    if t.ndim != 1 or not np.all(np.isfinite(t)) or not np.all(np.isfinite(v)):
        raise InputError(f"time and {name} must be finite, with {name} of shape (n, 2)")
    return t, v


def modulated_signal(
    t_s: ArrayLike,
    house_rate: ArrayLike,
    drift_stator: ArrayLike,
    *,
    stator_rate_rad_s: float,
    K: ArrayLike | None = None,
    L: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Signal in the rotating stator frame, ``f = K R(W t)^T w_ig^g + L eps`` (seed eq. (1)).

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Time [s].
    house_rate : array_like, shape (n, 2) or (2,)
        House rate about its X, Y axes relative to inertial space [rad/s].
    drift_stator : array_like, shape (n, 2) or (2,)
        Drift fixed to the stator, x and y [rad/s].
    stator_rate_rad_s : float
        Stator rotation rate W [rad/s] (0: no modulation).
    K, L : scalar or 2x2, optional
        Scale and drift-to-torque matrices (identity by default).
    """
    t, w = _series(t_s, house_rate, "house_rate")
    _, eps = _series(t, drift_stator, "drift_stator")
    R = stator_rotation(stator_rate_rad_s * t)
    w_s = np.einsum("nji,nj->ni", R, w)  # R^T w
    return w_s @ _matrix(K, "K").T + eps @ _matrix(L, "L").T


def demodulate(
    t_s: ArrayLike, signal: ArrayLike, *, stator_rate_rad_s: float, K: ArrayLike | None = None
) -> NDArray[np.float64]:
    """House-frame rate ``u = R(W t) K^-1 f`` [rad/s] from the stator signal (seed eq. (2))."""
    t, f = _series(t_s, signal, "signal")
    g = f @ np.linalg.inv(_matrix(K, "K")).T
    return np.einsum("nij,nj->ni", stator_rotation(stator_rate_rad_s * t), g)


def samples_per_period(sample_rate_hz: float, stator_rate_rad_s: float) -> int:
    """Samples in one stator period; an error unless it is a whole number (>= 3)."""
    if not np.isfinite(stator_rate_rad_s) or stator_rate_rad_s == 0:
        raise InputError("modulation needs a non-zero stator rate W")
    if not np.isfinite(sample_rate_hz) or sample_rate_hz <= 0:
        raise InputError(f"sample rate must be positive, got {sample_rate_hz}")
    n = sample_rate_hz * 2 * np.pi / abs(stator_rate_rad_s)
    k = int(round(n))
    if abs(n - k) > 1e-6 * n or k < 3:
        raise InputError(
            f"one stator period holds {n:.6g} samples; the integral filter needs a whole number "
            f"(>= 3): choose the sample rate as a multiple of the stator frequency "
            f"{abs(stator_rate_rad_s) / (2 * np.pi):.6g} Hz"
        )
    return k


def integral_filter(
    u: ArrayLike, *, samples_per_window: int, sliding: bool = True
) -> NDArray[np.float64]:
    """Mean over windows of whole periods (seed step (3)).

    Parameters
    ----------
    u : array_like, shape (n, 2)
        Demodulated rate.
    samples_per_window : int
        Samples in the window (whole stator periods).
    sliding : bool
        True: a moving mean, one output per sample from the first full window on (shape
        (n - N + 1, 2)), delayed by half a window. False: consecutive windows (shape (n // N, 2)).
    """
    x = np.asarray(u, dtype=float)
    N = int(samples_per_window)
    if N < 1 or x.shape[0] < N:
        raise InputError(
            f"the record ({x.shape[0]} samples) is shorter than one filter window ({N} samples, "
            "whole stator periods); record longer or use fewer periods per window"
        )
    if not sliding:
        m = x.shape[0] // N
        return x[: m * N].reshape(m, N, -1).mean(axis=1)
    c = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x]), axis=0)
    return (c[N:] - c[:-N]) / N


def drift_gain(freq_hz: ArrayLike, stator_hz: float, periods: int = 1) -> NDArray[np.float64]:
    """Gains of the two lines a stator-frame drift at ``freq_hz`` becomes after demodulation.

    Returns shape (n, 2): ``|sinc((nu - F) m T)|`` and ``|sinc((nu + F) m T)|`` with
    ``F = stator_hz``, ``T = 1/F``; each line carries half the drift amplitude. With
    ``stator_hz = 0`` (no modulation) the drift passes through the same boxcar at ``nu``.
    """
    nu = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if stator_hz == 0:
        g = np.abs(np.sinc(nu * periods))
        return np.column_stack([g, g])
    T = periods / abs(stator_hz)
    return np.column_stack([np.abs(np.sinc((nu - stator_hz) * T)),
                            np.abs(np.sinc((nu + stator_hz) * T))])


def ramp_residual(slope: ArrayLike, stator_rate_rad_s: float, window_start_s: float = 0.0):
    """Closed-form residual of a drift ramp ``eps1 t`` after one whole period [rad/s].

    ``R(W t0) J eps1 / W`` with ``J = [[0, 1], [-1, 0]]`` (see the module notes).
    """
    e1 = np.asarray(slope, dtype=float)
    J = np.array([[0.0, 1.0], [-1.0, 0.0]])
    R0 = stator_rotation(stator_rate_rad_s * window_start_s)[0]
    return R0 @ J @ e1 / stator_rate_rad_s


@dataclass(frozen=True)
class FilterCost:
    """What the integral filter costs: delay [s] and -3 dB bandwidth [Hz] of the rate output."""

    window_s: float
    delay_s: float
    bandwidth_hz: float


def filter_cost(stator_rate_rad_s: float, periods: int = 1) -> FilterCost:
    """Delay ``m T / 2`` and bandwidth ``0.4429 / (m T)`` of an m-period boxcar."""
    if stator_rate_rad_s == 0 or periods < 1:
        raise InputError("filter cost needs a non-zero stator rate and periods >= 1")
    window = periods * 2 * np.pi / abs(stator_rate_rad_s)
    return FilterCost(window, window / 2, BOXCAR_3DB / window)


@dataclass(frozen=True)
class ModulationRun:
    """One simulated record, processed with and without stator rotation.

    Rates are [rad/s]; ``t_out`` are the centres of the sliding windows, where the filtered
    estimates are compared with the true house rate averaged over the same window.
    """

    stator_rate_rad_s: float
    t_out: NDArray[np.float64]
    true_rate: NDArray[np.float64]
    estimate_modulated: NDArray[np.float64]
    estimate_fixed: NDArray[np.float64]
    cost: FilterCost

    @property
    def residual_modulated(self) -> NDArray[np.float64]:
        """Estimate minus true (window-averaged) rate, with modulation, shape (m, 2)."""
        return self.estimate_modulated - self.true_rate

    @property
    def residual_fixed(self) -> NDArray[np.float64]:
        """The same without modulation (stator not rotating), shape (m, 2)."""
        return self.estimate_fixed - self.true_rate

    def rms(self, modulated: bool = True) -> float:
        """RMS over both axes and all windows of the residual [rad/s]."""
        r = self.residual_modulated if modulated else self.residual_fixed
        return float(np.sqrt(np.mean(r**2)))


def run_modulation(
    t_s: ArrayLike,
    house_rate: ArrayLike,
    drift_stator: ArrayLike,
    *,
    stator_rate_rad_s: float,
    sample_rate_hz: float,
    periods: int = 1,
    K: ArrayLike | None = None,
    L: ArrayLike | None = None,
    noise: ArrayLike | None = None,
) -> ModulationRun:
    """Simulate measurement, demodulation and integral filtering, with and without rotation.

    ``noise`` (shape (n, 2), signal units) is added to the measured signal in both cases. The
    unmodulated case uses the same drift and noise with a stator at rest, filtered by the same
    window, so the comparison isolates what the rotation does.
    """
    t, w = _series(t_s, house_rate, "house_rate")
    n_win = samples_per_period(sample_rate_hz, stator_rate_rad_s) * int(periods)
    nz = 0.0 if noise is None else np.asarray(noise, dtype=float)
    f_mod = modulated_signal(t, w, drift_stator, stator_rate_rad_s=stator_rate_rad_s, K=K, L=L)
    f_fix = modulated_signal(t, w, drift_stator, stator_rate_rad_s=0.0, K=K, L=L)
    u_mod = demodulate(t, f_mod + nz, stator_rate_rad_s=stator_rate_rad_s, K=K)
    u_fix = demodulate(t, f_fix + nz, stator_rate_rad_s=0.0, K=K)
    filt = lambda x: integral_filter(x, samples_per_window=n_win)  # noqa: E731
    t_mid = filt(t[:, None])[:, 0]
    return ModulationRun(
        stator_rate_rad_s=float(stator_rate_rad_s),
        t_out=t_mid,
        true_rate=filt(w),
        estimate_modulated=filt(u_mod),
        estimate_fixed=filt(u_fix),
        cost=filter_cost(stator_rate_rad_s, periods),
    )


@dataclass(frozen=True)
class ComponentStudy:
    """The stator modulation at each stator frequency of a study (``modulation component``).

    Attributes
    ----------
    stator_hz : tuple of float
        Stator rotation frequencies [Hz].
    runs : tuple of ModulationRun
        The run at each frequency (drift, house rate, noise alike).
    """

    stator_hz: tuple[float, ...]
    runs: tuple[ModulationRun, ...]

    kind = "modulation-component"

    def rows(self) -> list[dict[str, float]]:
        """Per stator frequency: the RMS residual drift with and without modulation.

        Keys: ``stator_hz``, ``rms_residual_modulated_deg_h``, ``rms_residual_fixed_deg_h``
        [deg/h], the filter's ``delay_s`` [s], ``bandwidth_hz`` [Hz] and ``window_s`` [s].
        """
        k = DEG_PER_H_TO_RAD_PER_S
        return [{"stator_hz": f, "rms_residual_modulated_deg_h": r.rms(True) / k,
                 "rms_residual_fixed_deg_h": r.rms(False) / k, "delay_s": r.cost.delay_s,
                 "bandwidth_hz": r.cost.bandwidth_hz, "window_s": r.cost.window_s}
                for f, r in zip(self.stator_hz, self.runs, strict=True)]

    def to_dict(self) -> dict[str, object]:
        """The ``modulation-component`` result envelope."""
        return envelope(self.kind, result={
            "runs": self.rows(), "units": {"rms": "deg/h", "delay": "s", "bandwidth": "Hz"}})


def drift_scenario(
    t_s: ArrayLike,
    *,
    constant: ArrayLike = (0.0, 0.0),
    ramp: ArrayLike = (0.0, 0.0),
    random_walk: float = 0.0,
    sine_amplitude: float = 0.0,
    sine_hz: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> NDArray[np.float64]:
    """Stator-fixed drift [rad/s], shape (n, 2): constant + ramp t + random walk + sine.

    ``ramp`` [rad/s^2] stands for a temperature-like trend; ``random_walk`` [rad/s/sqrt(s)] is
    the rate-random-walk density (each axis independent); the sine of ``sine_amplitude``
    [rad/s] at ``sine_hz`` along the stator's x axis is a periodic disturbance; near the stator
    frequency half of it passes (see :func:`drift_gain`), which modulation cannot remove.
    """
    t = np.asarray(t_s, dtype=float)
    eps = np.broadcast_to(np.asarray(constant, float), (t.size, 2)) + np.outer(
        t, np.asarray(ramp, dtype=float))
    if random_walk:
        gen = np.random.default_rng(rng)
        dt = np.diff(t, prepend=t[0])
        eps = eps + np.cumsum(gen.normal(size=(t.size, 2)) * np.sqrt(dt)[:, None], 0) * random_walk
    if sine_amplitude:
        eps = eps.copy()
        eps[:, 0] += sine_amplitude * np.sin(2 * np.pi * sine_hz * t)
    return eps
