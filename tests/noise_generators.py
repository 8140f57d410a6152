"""Noise for the Monte Carlo tests, generated independently of the library (issue 15).

White; white + an offset per unit (position, run, window) as large as the sample noise; white +
a random walk wandering ~3 sigma over the test; flicker (1/f) by FFT shaping of white noise,
power 1/f from 1/(2n) cycles per sample up (Kasdin 1995). Shared by the procedure tests so that
every procedure's noise matrix is checked against the same generators.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def _shaped(rng: np.random.Generator, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """Unscaled 1/f noise along the last axis: one-sided PSD ``2 / (n f)`` per Hz (n samples).

    Complex normal lines of amplitude ``1/sqrt(f)`` over ``2 n`` samples (first ``n`` kept);
    a line's variance is ``4 / ((2 n)^2 f)`` in a band ``1 / (2 n)`` wide, whatever the
    sample interval.
    """
    n = shape[-1]
    f = np.fft.rfftfreq(2 * n)
    amp = np.r_[0.0, 1.0 / np.sqrt(f[1:])]
    z = rng.normal(size=(*shape[:-1], f.size)) + 1j * rng.normal(size=(*shape[:-1], f.size))
    return np.fft.irfft(z * amp, 2 * n)[..., :n]


def flicker(rng: np.random.Generator, shape: tuple[int, ...], *, per_row: bool = True
            ) -> NDArray[np.float64]:
    """1/f noise along the last axis of ``shape``, scaled to unit std (per row or overall)."""
    x = _shaped(rng, shape)
    return x / (x.std(axis=-1, keepdims=True) if per_row else x.std())


def flicker_rate(rng: np.random.Generator, n: int, *, h: float, oversample: int = 8
                 ) -> NDArray[np.float64]:
    """``n`` rate samples of flicker noise of one-sided PSD ``h / f``, each the mean over its
    sample interval (as a gyro's integrated output gives), whatever that interval.

    Synthesised at ``oversample`` points per sample (scaled by ``sqrt(h M / 2)``, M points,
    see :func:`_shaped`) and block-averaged, so that the Allan variance is the continuous
    ``2 ln2 h`` down to tau0 (point samples of noise band-limited at Nyquist have ~19 % more
    at tau0: ``h Cin(pi)`` instead of ``2 ln2 h``).
    """
    m = n * oversample
    x = np.sqrt(h * m / 2.0) * _shaped(rng, (m,))
    return x.reshape(n, oversample).mean(axis=1)


def noise(kind: str, rng: np.random.Generator, reps: int, unit_of_row: NDArray[np.int64],
          s: float) -> NDArray[np.float64]:
    """``reps`` noise series over the rows (in time order), sample std ``s``, of ``kind``.

    ``unit_of_row`` numbers the unit of independence of each row (0, 1, ...).
    """
    n = unit_of_row.size
    w = rng.normal(0.0, s, (reps, n))
    if kind == "white":
        return w
    if kind == "position-offsets":
        return w + rng.normal(0.0, s, (reps, int(unit_of_row.max()) + 1))[:, unit_of_row]
    if kind == "random-walk":
        return w + np.cumsum(rng.normal(0.0, 3 * s / np.sqrt(n), (reps, n)), axis=1)
    return s * flicker(rng, (reps, n))
