import numpy as np
import pytest
import scipy.linalg

from inertest.errors import IdentifiabilityError, InputError
from inertest.estimation.least_squares import identifiable_combinations, weighted_least_squares


def test_full_rank_matches_normal_equations_and_lstsq():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(40, 4)) * [1.0, 1e3, 1e-3, 5.0]  # badly scaled columns on purpose
    y = A @ [1, 2e-3, 3e3, -4] + rng.normal(size=40) * 0.1
    fit = weighted_least_squares(A, y)
    x_ref, *_ = np.linalg.lstsq(A, y, rcond=None)
    np.testing.assert_allclose(fit.x, x_ref, rtol=1e-9)
    r = y - A @ x_ref
    s2 = r @ r / (40 - 4)
    np.testing.assert_allclose(fit.covariance, s2 * np.linalg.inv(A.T @ A), rtol=1e-8)
    assert fit.dof == 36 and fit.rank == 4 and fit.identifiable.all()


def test_known_sigmas_weight_rows():
    rng = np.random.default_rng(2)
    A = rng.normal(size=(30, 3))
    s = rng.uniform(0.1, 2.0, size=30)
    y = A @ [1, 2, 3] + rng.normal(size=30) * s
    fit = weighted_least_squares(A, y, sigma=s)
    W = np.diag(1 / s**2)
    cov = np.linalg.inv(A.T @ W @ A)
    np.testing.assert_allclose(fit.covariance, cov, rtol=1e-9)
    np.testing.assert_allclose(fit.x, cov @ A.T @ W @ y, rtol=1e-9)
    assert not fit.sigma_from_residuals


def test_rank_deficient_null_space_and_combinations():
    rng = np.random.default_rng(3)
    B = rng.normal(size=(25, 3))
    A = np.column_stack([B, B[:, 1] - 2 * B[:, 2]])  # x1, x2, x3 mix with x4
    y = A @ [1.0, 2.0, 3.0, 4.0]
    fit = weighted_least_squares(A, y, sigma=1.0)
    assert fit.rank == 3
    ref = scipy.linalg.null_space(A)
    assert abs(abs(ref[:, 0] @ fit.null_space[:, 0]) - 1) < 1e-10
    assert fit.identifiable.tolist() == [True, False, False, False]
    rows = identifiable_combinations(fit.null_space, [1, 2, 3])
    # null vector (0, 1, -2, -1): combinations orthogonal to it, in RREF
    assert rows.shape == (2, 4)
    for r in rows:
        assert fit.is_identifiable(r)
        v, _ = fit.combination(r)
        assert v == pytest.approx(r @ [1, 2, 3, 4], abs=1e-10)
    with pytest.raises(IdentifiabilityError):
        fit.combination([0, 1, 0, 0])


def test_bad_input():
    A = np.ones((3, 2))
    with pytest.raises(InputError, match="NaN"):
        weighted_least_squares(A, [1, np.nan, 2])
    with pytest.raises(InputError, match="do not match"):
        weighted_least_squares(A, [1, 2])
    with pytest.raises(IdentifiabilityError, match="zero"):
        weighted_least_squares(np.zeros((3, 2)), [1, 2, 3])
    with pytest.raises(IdentifiabilityError, match="degree of freedom"):
        weighted_least_squares(np.eye(2), [1.0, 2.0])
    with pytest.raises(InputError, match="positive"):
        weighted_least_squares(np.eye(2), [1.0, 2.0], sigma=[1.0, 0.0])


def test_fewer_rows_than_unknowns_returns_the_whole_null_space():
    # 3 readings of 5 unknowns, one column never excited: the null space has dimension 2 and
    # must equal scipy's; the unexcited coefficient is not identifiable.
    rng = np.random.default_rng(5)
    A = rng.normal(size=(3, 5))
    A[:, 4] = 0.0
    A[:, 3] = 0.0
    fit = weighted_least_squares(A, rng.normal(size=3), sigma=1.0)
    expected = scipy.linalg.null_space(A)
    assert fit.null_space.shape == (5, 2)
    # Same subspace: projections onto each other's complement vanish.
    assert np.allclose(expected - fit.null_space @ (fit.null_space.T @ expected), 0, atol=1e-12)
    assert not fit.identifiable[3] and not fit.identifiable[4]


