"""1-sigma growth of the static-base INS errors from random sensor noise (covariance propagation).

Random sources, continuous white noises with two-sided power spectral density ``N^2``
(IEEE Std 952-1997 annex C and IEEE Std 1293-1998 terminology):

* gyro angle random walk ``N_g`` [rad/sqrt(s)]: white noise added to the drift rates ``eE, eN,
  eU`` (gyro output errors, entering ``phi'`` with a minus sign as in
  :mod:`inertest.ins.error_model`; the sign does not change a covariance that starts
  uncorrelated);
* accelerometer velocity random walk ``N_a`` [m/s/sqrt(s)]: white noise added to ``bE, bN``;
* gyro rate random walk ``K_g`` [rad/s/sqrt(s)]: the drift itself is a random walk,
  ``d' = w``, ``E[w w'] = K_g^2 delta``; three extra states ``dE, dN, dU`` feed ``phiE, phiN,
  phiU`` like a constant drift does.

The augmented system ``z = [x (7), d (3)]``, ``z' = F z + G w`` is discretised exactly with
Van Loan's method (C. F. Van Loan, "Computing integrals involving the matrix exponential",
IEEE Trans. Autom. Control 23(3):395-404, 1978, doi:10.1109/TAC.1978.1101743)::

    expm([[-F, G Q G'], [0, F']] dt) = [[., Phi^-1 Qd], [0, Phi']]

and ``P(t + dt) = Phi P(t) Phi' + Qd``. On a uniform grid the same doubling as
:func:`inertest.ins.propagation.propagate_many` fills all samples with ``log2(n)``
batched products, each level with its own exponential, so there is no step-size error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.ins.error_model import InsSite, input_matrix, system_matrix

__all__ = ["CovarianceHistory", "RandomSources", "propagate_covariance"]

_NX = 7
_NZ = 10


@dataclass(frozen=True)
class RandomSources:
    """Noise densities of the random error sources, SI (zero = absent).

    Attributes
    ----------
    gyro_arw : float or array_like (3,)
        Angle random walk of the E, N, U gyros [rad/sqrt(s)].
    accel_vrw : float or array_like (2,)
        Velocity random walk of the E, N accelerometers [m/s/sqrt(s)].
    gyro_rrw : float or array_like (3,)
        Rate random walk of the E, N, U gyro drifts [rad/s/sqrt(s)].
    """

    gyro_arw: float | tuple[float, ...] = 0.0
    accel_vrw: float | tuple[float, ...] = 0.0
    gyro_rrw: float | tuple[float, ...] = 0.0

    def densities(self) -> NDArray[np.float64]:
        """``[vrwE, vrwN, arwE, arwN, arwU, rrwE, rrwN, rrwU]`` (8,), SI."""
        parts = []
        for name, value, n in (("accel_vrw", self.accel_vrw, 2), ("gyro_arw", self.gyro_arw, 3),
                               ("gyro_rrw", self.gyro_rrw, 3)):
            a = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 \
                else np.asarray(value, dtype=float)
            if a.shape != (n,) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise InputError(f"{name} must be a non-negative number or {n} of them, got "
                                 f"{value!r}")
            parts.append(a)
        return np.concatenate(parts)


@dataclass(frozen=True)
class CovarianceHistory:
    """Covariance of the errors over time.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Times [s].
    sigma : ndarray, shape (n, 7)
        1-sigma of ``[dVE, dVN, dL, dlambda, phiE, phiN, phiU]``, SI.
    covariance : ndarray, shape (n, 10, 10)
        Full covariance of ``[x (7), drift random walk dE, dN, dU]``, SI.
    """

    t: NDArray[np.float64]
    sigma: NDArray[np.float64]
    covariance: NDArray[np.float64]


def noise_model(site: InsSite) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``F`` (10x10) and ``G`` (10x8) of the augmented system driven by unit white noises."""
    f = np.zeros((_NZ, _NZ))
    f[:_NX, :_NX] = system_matrix(site)
    f[4:7, 7:10] = -np.eye(3)  # random-walk drift enters phi like a constant drift (sign -)
    g = np.zeros((_NZ, 8))
    g[:_NX, :5] = input_matrix()  # white noise on bE, bN, eE, eN, eU
    g[7:10, 5:8] = np.eye(3)  # drives the drift random walk
    return f, g


