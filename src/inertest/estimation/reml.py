"""REML estimation of a noise model's variance component, and GLS under it.

The unit means (or window counts) of a test have covariance ``s2 (W + theta K)``: ``W`` the
white noise (diagonal), ``K`` the kernel of a correlated component
(:mod:`inertest.estimation.noise_models`). ``theta`` (and ``s2`` when the white level is not
known) maximise the restricted likelihood (Patterson & Thompson, Biometrika 58(3), 1971,
doi:10.1093/biomet/58.3.545); the coefficients then come from generalised least squares.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from inertest.estimation.least_squares import LinearFit, weighted_least_squares


@dataclass(frozen=True)
class Reml:
    """REML criterion on the unit means (Patterson & Thompson, Biometrika 58(3), 1971).

    The covariance of the unit means is ``s2 * (W + theta K)`` with ``W`` diagonal (white
    noise) and ``K`` a component; ``s2 = 1`` when the white level is known, else profiled out.
    One eigendecomposition of ``W^-1/2 K W^-1/2`` makes every evaluation cheap.
    """

    y: NDArray[np.float64]      # the unit means (or window counts)
    basis: NDArray[np.float64]  # orthonormal basis of the column space of the unit design
    white: NDArray[np.float64]  # diagonal of W
    scale_known: bool

    @classmethod
    def of(cls, A: ArrayLike, y: ArrayLike, white: ArrayLike, *, scale_known: bool,
           rank: int | None = None) -> Reml:
        """The criterion of unit design ``A`` (G, p), values ``y`` and white variances ``white``.

        ``rank``: of the design (default: numerical rank); the basis is its leading left
        singular vectors, columns scaled to unit norm first.
        """
        A = np.asarray(A, dtype=float)
        norm = np.linalg.norm(A, axis=0)
        Xs = A / np.where(norm > 0, norm, 1.0)
        U, sv, _ = np.linalg.svd(Xs, full_matrices=False)
        if rank is None:
            rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size and sv[0] > 0 else 0
        return cls(np.asarray(y, dtype=float), U[:, :rank],
                   np.asarray(white, dtype=float), scale_known)

    @property
    def size(self) -> int:
        """Number of units."""
        return int(self.y.size)

    @property
    def dof(self) -> int:
        """Units less the rank of the design."""
        return self.size - self.basis.shape[1]

    def criterion(
        self, K: NDArray[np.float64] | None
    ) -> Callable[[float], tuple[float, float]]:
        """``theta -> (negative restricted log-likelihood, scale s2)`` for component ``K``."""
        sw = np.sqrt(self.white)
        if K is None:
            lam, Xt, yt = np.zeros(self.size), self.basis / sw[:, None], self.y / sw
        else:
            lam, Qe = np.linalg.eigh(K / np.outer(sw, sw))
            lam = np.clip(lam, 0.0, None)
            Xt, yt = Qe.T @ (self.basis / sw[:, None]), Qe.T @ (self.y / sw)
        logdet_w = float(np.sum(np.log(self.white)))
        dof = self.dof

        def nll(theta: float) -> tuple[float, float]:
            d = 1.0 + theta * lam
            sd = np.sqrt(d)
            q, r = np.linalg.qr(Xt / sd[:, None])
            yw = yt / sd
            res = yw - q @ (q.T @ yw)
            rss = float(res @ res)
            logdet = logdet_w + float(np.sum(np.log(d))) + 2 * float(
                np.sum(np.log(np.abs(np.diag(r)))))
            if self.scale_known:
                return 0.5 * (logdet + rss), 1.0
            s2 = max(rss / dof, 1e-300)
            return 0.5 * (logdet + dof * np.log(s2) + dof), s2

        return nll

    def fit(self, K: NDArray[np.float64], ref: float) -> tuple[float, float]:
        """``theta >= 0`` minimising the criterion (grid, then Brent), and the minimum."""
        nll = self.criterion(K)
        # Up to 1e8 x the white variance of a unit mean: long units (a centrifuge run of
        # thousands of samples) make even modest offsets that many times larger.
        grid = ref * np.logspace(-4, 8, 25)
        vals = [nll(t)[0] for t in grid]
        i = int(np.argmin(vals))
        best_t, best = float(grid[i]), float(vals[i])
        lo, hi = np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, grid.size - 1)])
        opt_x, opt_fun = bounded_minimum(lambda lt: nll(float(np.exp(lt)))[0], lo, hi,
                                          xatol=1e-3)
        if opt_fun < best:
            best_t, best = float(np.exp(opt_x)), float(opt_fun)
        zero = nll(0.0)[0]
        return (0.0, zero) if zero <= best else (best_t, best)


def bounded_minimum(
    func: Callable[[float], float], lo: float, hi: float, *, xatol: float, maxiter: int = 500,
) -> tuple[float, float]:
    """Minimum of ``func`` on ``[lo, hi]``: Brent's golden-section search with parabolic steps.

    The algorithm of ``scipy.optimize.minimize_scalar(method="bounded")`` (``fminbound``:
    Forsythe, Malcolm & Moler, *Computer Methods for Mathematical Computations*, Prentice-Hall
    1977; Brent, *Algorithms for Minimization Without Derivatives*, 1973), transcribed step for
    step from SciPy 1.17 (BSD-3-Clause) so that the same iterates give the same numbers (tested)
    without importing scipy.optimize (~0.1 s of every fit's start-up). Returns ``(x, f(x))``.
    """
    sqrt_eps = np.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - np.sqrt(5.0))
    a, b = lo, hi
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = func(x)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while np.abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = True
        if np.abs(e) > tol1:  # try a parabola through the three best points
            golden = False
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = np.abs(q)
            r = e
            e = rat
            if (np.abs(p) < np.abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
                rat = (p + 0.0) / q
                x = xf + rat
                if ((x - a) < tol2) or ((b - x) < tol2):
                    rat = tol1 * (np.sign(xm - xf) + ((xm - xf) == 0))
            else:
                golden = True
        if golden:
            e = a - xf if xf >= xm else b - xf
            rat = golden_mean * e
        x = xf + (np.sign(rat) + (rat == 0)) * np.maximum(np.abs(rat), tol1)
        fu = func(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return float(xf), float(fx)


@dataclass(frozen=True)
class Component:
    """A candidate noise model fitted by REML.

    Attributes
    ----------
    aic : float
        ``2 nll`` (white) or ``2 nll + 2`` (one component) of the restricted likelihood.
    theta : float
        Component variance per unit of ``W``'s scale (0 for white).
    kernel : ndarray or None
        The component's kernel scaled to mean diagonal 1; None for white noise.
    kernel_scale : float
        Mean diagonal of the kernel as given (the component's size per unit of variance).
    """

    aic: float
    theta: float
    kernel: NDArray[np.float64] | None
    kernel_scale: float

    def fitted(self, reml: Reml) -> tuple[float, NDArray[np.float64]]:
        """``s2`` at the fitted ``theta`` and the covariance ``s2 (W + theta K)`` of the units.

        ``s2`` is 1 when the white level is known (then ``W`` holds it).
        """
        if self.kernel is None:
            s2 = reml.criterion(None)(0.0)[1]
            return s2, np.diag(s2 * reml.white)
        s2 = reml.criterion(self.kernel)(self.theta)[1]
        return s2, s2 * (np.diag(reml.white) + self.theta * self.kernel)

    def level(self, s2: float) -> float:
        """Standard deviation of the component per unit of the kernel as given."""
        return float(np.sqrt(s2 * self.theta / self.kernel_scale))


def components(reml: Reml, kernels: Mapping[str, Callable[[], NDArray[np.float64]]], *,
               with_white: bool) -> dict[str, Component]:
    """REML fit of each candidate component (and of white noise with ``with_white``).

    ``kernels``: by model name, the kernel of its component (built on demand). The grid of
    :meth:`Reml.fit` is scaled by the mean white variance when the white level is known.
    """
    ref = float(np.mean(reml.white)) if reml.scale_known else 1.0
    out: dict[str, Component] = {}
    if with_white:
        out["white"] = Component(2 * reml.criterion(None)(0.0)[0], 0.0, None, 1.0)
    for name, build in kernels.items():
        Kc = build()
        cc = float(np.mean(np.diag(Kc)))
        th, nll = reml.fit(Kc / cc, ref)
        out[name] = Component(2 * nll + 2, th, Kc / cc, cc)
    return out


def gls(A: ArrayLike, y: ArrayLike, V: NDArray[np.float64]) -> LinearFit:
    """Generalised least squares of ``y = A x`` with covariance ``V`` (whitened by Cholesky)."""
    L = np.linalg.cholesky(V)
    Aw = scipy.linalg.solve_triangular(L, np.asarray(A, dtype=float), lower=True)
    yw = scipy.linalg.solve_triangular(L, np.asarray(y, dtype=float), lower=True)
    return weighted_least_squares(Aw, yw, sigma=1.0)
