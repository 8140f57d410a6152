"""Weighted linear least squares with full covariance and an identifiability analysis.

The solver works on a column-scaled design through the SVD (Golub & Van Loan, *Matrix
Computations*, 4th ed., sec. 5.5), so that rank deficiency is found reliably whatever the units of
the columns. From the SVD it returns the minimum-norm estimate, its covariance (the pseudo-inverse
covariance), the null space of the design, and so what the data determine:

* a coefficient is *individually identifiable* when its unit vector is orthogonal to the null
  space (its estimate does not depend on how the null space is filled);
* for the rest, a basis of identifiable linear combinations ``c . x`` (``c`` orthogonal to the null
  space) in reduced row-echelon form, so each combination has a leading coefficient of weight 1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import IdentifiabilityError, InputError

#: Singular values below this fraction of the largest (after column scaling) count as zero.
DEFAULT_RCOND = 1e-9
#: A coefficient whose unit vector has a null-space component below this is identifiable.
_IDENTIFIABLE_TOL = 1e-7
#: Rows per block of the QR of a tall design (above it the design is reduced to its R factor).
_BLOCK_ROWS = 65536


@dataclass(frozen=True)
class LinearFit:
    """Result of :func:`weighted_least_squares`.

    Attributes
    ----------
    x : ndarray, shape (p,)
        Minimum-norm estimate (in the column-scaled sense). Only identifiable functions of it
        (see :attr:`identifiable`, :meth:`combination`) mean anything when ``rank < p``.
    covariance : ndarray, shape (p, p)
        Covariance of ``x`` (pseudo-inverse covariance scaled by ``sigma**2``).
    residuals : ndarray, shape (n,)
        ``y - A x`` in the units of ``y``.
    sigma : float
        Standard deviation of unit weight: the noise per sample when no ``sigma`` was given (in the
        units of ``y``), otherwise 1 (the given sigmas are taken as known).
    sigma_from_residuals : bool
        True when ``sigma`` was estimated from the residuals.
    dof : int
        Degrees of freedom of the residuals, ``n - rank``.
    rank : int
        Numerical rank of the design.
    null_space : ndarray, shape (p, p - rank)
        Orthonormal basis of the null space of the design.
    singular_values : ndarray
        Singular values of the column-scaled, weighted design.
    """

    x: NDArray[np.float64]
    covariance: NDArray[np.float64]
    residuals: NDArray[np.float64]
    sigma: float
    sigma_from_residuals: bool
    dof: int
    rank: int
    null_space: NDArray[np.float64]
    singular_values: NDArray[np.float64]

    @property
    def std(self) -> NDArray[np.float64]:
        """Standard uncertainty of each element of :attr:`x` (meaningful where identifiable)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def identifiable(self) -> NDArray[np.bool_]:
        """Mask of individually identifiable coefficients."""
        if self.null_space.shape[1] == 0:
            return np.ones(self.x.size, dtype=bool)
        return np.linalg.norm(self.null_space, axis=1) < _IDENTIFIABLE_TOL

    def is_identifiable(self, weights: ArrayLike) -> bool:
        """True when the linear combination ``weights . x`` is determined by the data."""
        c = np.asarray(weights, dtype=float)
        scale = max(float(np.linalg.norm(c)), 1e-300)
        return bool(np.linalg.norm(self.null_space.T @ c) <= _IDENTIFIABLE_TOL * scale)

    def combination(self, weights: ArrayLike) -> tuple[float, float]:
        """Value and standard uncertainty of ``weights . x``; it must be identifiable."""
        c = np.asarray(weights, dtype=float)
        if not self.is_identifiable(c):
            raise IdentifiabilityError(
                "the requested combination of coefficients is not determined by this test"
            )
        return float(c @ self.x), float(np.sqrt(max(c @ self.covariance @ c, 0.0)))