def propagate_covariance(
    site: InsSite,
    t: ArrayLike,
    sources: RandomSources,
    *,
    p0: ArrayLike | None = None,
) -> CovarianceHistory:
    """Exact covariance of the errors at times ``t`` under the random sources.

    Parameters
    ----------
    site : InsSite
        Linearisation point.
    t : array_like, shape (n,)
        Uniformly spaced times [s] from the start at ``t = 0`` (``t[0] >= 0``).
    sources : RandomSources
        Noise densities.
    p0 : array_like, shape (10, 10) or (7, 7), optional
        Initial covariance (SI); zero when omitted.

    Returns
    -------
    CovarianceHistory
    """
    tt = np.asarray(t, dtype=float)
    if tt.ndim != 1 or tt.size == 0 or not np.all(np.isfinite(tt)) or tt[0] < 0:
        raise InputError("times must be a non-empty 1-D array of finite times >= 0 [s]")
    n = tt.size
    dts = np.diff(tt)
    if n > 1 and (dts[0] <= 0 or np.any(np.abs(dts - dts[0]) > 1e-9 * dts[0])):
        raise InputError("covariance propagation needs uniformly increasing times; use a "
                         "regular grid (e.g. --step)")
    q = sources.densities() ** 2
    f, g = noise_model(site)
    # Balanced units (velocities over sqrt(g R)) keep the exponentials accurate.
    d = np.ones(_NZ)
    d[:2] = math.sqrt(site.gravity_m_s2 * site.radius_m)
    fb = f * d[None, :] / d[:, None]
    gqg = (g / d[:, None]) @ np.diag(q) @ (g / d[:, None]).T
    p_init = np.zeros((_NZ, _NZ))
    if p0 is not None:
        pa = np.asarray(p0, dtype=float)
        if pa.shape not in ((_NX, _NX), (_NZ, _NZ)) or not np.all(np.isfinite(pa)):
            raise InputError(f"p0 must be a finite (7, 7) or (10, 10) matrix, got {pa.shape}")
        p_init[:pa.shape[0], :pa.shape[0]] = pa
    p_init = p_init / np.outer(d, d)

    def steps(hs: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Van Loan: transitions and noise covariances over each interval in ``hs`` (batched)."""
        m = np.zeros((2 * _NZ, 2 * _NZ))
        m[:_NZ, :_NZ] = -fb
        m[:_NZ, _NZ:] = gqg
        m[_NZ:, _NZ:] = fb.T
        e = scipy.linalg.expm(m[None] * hs[:, None, None])
        phi = e[:, _NZ:, _NZ:].transpose(0, 2, 1)
        qd = phi @ e[:, :_NZ, _NZ:]
        return phi, 0.5 * (qd + qd.transpose(0, 2, 1))

    ps = np.empty((n, _NZ, _NZ))
    if tt[0] > 0:
        phi, qd = steps(tt[:1])
        ps[0] = phi[0] @ p_init @ phi[0].T + qd[0]
    else:
        ps[0] = p_init
    if n > 1:
        # P(t + p dt) = Phi_p P(t) Phi_p' + Qd_p fills samples p..2p-1 from 0..p-1 (doubling).
        levels = 1 << np.arange(int(n - 1).bit_length())
        phis, qds = steps(levels * dts[0])
        k = 1
        while k < n:
            phi, qd = phis[k.bit_length() - 1], qds[k.bit_length() - 1]
            m_ = min(k, n - k)
            ps[k:k + m_] = phi @ ps[:m_] @ phi.T + qd
            k += m_
    ps *= np.outer(d, d)[None]
    var = np.clip(np.diagonal(ps, axis1=1, axis2=2)[:, :_NX], 0.0, None)
    return CovarianceHistory(t=tt, sigma=np.sqrt(var), covariance=ps)
