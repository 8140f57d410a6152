"""Solving a static test per position (PositionDesign) equals solving it reading by reading."""

import warnings

import numpy as np
import pytest
import scipy.special

from inertest.errors import IdentifiabilityError, InputError
from inertest.estimation import identify as idf
from inertest.estimation import noise_models as nm
from inertest.estimation import reml, units


def _test(rng, G=24, m=7, shuffle=False):
    # Position offsets well above the white noise: ``auto`` far from a tie (a random walk
    # fitted to zero has the AIC of white + 2 exactly, and rounding then decides the set of
    # close models).
    x = np.linspace(-1, 1, G)
    rows = np.column_stack([np.ones(G), x, x**2, np.zeros(G)])  # last column: never excited
    codes = np.repeat(rng.permutation(G) if shuffle else np.arange(G), m)
    if shuffle:  # positions revisited: runs of one position apart in time
        codes = np.concatenate([codes[: codes.size // 2], codes[: codes.size // 2]])
    y = (rows[codes] @ [1.0, 2.0, -0.5, 0.0] + np.repeat(rng.normal(0, 1.0, G), m)[: codes.size]
         + rng.normal(0, 1.0, codes.size))
    labels = [f"p{k:02d}" for k in range(G)]
    return rows, codes, labels, y


def _solve(A, y, groups, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return idf.solve(A, y, groups=groups, **kw)


# Shuffled rows with a given sigma under a correlated model add nothing the unshuffled cases do
# not cover, so those combinations are not generated (rather than generated and skipped).
_CASES = [(m, s, sh) for m in nm.NOISE_MODELS for s in (None, 0.9, "rows")
          for sh in (False, True) if not (s is not None and m not in ("white", "auto") and sh)]


@pytest.mark.parametrize(("model", "sigma", "shuffle"), _CASES)
def test_position_design_equals_the_full_design(model, sigma, shuffle):
    rng = np.random.default_rng(18)
    rows, codes, labels, y = _test(rng, shuffle=shuffle)
    sig = rng.uniform(0.5, 1.5, y.size) if sigma == "rows" else sigma
    full, nf_full = _solve(rows[codes], y, np.asarray(labels)[codes], sigma_si=sig,
                           noise_model=model)
    P = units.PositionDesign.from_codes(rows, codes, labels)
    pos, nf_pos = _solve(P, y, None, sigma_si=sig, noise_model=model)
    assert nf_pos.model == nf_full.model
    assert nf_pos.unit_labels == nf_full.unit_labels
    np.testing.assert_array_equal(nf_pos.unit_index, nf_full.unit_index)
    scale = full.std[full.identifiable]
    np.testing.assert_allclose(pos.x[:3], full.x[:3], rtol=0, atol=1e-10 * scale.max())
    np.testing.assert_allclose(pos.covariance, full.covariance, rtol=1e-10,
                               atol=1e-12 * scale.max() ** 2)
    np.testing.assert_allclose(pos.residuals, full.residuals, rtol=0, atol=1e-12)
    assert (pos.rank, pos.dof, pos.sigma_from_residuals) == (full.rank, full.dof,
                                                             full.sigma_from_residuals)
    np.testing.assert_allclose(pos.sigma, full.sigma, rtol=1e-13)
    np.testing.assert_allclose(np.abs(pos.null_space), np.abs(full.null_space), atol=1e-12)
    assert nf_pos.checks.verdict == nf_full.checks.verdict
    np.testing.assert_allclose(nf_pos.checks.chi_square, nf_full.checks.chi_square, rtol=1e-10)
    for k, v in nf_full.components.items():
        np.testing.assert_allclose(nf_pos.components[k], v, rtol=1e-9)


def test_position_design_from_codes_orders_positions_in_time_and_checks_its_input():
    rows = np.arange(12.0).reshape(4, 3)
    P = units.PositionDesign.from_codes(rows, [2, 2, 0, 0, 2, 3], ["a", "b", "c", "d"])
    assert P.labels == ("c", "a", "d")  # b has no readings
    np.testing.assert_array_equal(P.index, [0, 0, 1, 1, 0, 2])
    np.testing.assert_array_equal(P.rows, rows[[2, 0, 3]])
    assert P.shape == (6, 3)
    np.testing.assert_array_equal(P @ np.ones(3), rows[[2, 2, 0, 0, 2, 3]].sum(axis=1))
    with pytest.raises(InputError, match="codes must lie"):
        units.PositionDesign.from_codes(rows, [0, 4], ["a", "b", "c", "d"])
    with pytest.raises(InputError, match="no groups"):
        idf.solve(P, np.ones(6), groups=np.array(list("abcdef")))
    with pytest.raises(IdentifiabilityError, match="no degree of freedom"):
        idf.solve(units.PositionDesign.from_codes(np.eye(3), [0, 1, 2], "abc"), np.ones(3))


@pytest.mark.parametrize("n", [1, 10, 1000, 70_000, 140_000])
def test_flicker_second_antidifference_is_the_whole_record_bit_for_bit(n):
    c = nm.flicker_row_covariance(n)
    step = c[0] / 2 + np.concatenate(([0.0], np.cumsum(c[1:])))
    phi = np.concatenate(([0.0], np.cumsum(step)))  # Phi(0 .. n + 1) over the whole record
    lags = np.arange(n + 2)
    c0, got = nm.flicker_phi(n, lags)
    assert c0 == c[0]
    np.testing.assert_array_equal(got, phi)
    np.testing.assert_array_equal(nm.flicker_phi(n, lags[::3])[1], phi[::3])
    np.testing.assert_array_equal(nm.flicker_phi(n, lags[: n // 2])[1], phi[: n // 2])
    with pytest.raises(InputError, match="beyond the record"):
        nm.flicker_phi(n, np.array([n + 2]))


@pytest.mark.parametrize("n", [3, 5000])
def test_flicker_short_records_by_scipy_agree_with_the_compiled_loop(n, monkeypatch):
    # short records skip numba (its import costs a small fit more than the fit)
    lags = np.arange(n + 2)
    c_py, phi_py = nm.flicker_row_covariance(n), nm.flicker_phi(n, lags)[1]
    monkeypatch.setattr(nm, "COMPILED_FROM", 0)
    c_nb, phi_nb = nm.flicker_row_covariance(n), nm.flicker_phi(n, lags)[1]
    np.testing.assert_allclose(c_py, c_nb, rtol=0, atol=2e-16 * c_py[0])
    np.testing.assert_allclose(phi_py, phi_nb, rtol=4e-15, atol=0)


@pytest.mark.parametrize("scale", [1.0, 2.0, 30.0])
def test_flicker_row_covariance_is_the_cosine_integral_of_scipy(scale):
    # c(L) = Ci(pi L) - Ci(2 pi f_lo L): the kernel's series and asymptotic expansion against
    # scipy's sici (cephes) over lags on both sides of where the expansion takes over, to
    # about an ulp of c(0) (scipy's Ci(pi L) takes the rounded argument: ~4e-17 apart)
    n = 300_000
    c = nm.flicker_row_covariance(n, scale)
    f_lo = nm.flicker_low(n, scale)
    lag = np.arange(1, n + 1, dtype=float)
    ref = scipy.special.sici(np.pi * lag)[1] - scipy.special.sici(2 * np.pi * f_lo * lag)[1]
    assert c[0] == np.log(0.5 / f_lo)
    np.testing.assert_allclose(c[1:], ref, rtol=0, atol=2e-16 * c[0])


def test_bounded_minimum_is_scipy_minimize_scalar_bounded_bit_for_bit():
    # The REML fit's line search without importing scipy.optimize: same iterates, same numbers.
    import scipy.optimize

    rng = np.random.default_rng(18)
    funcs = [lambda x, c=c, d=d: (x - c) ** 2 * (1 + 0.3 * np.sin(d * x)) + 0.1 * np.cos(3 * x)
             for c, d in rng.normal(size=(40, 2))]
    funcs += [lambda x: abs(x - 0.3), lambda x: 1.0, lambda x: -x, lambda x: x**4 - x**2]
    for f in funcs:
        lo, hi = np.sort(rng.normal(0, 3, 2))
        for xatol in (1e-3, 1e-8):
            ref = scipy.optimize.minimize_scalar(f, bounds=(lo, hi), method="bounded",
                                                 options={"xatol": xatol})
            x, fx = reml.bounded_minimum(f, lo, hi, xatol=xatol)
            assert x == float(ref.x) and fx == float(ref.fun)
