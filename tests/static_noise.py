"""The noise of an instrument at rest for the acceptance-test Monte Carlo, made here (issue 32).

Independent of the library: white noise, band-limited flicker synthesised line by line in the
frequency domain, and a rate random walk from power-on, vectorised over many records, plus the
warm-up transient of a fibre-optic gyro after power-on. The library's models describe the same
noise (``inertest.noise.record_noise``); nothing here calls them.

* white: ``N / sqrt(tau0)`` per reading (angle random walk ``N``);
* flicker: one-sided PSD ``h / f``, ``h = B^2 / pi`` (IEEE Std 952-1997 Annex C: Allan variance
  ``(2 ln 2 / pi) B^2``), from ``f_lo = 1 / (2 s T)`` (``T`` the record, ``s`` = 2) to the
  Nyquist frequency: a periodic process of period ``over x T`` whose line ``k`` carries exactly
  the power of its band ``[f_k - df/2, f_k + df/2]`` above ``f_lo`` (so the band edge is where
  it is said to be), the first ``T`` kept;
* rate random walk: cumulative sum of steps ``K sqrt(tau0)`` from the first reading.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

DEG_H = np.pi / 180 / 3600          # rad/s per deg/h
#: deg/sqrt(h) -> rad/sqrt(s); deg/h/sqrt(h) -> rad/s/sqrt(s)
DEG_SQRT_H = np.pi / 180 / 60
DEG_H_SQRT_H = DEG_H / 60


def band_flicker(rng: np.random.Generator, shape: tuple[int, ...], tau0: float, h: float,
                 f_lo: float, *, over: int = 8) -> NDArray[np.float64]:
    """Flicker of PSD ``h / f`` from ``f_lo`` up, along the last axis of ``shape``."""
    n = shape[-1]
    L = over * n
    f = np.fft.rfftfreq(L, tau0)
    df = 1.0 / (L * tau0)
    lo = np.maximum(f - df / 2, f_lo)
    hi = f + df / 2
    power = np.where(hi > lo, h * np.log(hi / np.where(lo > 0, lo, 1.0)), 0.0)
    power[0] = power[-1] = 0.0
    amp = (L / 2) * np.sqrt(power)
    z = rng.normal(size=(*shape[:-1], f.size)) + 1j * rng.normal(size=(*shape[:-1], f.size))
    return np.fft.irfft(z * amp, L)[..., :n]


def at_rest(rng: np.random.Generator, shape: tuple[int, ...], tau0: float, *, N: float = 0.0,
            B: float = 0.0, K: float = 0.0, s: float = 2.0) -> NDArray[np.float64]:
    """Noise of records of ``shape[-1]`` readings: white ``N``, flicker ``B``, random walk ``K``.

    ``N`` [u sqrt(s)], ``B`` [u], ``K`` [u / sqrt(s)] for a rate unit u.
    """
    n = shape[-1]
    y = (N / np.sqrt(tau0)) * rng.normal(size=shape)
    if B:
        y += band_flicker(rng, shape, tau0, B * B / np.pi, 1.0 / (2.0 * s * n * tau0))
    if K:
        y += np.cumsum((K * np.sqrt(tau0)) * rng.normal(size=shape), axis=-1)
    return y


def warm_up(t_s: NDArray[np.float64], b_inf: float, terms: list[tuple[float, float]]
            ) -> NDArray[np.float64]:
    """A warm-up transient ``b_inf + sum a_i exp(-t / T_i)`` (amplitude, time constant [s])."""
    out = np.full_like(np.asarray(t_s, dtype=float), b_inf)
    for a, T in terms:
        out = out + a * np.exp(-t_s / T)
    return out
