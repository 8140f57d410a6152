"""The noise models as values (estimation/noise_models.py), against their closed forms.

Each kernel is checked once here against an independent computation: dense averages of the
written-out covariance (random walk ``min(i, k) + 1``), the spectral integral of 1/f noise by
quadrature (scipy.integrate), and integrals over a fine grid. A last test flips a rule in the
one place and sees every procedure that models noise change: none keeps a copy.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate

import inertest
import inertest.io.plan_file
from inertest.errors import InertestWarning
from inertest.estimation import noise_models as nm
from inertest.estimation import units
from inertest.estimation.noise_models import MODELS, NoiseModel


def _dense_unit_kernel(index, counts, K):
    M = (index[None, :] == np.arange(counts.size)[:, None]) / counts[:, None]
    return M @ K @ M.T


@pytest.mark.parametrize("contiguous", [True, False])
def test_unit_kernels_equal_the_dense_averages(contiguous):
    """Random walk (min(i, k) + 1) averaged over units, vs dense M K M'."""
    n = 60
    labels = np.repeat(np.arange(12), 5) if contiguous else np.tile(np.arange(12), 5)
    u = units.units_of_rows(np.ones((n, 1)), np.zeros(n), labels.astype(str))
    i = np.arange(n)
    K_rw = np.minimum.outer(i, i) + 1.0
    np.testing.assert_allclose(nm.random_walk_unit_kernel(u),
                               _dense_unit_kernel(u.index, u.counts, K_rw), rtol=1e-12)


@pytest.mark.parametrize("contiguous", [True, False])
def test_flicker_kernel_equals_the_dense_average_of_the_integrated_spectrum(contiguous):
    """Flicker unit kernel vs dense M C M' with C[i, k] = c(|i - k|) / c(0), c(L) the integral
    of cos(2 pi f L) / f over 1/(4 n) .. 1/2 cycles per row, by quadrature (scipy.integrate)."""
    n = 60
    labels = np.repeat(np.arange(12), 5) if contiguous else np.tile(np.arange(12), 5)
    u = units.units_of_rows(np.ones((n, 1)), np.zeros(n), labels.astype(str))
    c = np.array([scipy.integrate.quad(lambda f, L=L: np.cos(2 * np.pi * f * L) / f,
                                       0.25 / n, 0.5, limit=400)[0] for L in range(n)])
    i = np.arange(n)
    C = c[np.abs(np.subtract.outer(i, i))] / c[0]
    np.testing.assert_allclose(nm.flicker_unit_kernel(u),
                               _dense_unit_kernel(u.index, u.counts, C), atol=1e-9)


@pytest.mark.parametrize("scale", [2.0, 32.0])
def test_flicker_kernel_for_a_bias_time_scale_starts_at_1_over_2_scale_n(scale):
    """``bias_time_scale`` s: the quadrature of cos(2 pi f L) / f from 1/(2 s n); s = 2 is the
    old 1/(4 n) bit for bit."""
    n = 40
    u = units.units_of_rows(np.ones((n, 1)), np.zeros(n), np.repeat(np.arange(8), 5).astype(str))
    c = np.array([scipy.integrate.quad(lambda f, L=L: np.cos(2 * np.pi * f * L) / f,
                                       0.5 / (scale * n), 0.5, limit=400)[0] for L in range(n)])
    i = np.arange(n)
    C = c[np.abs(np.subtract.outer(i, i))] / c[0]
    np.testing.assert_allclose(nm.flicker_unit_kernel(u, scale),
                               _dense_unit_kernel(u.index, u.counts, C), atol=1e-9)
    if scale == 2.0:
        np.testing.assert_array_equal(nm.flicker_unit_kernel(u, scale),
                                      nm.flicker_unit_kernel(u))


def test_random_walk_and_offsets_window_kernels_equal_the_integrated_covariance():
    """min(s, t) integrated over the windows on a fine grid (midpoint rule, 0.05 s); offsets
    per window ``T^2``."""
    start, dur = np.array([0.0, 10.0, 35.0]), np.array([10.0, 20.0, 5.0])
    h = 0.05
    pts = [a + h * (np.arange(int(round(T / h))) + 0.5) for a, T in zip(start, dur, strict=True)]
    rw = np.array([[np.minimum.outer(p, q).sum() * h * h for q in pts] for p in pts])
    np.testing.assert_allclose(MODELS["random-walk"].window_kernel(start, dur), rw, rtol=1e-4)
    np.testing.assert_allclose(MODELS["position-offsets"].window_kernel(start, dur),
                               np.diag(dur**2))


def _spectral_window_integral(ai, bi, ak, bk, f_lo, f_hi):
    """int_{f_lo}^{f_hi} (1/f) E[integral_i integral_k] df for a unit-density 1/f rate, by the
    trapezoid rule over ln f: the covariance of two window integrals in continuous time."""
    lf = np.linspace(np.log(f_lo), np.log(f_hi), 400_001)
    w = 2 * np.pi * np.exp(lf)
    g = (np.cos(w * (ai - ak)) - np.cos(w * (ai - bk)) - np.cos(w * (bi - ak))
         + np.cos(w * (bi - bk))) / w**2
    return float(np.sum((g[1:] + g[:-1]) / 2) * (lf[1] - lf[0]))