def weighted_least_squares(
    A: ArrayLike,
    y: ArrayLike,
    *,
    sigma: float | ArrayLike | None = None,
    rcond: float = DEFAULT_RCOND,
) -> LinearFit:
    """Solve ``y = A x + e`` by weighted least squares through the SVD.

    Parameters
    ----------
    A : array_like, shape (n, p)
        Design matrix.
    y : array_like, shape (n,)
        Observations.
    sigma : float or array_like of shape (n,), optional
        Known standard deviation of each observation (units of ``y``). When omitted, all rows
        get equal weight and the noise level is estimated from the residuals,
        ``sigma^2 = |r|^2 / (n - rank)``.
    rcond : float
        Relative threshold on the singular values of the column-scaled design for the rank.

    Returns
    -------
    LinearFit

    Raises
    ------
    InputError
        Shapes do not match, or ``A``, ``y`` or ``sigma`` hold NaN/inf or non-positive sigmas.
    IdentifiabilityError
        The design is all zero, or the noise must be estimated but no degree of freedom is left.

    Notes
    -----
    A design of more than 65,536 rows is first reduced block by block to the R factor of the QR
    of the weighted ``[A y]`` (:func:`_scaled_r_factor`), and the SVD is taken of the small
    column-scaled R: the same singular values, V, estimate and covariance as the thin SVD of the
    whole design, to rounding, at O(p^2) memory beyond the data instead of three copies of it.
    """
    A = np.asarray(A, dtype=float)
    y = np.asarray(y, dtype=float)
    if A.ndim != 2 or y.ndim != 1 or A.shape[0] != y.shape[0]:
        raise InputError(f"design {A.shape} and observations {y.shape} do not match")
    n, p = A.shape
    s = None
    if sigma is not None:
        s = np.broadcast_to(np.asarray(sigma, dtype=float), (n,))
        if not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError("observation sigmas must be finite and positive")
    if n > _BLOCK_ROWS and n >= p:
        # Tall design: the R of a blocked QR of [A y] (weighted) holds all the SVD needs
        # (same singular values and V; U' y = U_R' Q' y), in O(p^2) memory beyond the data.
        Rs, qy, scale = _scaled_r_factor(A, y, s)
        U, s_val, Vt = np.linalg.svd(Rs)
        yw = qy
    else:
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(y))):
            raise InputError("design or observations contain NaN or inf")
        w = np.ones(n) if s is None else 1.0 / s
        Aw = A * w[:, None]
        scale = _column_scale(np.linalg.norm(Aw, axis=0))
        # Full V when there are fewer rows than unknowns, so that Vt[rank:] spans the whole null
        # space.
        U, s_val, Vt = np.linalg.svd(Aw / scale, full_matrices=n < p)
        yw = y * w
    if s_val.size == 0 or s_val[0] == 0:
        raise IdentifiabilityError("the design matrix is zero: the data determine nothing")
    rank = int(np.sum(s_val > rcond * s_val[0]))
    Ur, sr, Vr = U[:, :rank], s_val[:rank], Vt[:rank].T
    z = Vr @ ((Ur.T @ yw) / sr)
    x = z / scale
    residuals = y - A @ x
    dof = n - rank
    if sigma is None:
        if dof <= 0:
            raise IdentifiabilityError(
                f"{n} observations leave no degree of freedom to estimate the noise "
                f"({rank} independent unknowns); add positions or samples, or give the noise level"
            )
        sigma0 = float(np.sqrt(np.sum(residuals**2) / dof))
    else:
        sigma0 = 1.0
    cov_z = (Vr / sr**2) @ Vr.T * sigma0**2
    cov = cov_z / scale[:, None] / scale[None, :]
    # Null space in the original coordinates: x = z / scale, so null vectors are V_null / scale.
    null_z = Vt[rank:].T
    if null_z.shape[1]:
        q, _ = np.linalg.qr(null_z / scale[:, None])
        null = q
    else:
        null = np.zeros((p, 0))
    return LinearFit(
        x=x,
        covariance=cov,
        residuals=residuals,
        sigma=sigma0,
        sigma_from_residuals=sigma is None,
        dof=dof,
        rank=rank,
        null_space=null,
        singular_values=s_val,
    )


def _column_scale(norms: NDArray[np.float64]) -> NDArray[np.float64]:
    """Column scale of the weighted design: its column norms, zero columns at a typical scale.

    An all-zero column is a null direction whatever its scale; it gets the geometric mean of
    the others so that mapping the null space back (divide by scale, orthonormalise) does not
    mix vectors of sizes 1 and 1/|w| and lose digits (heavily weighted rows, e.g. run means).
    """
    nonzero = norms[norms > 0]
    typical = float(np.exp(np.mean(np.log(nonzero)))) if nonzero.size else 1.0
    return np.where(norms > 0, norms, typical)


