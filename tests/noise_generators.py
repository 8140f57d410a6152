"""Noise for the Monte Carlo tests, generated independently of the library (issue 15).

White; white + an offset per unit (position, run, window) as large as the sample noise; white +
a random walk wandering ~3 sigma over the test; flicker (1/f) by FFT shaping of white noise,
power 1/f from 1/(2n) cycles per sample up (Kasdin 1995). Shared by the procedure tests so that
every procedure's noise matrix is checked against the same generators.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def flicker(rng: np.random.Generator, shape: tuple[int, ...], *, per_row: bool = True
            ) -> NDArray[np.float64]:
    """1/f noise along the last axis of ``shape``, scaled to unit std (per row or overall)."""
    n = shape[-1]
    f = np.fft.rfftfreq(2 * n)
    amp = np.r_[0.0, 1.0 / np.sqrt(f[1:])]
    z = rng.normal(size=(*shape[:-1], f.size)) + 1j * rng.normal(size=(*shape[:-1], f.size))
    x = np.fft.irfft(z * amp, 2 * n)[..., :n]
    return x / (x.std(axis=-1, keepdims=True) if per_row else x.std())


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