def test_flicker_window_kernel_equals_the_continuous_spectral_integral():
    """1/f rate noise from 1/(2 s span) up, over windows in continuous time (no grid), scaled
    to unit variance of the rate averaged over the shortest window: the kernel's time grid of
    64 points per shortest window agrees within 1e-3."""
    start, dur = np.array([0.0, 10.0, 35.0, 200.0]), np.array([10.0, 20.0, 5.0, 40.0])
    a, b = start, start + dur
    f_lo, f_hi = 1.0 / (2 * nm.BIAS_TIME_SCALE_DEFAULT * (b.max() - a.min())), 200.0 / dur.min()
    K = np.array([[_spectral_window_integral(a[i], b[i], a[k], b[k], f_lo, f_hi)
                   for k in range(4)] for i in range(4)])
    t = dur.min()
    var_short = _spectral_window_integral(0.0, t, 0.0, t, f_lo, f_hi) / t**2
    np.testing.assert_allclose(MODELS["flicker"].window_kernel(start, dur), K / var_short,
                               rtol=1e-3)


@pytest.mark.parametrize("level_rows", [None, 40])
def test_row_kernels_equal_the_dense_covariance(level_rows):
    """``K v`` over rows: min(i, k) + 1 for the random walk; for flicker c(|i - k|) / c_m(0)
    with c the quadrature of cos(2 pi f L) / f from 1/(4 n) (n = 100 rows) and c_m(0) that of
    the record the level was fitted on (m = level_rows)."""
    n = 100
    v = np.random.default_rng(1).normal(size=(n, 3))
    i = np.arange(n)
    np.testing.assert_allclose(MODELS["random-walk"].row_apply(v, level_rows=level_rows),
                               (np.minimum.outer(i, i) + 1.0) @ v, rtol=1e-12)

    def c(L, rows):
        return scipy.integrate.quad(lambda f: np.cos(2 * np.pi * f * L) / f, 0.25 / rows, 0.5,
                                    limit=400)[0]

    C = np.array([c(L, n) for L in range(n)])[np.abs(np.subtract.outer(i, i))]
    C /= c(0, level_rows or n)
    np.testing.assert_allclose(MODELS["flicker"].row_apply(v, level_rows=level_rows), C @ v,
                               rtol=1e-8, atol=1e-8)


def test_white_noise_has_no_component_kernel():
    u = units.Units.of_values(np.zeros(4), np.ones((4, 1)))
    with pytest.raises(Exception, match="no component"):
        MODELS["white"].unit_kernel(u)
    assert MODELS["white"].component is None
    assert [m.component for m in MODELS.values()] == [None, "position offset", "random walk",
                                                       "flicker"]


#: Example plans of the procedures that model noise.
EXAMPLES = {k: Path(__file__).resolve().parents[2] / "examples" / d / "plan.toml" for k, d in (
    ("polar-tumble", "polar_tumble"), ("triad-multiposition", "triad_multiposition"),
    ("gyro-triad-rotation", "gyro_triad_rotation"), ("ferraris", "ferraris"))}


# --- one place: a rule changed here changes every procedure that models noise ---------------

def _fit_std(kind, truth, noise, noise_model, walk):
    plan = inertest.load_plan(EXAMPLES[kind])
    data = inertest.simulate(plan, truth, noise=noise, rng=3)
    rng = np.random.default_rng(5)
    for col, step in walk.items():  # a random walk of the bias: a component to model
        data[col] = data[col] + np.cumsum(rng.normal(0.0, step, data[col].size))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)
        res = inertest.fit(plan, data, noise_model=noise_model)
    return np.array([e.std for e in res.coefficients.values()])


def _distorted(method):
    """The method with its rule changed: a kernel changed in shape (an extra independent part
    per unit), or the row kernel that carries a fitted level over a record, doubled."""
    def patched(self, *args, **kwargs):
        K = method(self, *args, **kwargs)
        if method.__name__ == "row_apply":
            return 2.0 * K
        return K + 5.0 * np.mean(np.diag(K)) * np.eye(K.shape[0])
    return patched


CASES = {  # procedure: (truth, noise, noise model, the rule it uses, random walk added)
    "polar-tumble": ({"DF": 1.2, "DI": 0.85}, 0.002, "random-walk", "unit_kernel",
                     {"output": 0.002}),
    "triad-multiposition": ({"K_x": 1671.0, "K_y": 1671.0, "K_z": 1671.0}, 2.0, "flicker",
                            "unit_kernel", {}),
    "gyro-triad-rotation": (None, 30.0, "random-walk", "window_kernel", {}),
    "ferraris": (None, 0.0, "random-walk", "row_apply",
                 {f"{s}_{a}": 0.05 for s in ("acc", "gyr") for a in "xyz"}),
}


@pytest.mark.parametrize("kind", list(CASES))
def test_flipping_a_noise_model_rule_changes_every_procedure(kind, monkeypatch, examples_dir):
    truth, noise, model, rule, walk = CASES[kind]
    if truth is None:
        truth = inertest.io.plan_file.load_truth(examples_dir / EXAMPLES[kind].parent.name
                                                 / "truth.toml")
    before = _fit_std(kind, truth, noise, model, walk)
    monkeypatch.setattr(NoiseModel, rule, _distorted(getattr(NoiseModel, rule)))
    after = _fit_std(kind, truth, noise, model, walk)
    assert np.max(np.abs(after / before - 1)) > 0.01, kind