def _scaled_r_factor(
    A: NDArray[np.float64], y: NDArray[np.float64], sigma: NDArray[np.float64] | None,
    block: int = _BLOCK_ROWS,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Blocked (TSQR) R factor of the weighted ``[A y]``, column-scaled.

    Householder QR of ``[R_prev; next block]`` block after block gives the R of the whole
    weighted design (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 5.2.2 and 5.5;
    Demmel et al., SIAM J. Sci. Comput. 34(1), 2012, doi:10.1137/080731992), so that only one
    block and a ``(p+1, p+1)`` triangle are held: ``A_w = Q R`` and ``Q' y_w = qy``. The column
    norms of ``A_w`` are those of ``R`` (Q is orthonormal), and QR commutes with column scaling:
    ``A_w / scale = Q (R / scale)``.

    Returns
    -------
    Rs : ndarray, shape (p, p)
        ``R / scale``.
    qy : ndarray, shape (p,)
        ``Q' y_w``.
    scale : ndarray, shape (p,)
        Column scale (:func:`_column_scale` of the column norms of ``A_w``).

    Raises
    ------
    InputError
        ``A`` or ``y`` hold NaN or inf.
    """
    n, p = A.shape
    R = np.zeros((0, p + 1))
    for start in range(0, n, block):
        stop = min(start + block, n)
        a, b = A[start:stop], y[start:stop]
        if not (np.isfinite(a).all() and np.isfinite(b).all()):
            raise InputError("design or observations contain NaN or inf")
        m = R.shape[0]
        work = np.empty((m + stop - start, p + 1))
        work[:m] = R
        if sigma is None:
            work[m:, :p] = a
            work[m:, p] = b
        else:
            w = 1.0 / sigma[start:stop]
            np.multiply(a, w[:, None], out=work[m:, :p])
            np.multiply(b, w, out=work[m:, p])
        R = np.asarray(np.linalg.qr(work, mode="r"))
    scale = _column_scale(np.linalg.norm(R[:, :p], axis=0))
    return R[:p, :p] / scale, R[:p, p].copy(), scale


def identifiable_combinations(
    null_space: ArrayLike,
    candidates: Sequence[int],
    *,
    pivot_order: Sequence[int] | None = None,
    tol: float = 1e-9,
) -> NDArray[np.float64]:
    """Basis of identifiable linear combinations supported on ``candidates``.

    Parameters
    ----------
    null_space : array_like, shape (p, k)
        Orthonormal null-space basis of the design (:attr:`LinearFit.null_space`).
    candidates : sequence of int
        Indices of the coefficients that are not individually identifiable.
    pivot_order : sequence of int, optional
        Order in which the candidates are preferred as leading terms (default: as given). The
        result is the reduced row-echelon form in this order, so the first combinations lead with
        the first names, and the last names appear as the other terms.
    tol : float
        Entries below this are set to zero.

    Returns
    -------
    ndarray, shape (m, p)
        Rows ``c`` with ``c . x`` identifiable, zero outside ``candidates``, the leading term 1.
        ``m = len(candidates) - rank(null_space restricted to candidates)``.
    """
    N = np.asarray(null_space, dtype=float)
    p = N.shape[0]
    order = list(pivot_order) if pivot_order is not None else list(candidates)
    if sorted(order) != sorted(candidates):
        raise InputError("pivot_order must be a permutation of candidates")
    if not order:
        return np.zeros((0, p))
    Nc = N[order, :]
    # Orthogonal complement of the null space within the candidate coordinates.
    if Nc.shape[1]:
        u, s, _ = np.linalg.svd(Nc, full_matrices=True)
        r = int(np.sum(s > 1e-10))
        comp = u[:, r:].T
    else:
        comp = np.eye(len(order))
    rows = _rref(comp, tol)
    out = np.zeros((rows.shape[0], p))
    out[:, order] = rows
    out[np.abs(out) < tol] = 0.0
    return out


def _rref(M: NDArray[np.float64], tol: float) -> NDArray[np.float64]:
    """Reduced row-echelon form with partial pivoting; zero rows dropped."""
    R = M.astype(float).copy()
    rows, cols = R.shape
    lead = 0
    for c in range(cols):
        if lead >= rows:
            break
        piv = lead + int(np.argmax(np.abs(R[lead:, c])))
        if abs(R[piv, c]) <= tol:
            continue
        R[[lead, piv]] = R[[piv, lead]]
        R[lead] /= R[lead, c]
        for r in range(rows):
            if r != lead:
                R[r] -= R[r, c] * R[lead]
        lead += 1
    return R[:lead]