def test_null_space_accurate_with_heavy_row_weights_and_a_zero_column():
    # Run means of 1e18 samples weigh ~1e9; a zero column (a coefficient no position excites)
    # next to a genuine dependency (column 2 = column 0 + column 1) must still give a null
    # space that A annihilates to rounding, and the dependency must be recognised.
    rng = np.random.default_rng(1)
    b = rng.normal(size=(50, 3))
    a = np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 1], np.zeros(50), b[:, 2]])
    for weight in (1.0, 1e9):
        for _ in range(10):  # the SVD mixes the two null vectors differently for each ordering
            perm = rng.permutation(5)
            fit = weighted_least_squares(
                a[:, perm], rng.normal(size=50), sigma=np.full(50, 1.0 / weight)
            )
            assert fit.rank == 3
            assert np.abs(a[:, perm] @ fit.null_space).max() < 1e-12
        fit = weighted_least_squares(a, rng.normal(size=50), sigma=np.full(50, 1.0 / weight))
        assert fit.is_identifiable([1.0, 1.0, -1.0, 0.0, 0.0]) is False
        assert fit.is_identifiable([1.0, 0.0, 1.0, 0.0, 0.0]) is True  # orthogonal to (1,1,-1)
        assert fit.identifiable.tolist() == [False, False, False, False, True]


def _thin_svd_reference(A, y, w):
    """The textbook solution on the whole weighted design (Golub & Van Loan sec. 5.5)."""
    Aw, yw = A * w[:, None], y * w
    norms = np.linalg.norm(Aw, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    U, s, Vt = np.linalg.svd(Aw / scale, full_matrices=False)
    r = int(np.sum(s > 1e-9 * s[0]))
    x = Vt[:r].T @ ((U[:, :r].T @ yw) / s[:r]) / scale
    cov_z = (Vt[:r].T / s[:r] ** 2) @ Vt[:r]
    return x, cov_z / np.outer(scale, scale), s / s[0], r


@pytest.mark.parametrize("weighted", [False, True])
def test_tall_design_blocked_qr_equals_the_thin_svd(weighted):
    # 200,000 rows (four QR blocks): the R-factor path against the thin SVD of the whole design.
    rng = np.random.default_rng(3)
    n = 200_000
    t = rng.uniform(-1, 1, n)
    A = np.column_stack([np.ones(n), 1e3 * t, 1e-3 * t**2, np.sin(3 * t), np.zeros(n)])
    A[:, 4] = A[:, 0] - 2e-3 * A[:, 1]  # an exact dependency: rank 4
    sig = rng.uniform(0.5, 2.0, n) if weighted else np.ones(n)
    y = A @ np.array([1.0, 2e-3, 5.0, -0.7, 0.0]) + sig * rng.normal(0, 0.01, n)
    fit = weighted_least_squares(A, y, sigma=sig if weighted else None)
    x, cov, s_rel, r = _thin_svd_reference(A, y, 1.0 / sig)
    assert fit.rank == r == 4
    np.testing.assert_allclose(fit.singular_values / fit.singular_values[0], s_rel,
                               rtol=1e-9, atol=1e-14)
    # identifiable functions agree; the minimum-norm estimate itself agrees too
    np.testing.assert_allclose(A @ fit.x, A @ x, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(fit.x, x, rtol=1e-9, atol=1e-12)
    ref_sigma = (np.sqrt(np.sum(((y - A @ x) / sig) ** 2) / (n - r)) if not weighted else 1.0)
    np.testing.assert_allclose(fit.sigma, ref_sigma, rtol=1e-12)
    np.testing.assert_allclose(fit.covariance, cov * ref_sigma**2, rtol=1e-8,
                               atol=1e-12 * np.abs(cov).max())
    assert fit.null_space.shape == (5, 1)
    assert np.abs(A @ fit.null_space[:, 0]).max() < 1e-9 * np.abs(A).max()


def test_tall_design_with_nan_is_refused():
    A = np.ones((100_000, 2))
    A[99_999, 1] = np.nan
    with pytest.raises(InputError, match="NaN"):
        weighted_least_squares(A, np.ones(100_000))
