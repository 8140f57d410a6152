"""Data reduction: grouping rows into runs, whole-cycle masks and weights."""

import numpy as np
import pytest

from inertest.errors import DataError, InputError
from inertest.estimation.reduction import (
    BOUNDARY_TOLERANCE_CYCLES,
    group_rows,
    harmonic_rows,
    whole_cycle_correction,
    whole_cycle_mask,
    whole_cycle_weights,
)


def test_group_rows_matches_a_dictionary_of_key_tuples():
    rng = np.random.default_rng(3)
    pos = rng.integers(1, 10, 5000)
    rate = rng.choice([-8.85, 4.43, 8.85, 2.0], 5000)
    label = rng.choice(np.array(["a", "b"]), 5000)
    groups = group_rows(pos, rate, label)
    # independent reference: a dict from the key tuple to the rows, in first-seen order
    ref: dict[tuple, list[int]] = {}
    for i, k in enumerate(zip(pos.tolist(), rate.tolist(), label.tolist(), strict=True)):
        ref.setdefault(k, []).append(i)
    assert len(groups) == len(ref)
    keys = list(zip(*(k.tolist() for k in groups.keys), strict=True))
    assert keys == sorted(ref)  # runs sorted by the first key, then the second, ...
    for r, k in enumerate(keys):
        np.testing.assert_array_equal(groups.rows(r), ref[k])  # original order kept
    assert groups.keys[0].dtype == pos.dtype and groups.keys[1].dtype == rate.dtype


@pytest.mark.parametrize("stretch", [1, 7, 400])
def test_group_rows_of_runs_in_stretches_and_their_spans(stretch):
    # Test data come in stretches of equal keys (a run's samples one after another), in any
    # order of the runs and a run possibly in several stretches; the reference is a dict.
    rng = np.random.default_rng(stretch)
    k = 4000 // stretch
    pos = np.repeat(rng.integers(1, 4, k), stretch)
    rate = np.repeat(rng.choice([-8.85, 4.43], k), stretch)
    groups = group_rows(pos, rate)
    ref: dict[tuple, list[int]] = {}
    for i, key in enumerate(zip(pos.tolist(), rate.tolist(), strict=True)):
        ref.setdefault(key, []).append(i)
    keys = list(zip(*(v.tolist() for v in groups.keys), strict=True))
    assert keys == sorted(ref)
    rows = np.arange(pos.size)
    for r, key in enumerate(keys):
        np.testing.assert_array_equal(groups.rows(r), ref[key])
        span = groups.span(r)
        np.testing.assert_array_equal(rows[span], ref[key])
        one_stretch = ref[key][-1] - ref[key][0] == len(ref[key]) - 1
        assert isinstance(span, slice) == one_stretch
    empty = group_rows(np.zeros(0), np.zeros(0))
    assert len(empty) == 0 and empty.order.size == 0


def test_harmonic_rows_are_the_cosines_and_sines():
    a = np.linspace(-40.0, 900.0, 1001)
    rows = harmonic_rows(a, 3)
    assert rows.shape == (7, a.size)
    np.testing.assert_array_equal(rows[0], 1.0)
    # reference in long double: k a is exact there (a float64 k a is off by up to 3e-13 rad)
    al = a.astype(np.longdouble)
    for k in (1, 2, 3):
        np.testing.assert_allclose(rows[2 * k - 1], np.cos(k * al).astype(float), rtol=0,
                                   atol=4e-16 * k)
        np.testing.assert_allclose(rows[2 * k], np.sin(k * al).astype(float), rtol=0,
                                   atol=4e-16 * k)


def test_whole_cycle_correction_gives_the_weights():
    # 70.9 samples per cycle: the correction is not zero; the weights from it are those that
    # zero the harmonics' means (checked against the definition, not the implementation)
    omega = 4.43
    t = np.arange(709) / (70.9 * omega / (2 * np.pi))
    rows = harmonic_rows(omega * t, 2)
    w = 1.0 / t.size + whole_cycle_correction(rows @ rows.T, t.size, omega, 2) @ rows
    np.testing.assert_allclose(rows @ w, [1, 0, 0, 0, 0], atol=1e-14)
    np.testing.assert_allclose(w, whole_cycle_weights(t, omega), rtol=1e-12)
    with pytest.raises(DataError, match="too few samples per cycle"):
        whole_cycle_correction(rows[:, :3] @ rows[:, :3].T, 3, omega, 2)


def test_group_rows_rejects_ragged_keys():
    with pytest.raises(InputError, match="equal length"):
        group_rows(np.arange(3), np.arange(4))
    with pytest.raises(InputError, match="one or more"):
        group_rows()


def test_whole_cycle_mask_boundaries():
    w = 2 * np.pi  # one cycle per second
    t = np.arange(0, 301) / 100.0  # 0..3.00 s: the last sample closes the third cycle
    mask, n = whole_cycle_mask(t, w)
    assert n == 3 and mask.sum() == 300 and not mask[-1]
    mask, n = whole_cycle_mask(t[:-1], -w)  # 0..2.99 s: two whole cycles; sign ignored
    assert n == 2 and mask.sum() == 200
    mask, n = whole_cycle_mask(t[:50], w)
    assert n == 0 and not mask.any()
    # a last sample short of the boundary by less than the tolerance still closes the cycle
    t2 = np.r_[t[:-1], 3.0 - 0.1 * BOUNDARY_TOLERANCE_CYCLES]
    assert whole_cycle_mask(t2, w)[1] == 3


@pytest.mark.parametrize("omega", [4.43, -8.85])
def test_whole_cycle_weights_integrate_harmonics_like_the_integral(omega):
    # 50 Hz at 4.43 rad/s: 70.9 samples per cycle; the weighted mean of cos k a, sin k a
    # (k = 1, 2) must be zero as over whole cycles of the continuous signal, and of cos 3a not
    t = np.arange(0, int(7 * 2 * np.pi / abs(omega) * 50.0)) / 50.0
    mask, n = whole_cycle_mask(t, omega)
    tk = t[mask]
    wts = whole_cycle_weights(tk, omega)
    a = abs(omega) * (tk - tk[0])
    assert wts.sum() == pytest.approx(1.0, abs=1e-14)
    for k in (1, 2):
        assert abs(wts @ np.cos(k * a)) < 1e-15 and abs(wts @ np.sin(k * a)) < 1e-15
    plain = np.full(tk.size, 1 / tk.size)
    assert abs(plain @ np.cos(a)) > 1e-5  # the plain mean leaks O(1/samples)
    # minimum-norm correction, by an independent route: the KKT system of
    # min |w - u|^2 subject to B^T w = e1
    basis = np.column_stack([np.ones_like(a), np.cos(a), np.sin(a), np.cos(2 * a),
                             np.sin(2 * a)])
    kkt = np.block([[np.eye(a.size), basis], [basis.T, np.zeros((5, 5))]])
    rhs = np.r_[plain, 1.0, 0, 0, 0, 0]
    np.testing.assert_allclose(wts, np.linalg.solve(kkt, rhs)[: a.size], atol=1e-12 / a.size)
    # three harmonics on request
    w3 = whole_cycle_weights(tk, omega, harmonics=3)
    assert abs(w3 @ np.cos(3 * a)) < 1e-15


def test_whole_cycle_weights_are_equal_with_whole_samples_per_cycle():
    t = np.arange(40 * 12) / 40.0  # 40 samples per cycle of 1 s, 12 cycles
    np.testing.assert_allclose(whole_cycle_weights(t, 2 * np.pi), 1 / t.size, rtol=1e-12)


def test_whole_cycle_weights_need_enough_samples_per_cycle():
    t = np.arange(8) * 0.25  # 4 samples per cycle: sin 2a = 0 at every sample
    with pytest.raises(DataError, match="at least 5 times per cycle"):
        whole_cycle_weights(t, 2 * np.pi)


@pytest.mark.parametrize("n", [1, 5, 4096 * 2 + 3])
def test_whole_cycle_kernel_sums_equal_numpy(n):
    # The fused sums (tiles of 4096, any stride of y and r) against numpy's products of the
    # basis written out: Gram matrix, weighted sums, fits and residuals.
    from inertest.estimation import _whole_cycle_kernel as kernel

    rng = np.random.default_rng(n)
    t = np.sort(rng.uniform(0.0, 30.0, n))
    y2, f = rng.normal(size=(n, 2)), rng.normal(size=(n, 3)) * 20.0
    y, r = y2[:, 0], y2[:, 1]  # strided
    rows = harmonic_rows(2.1 * (t - 0.5), 2)
    gram, cos_sin = np.zeros((5, 5)), np.empty((2, n))
    kernel.gram(t, 2.1, 0.5, cos_sin, gram)
    np.testing.assert_allclose(gram, rows @ rows.T, rtol=1e-13, atol=1e-12 * n)
    np.testing.assert_array_equal(cos_sin, rows[1:3])
    weights = rng.normal(size=5)
    out = np.zeros(25)
    kernel.weighted_sums(cos_sin, y, r, f, 0.1, weights, out)
    w = weights @ rows
    g = f * 0.1
    gi, go, gs = g.T
    values = np.column_stack([y - r, r, g, gi * go, go * gs, gs * gi, g * g])
    scale = np.abs(values).max() * n
    np.testing.assert_allclose(out[:11], w @ values, rtol=1e-12, atol=1e-14 * scale)
    np.testing.assert_allclose(out[11:20], (rows[:3] @ g).ravel(), rtol=1e-12,
                               atol=1e-14 * scale)
    np.testing.assert_allclose(out[20:25], rows @ (y - r), rtol=1e-12, atol=1e-14 * scale)
    k = rng.normal(size=5)
    res = np.empty(n)
    kernel.basis_residuals(cos_sin, y, r, k, res)
    np.testing.assert_allclose(res, (y - r) - k @ rows, rtol=0, atol=1e-14)
