"""Static-base strapdown navigation and its error sensitivities: navigation-mode observations.

A unit at rest on a table at a fixed site, turned between dwells, navigates in the local-level
frame n = ENU with its position held fixed (PSINS ``kf/sysclbt.m``). The *pseudo-velocity*

    u(t) = int_0^t (C_nb f_b + g_n) dt,        g_n = (0, 0, -g)

is zero at every instant the unit is at rest when its rates and specific forces are right, so
its value during the dwells is the observation of a navigation-mode calibration. (It is the
velocity without the Coriolis and transport terms, as PSINS computes it; with the position
fixed they are not part of the error dynamics.)

Algorithms
----------
Attitude ``C_nb(t_k) = E(t_k) C_nb0 B_k``: ``E(t) = exp(-[W_ie x] t)`` turns the local frame
with the Earth, ``B_k = R(phi_1) ... R(phi_k)`` the body increments with the two-sample coning
term ``phi_k = dtheta_k + dtheta_{k-1} x dtheta_k / 12`` (Savage, *Strapdown Analytics*, 2nd ed.,
eq. 7.1.1.1-11), products by a parallel prefix scan (17 passes for 1e5 samples) of unit
quaternions in :class:`scipy.spatial.transform.Rotation`'s order (scalar last), multiplied as
arrays (the Hamilton product; ``Rotation.__mul__`` costs 50 ms per pass at 1e5 rotations).

Velocity increments are resolved at the start of the sample with the rotation compensation to
second order, ``dv + dtheta x dv / 2 + dtheta x (dtheta x dv) / 12`` (the series of
``int R(alpha(s)) f_b ds`` for a body turning at a constant rate while the specific force is
fixed in the local frame, as on a table at rest, where there is no vibration for a sculling
term), and the local frame at the sample's middle. On a simulated 20 Hz sequence with turns of
30 deg/s (increments integrated exactly) the pseudo-velocity stays within 4e-7 m/s; the
first-order compensation alone leaves 8e-3 m/s.

Sensitivities (first order; PSINS's error model ``Ft`` with the position fixed)::

    phi' = -W_ie x phi - C_nb dw,       u' = f_n x phi + C_nb df,        f_n = (0, 0, g)

for rate errors ``dw`` and specific-force errors ``df`` on the body axes. The attitude equation
is solved exactly, ``phi(t) = -E(t) int_0^t C_ib dw ds`` with ``C_ib = C_nb0 B`` (the body in
the local frame of the start, fixed in inertial space), and everything is summed over blocks of
``m`` samples (``E`` constant within a block; the sum of the cumulative sum within a block is
the weighted sum ``sum_i x_i (m - pos_i - 1/2)``, a sample's own rotation counting half), so
one parameter costs a few operations per block, and the observations are taken at block ends.

Noise: white rate and specific-force noise, and per-block (slow) bias processes
(:mod:`inertest.estimation.noise_models`), propagated to the observations through the same
equations (the Earth-rate coupling of ``phi``, 7 % of the attitude error after 1000 s and
0.5 % of its variance, is left out of the noise propagation only).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import earth_rate_enu
from inertest.errors import InputError
from inertest.estimation.noise_models import MODELS, check_bias_time_scale, flicker_row_covariance


def quaternion_product(p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product ``p q`` of quaternions stored as rows ``(x, y, z, w)``: shape (4, ...).

    Scalar last, as :meth:`scipy.spatial.transform.Rotation.as_quat` (transposed): the
    quaternion of ``Rotation.from_quat(p.T) * Rotation.from_quat(q.T)``.
    """
    px, py, pz, pw = p
    qx, qy, qz, qw = q
    return np.stack([pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw,
                     pw * qw - px * qx - py * qy - pz * qz])


def cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``a x b`` row by row for (n, 3) arrays (``np.cross`` without its dispatch)."""
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def cumulative_quaternions(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Prefix products ``q_1, q_1 q_2, ..., q_1 ... q_n`` of (4, n) quaternions (prefix scan)."""
    q = q.copy()
    n = q.shape[1]
    shift = 1
    while shift < n:
        q[:, shift:] = quaternion_product(q[:, :-shift], q[:, shift:])
        shift *= 2
    return q


def cumulative_rotation(increments: Rotation) -> Rotation:
    """``R_1, R_1 R_2, ..., R_1 ... R_n`` by a parallel prefix scan (log2 n compositions)."""
    return Rotation.from_quat(cumulative_quaternions(increments.as_quat().T).T)


def _previous(x: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.empty_like(x)
    out[0] = 0.0
    out[1:] = x[:-1]
    return out


@dataclass(frozen=True)
class Navigation:
    """A static-base navigation run over a record.

    Attributes
    ----------
    u : ndarray, shape (nb, 3)
        Pseudo-velocity at the end of each block [m/s], ENU.
    C_ib : ndarray, shape (n, 3, 3)
        Body to the local frame of the start (inertially fixed) at the middle of each sample
        (the first-order rotation compensation of the increments, for the sensitivities).
    E : ndarray, shape (nb, 3, 3)
        Rotation of the local frame since the start at each block's middle (``exp(-[W x] t)``).
    dt_s : float
        Sample interval [s].
    block : int
        Samples per block ``m``.
    gravity_m_s2 : float
    w_ie : ndarray, shape (3,)
        Earth rate in ENU at the site [rad/s].
    """

    u: NDArray[np.float64]
    C_ib: NDArray[np.float64]
    E: NDArray[np.float64]
    dt_s: float
    block: int
    gravity_m_s2: float
    w_ie: NDArray[np.float64]

    @property
    def n_blocks(self) -> int:
        """Number of whole blocks ``nb``."""
        return int(self.u.shape[0])

    @property
    def C_nb(self) -> NDArray[np.float64]:
        """Body to ENU at the middle of each sample of the whole blocks (n, 3, 3)."""
        E = np.repeat(self.E, self.block, axis=0)
        return np.asarray(E @ self.C_ib[:E.shape[0]])


def navigate(omega: ArrayLike, force: ArrayLike, dt_s: float, C_nb0: ArrayLike, *,
             latitude_rad: float, gravity_m_s2: float, block: int) -> Navigation:
    """Navigate a static-base record in the local-level frame (module docstring).

    Parameters
    ----------
    omega, force : array_like, shape (n, 3)
        Calibrated rates [rad/s] and specific forces [m/s^2], one row per sample interval.
    dt_s : float
        Sample interval [s].
    C_nb0 : array_like, shape (3, 3)
        Attitude at the start (body to ENU).
    latitude_rad, gravity_m_s2 : float
        The site.
    block : int
        Samples per block (observations at block ends).

    Returns
    -------
    Navigation
    """
    w = np.asarray(omega, dtype=float)
    f = np.asarray(force, dtype=float)
    n = w.shape[0]
    if block < 1 or n < block:
        raise InputError(f"navigation needs at least one block of {block} samples, got {n}")
    dth = w * dt_s
    dv = f * dt_s
    prev = _previous(dth)
    phi = dth + cross(prev, dth) / 12.0
    body = cumulative_quaternions(Rotation.from_rotvec(phi).as_quat().T)
    c0 = Rotation.from_matrix(np.asarray(C_nb0, dtype=float)).as_quat()[:, None]
    start_q = np.concatenate([c0, quaternion_product(c0, body[:, :-1])], axis=1)
    start = Rotation.from_quat(start_q.T)  # C_ib at the start of each sample
    half = Rotation.from_rotvec(0.5 * dth).as_quat().T
    mid = Rotation.from_quat(quaternion_product(start_q, half).T)  # ... at its middle
    rot = cross(dth, dv)
    dv_rot = dv + 0.5 * rot + cross(dth, rot) / 12.0
    w_ie = earth_rate_enu(latitude_rad)
    t_mid = (np.arange(n) + 0.5) * dt_s
    dv_i = start.apply(dv_rot)
    dv_n = Rotation.from_rotvec(-np.outer(t_mid, w_ie)).apply(dv_i)
    nb = n // block
    u = np.cumsum(dv_n[:nb * block].reshape(nb, block, 3).sum(axis=1), axis=0)
    t_end = (np.arange(nb) + 1) * block * dt_s
    u[:, 2] -= gravity_m_s2 * t_end
    t_blk = (np.arange(nb) + 0.5) * block * dt_s
    return Navigation(u=u, C_ib=mid.as_matrix(),
                      E=Rotation.from_rotvec(-np.outer(t_blk, w_ie)).as_matrix(), dt_s=dt_s,
                      block=block, gravity_m_s2=gravity_m_s2, w_ie=w_ie)


def _skew(v: Sequence[float]) -> NDArray[np.float64]:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def block_moments(nav: Navigation, series: ArrayLike, *, weighted: bool
                  ) -> NDArray[np.float64]:
    """Per block, ``sum_j C_ib,j s_j dt`` for each scalar series ``s`` (nb, K, 3, 3).

    With ``weighted`` each sample is weighted by ``m - pos - 1/2`` (``pos`` its place in the
    block): how many of the block's samples its rotation turns, the later ones fully and its
    own by half (the velocity increment of a sample is resolved at its middle).
    """
    s = np.asarray(series, dtype=float)
    if s.ndim == 1:
        s = s[:, None]
    m, nb = nav.block, nav.n_blocks
    C = nav.C_ib[:nb * m].reshape(nb, m, 3, 3)
    sb = s[:nb * m].reshape(nb, m, -1) * nav.dt_s
    if weighted:
        sb = sb * (m - np.arange(m) - 0.5)[None, :, None]
    return np.asarray(np.einsum("bmij,bmk->bkij", C, sb, optimize=True))


@dataclass(frozen=True)
class ErrorInputs:
    """Rate and specific-force errors of a set of parameters, per block.

    Attributes
    ----------
    gyro_sum, gyro_weighted : ndarray, shape (nb, 3, P)
        ``sum_j C_ib,j dw_j dt`` and the same weighted by ``m - pos - 1/2`` (inertial-fixed
        frame; :func:`block_moments`).
    accel_sum : ndarray, shape (nb, 3, P)
        ``sum_j C_ib,j df_j dt``.
    """

    gyro_sum: NDArray[np.float64]
    gyro_weighted: NDArray[np.float64]
    accel_sum: NDArray[np.float64]


def propagate(nav: Navigation, inputs: ErrorInputs) -> NDArray[np.float64]:
    """Pseudo-velocity errors at every block end, shape (nb, 3, P) (module docstring)."""
    m, dt = nav.block, nav.dt_s
    psi_end = np.cumsum(inputs.gyro_sum, axis=0)
    psi_sum = inputs.gyro_weighted.copy()
    psi_sum[1:] += m * psi_end[:-1]
    phi_sum = -(nav.E @ psi_sum)
    du = nav.E @ inputs.accel_sum
    g = nav.gravity_m_s2 * dt  # f_n x phi with f_n = (0, 0, g): (-g phi_N, g phi_E, 0)
    du[:, 0] -= g * phi_sum[:, 1]
    du[:, 1] += g * phi_sum[:, 0]
    return np.asarray(np.cumsum(du, axis=0))


def attitude_sensitivity(nav: Navigation) -> NDArray[np.float64]:
    """Pseudo-velocity errors (nb, 3, 3) of a rotation ``delta`` of the initial attitude.

    ``C_nb0 -> R(delta) C_nb0`` makes ``phi = -E delta``; column j for ``delta = e_j``.
    """
    F = _skew([0.0, 0.0, nav.gravity_m_s2])
    per = -nav.block * nav.dt_s * np.einsum("ij,bjk->bki", F, nav.E)  # (nb, j, i)
    return np.asarray(np.cumsum(per, axis=0))


# --- noise ------------------------------------------------------------------------------------

#: Channels of an IMU's noise: three gyros, then three accelerometers.
CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z")


def white_covariance(nav: Navigation, blocks: ArrayLike, variance: ArrayLike
                     ) -> NDArray[np.float64]:
    """Covariance of the pseudo-velocity at the ends of ``blocks`` under white sensor noise.

    Parameters
    ----------
    nav : Navigation
    blocks : array_like of int, shape (k,)
        Block indices of the observations, increasing.
    variance : array_like, shape (6,)
        Variance per sample of each channel's rate [(rad/s)^2] or specific force
        [(m/s^2)^2] (:data:`CHANNELS`).

    Returns
    -------
    ndarray, shape (3k, 3k)
        Rows ``3 i + axis`` (E, N, U of observation i).

    Notes
    -----
    Exact sums over the samples: an accelerometer error ``df_i`` adds ``C_nb,i df_i dt`` to
    every later ``u``; a rate error ``dw_i`` adds ``-F C_nb,i dw_i dt^2 (o - i + 1/2)`` to ``u``
    at the end of sample o (its own sample's increment resolved at its middle), so the
    covariance needs the moments ``sum i^q c c^T`` (q = 0, 1, 2) of each channel's direction
    ``c`` (the column of ``C_nb``) up to the earlier observation.
    """
    b = np.asarray(blocks, dtype=np.intp)
    var = np.asarray(variance, dtype=float)
    m, dt, nb = nav.block, nav.dt_s, nav.n_blocks
    k = b.size
    Cn = nav.C_nb.reshape(nb, m, 3, 3)
    idx = (np.arange(nb * m, dtype=float)).reshape(nb, m)
    o = (b + 1) * m - 1.0  # sample index of each observation's end
    hi_a, hi_b = np.meshgrid(o, o, indexing="ij")
    later = np.minimum.outer(b, b)
    F = _skew([0.0, 0.0, nav.gravity_m_s2])
    out = np.zeros((k, k, 3, 3))
    for ch in range(6):
        if var[ch] == 0:
            continue
        c = Cn[:, :, :, ch % 3]  # (nb, m, 3)
        cc = np.einsum("bmi,bmj->bmij", c, c)
        if ch >= 3:
            P0 = np.cumsum(cc.sum(axis=1), axis=0)[later]
            out += var[ch] * dt**2 * P0
            continue
        moments = [np.cumsum(np.einsum("bmij,bm->bij", cc, idx**q), axis=0)[later]
                   for q in range(3)]
        S = ((hi_a + 0.5) * (hi_b + 0.5))[..., None, None] * moments[0] - (
            hi_a + hi_b + 1.0)[..., None, None] * moments[1] + moments[2]
        out += var[ch] * dt**4 * np.einsum("ij,abjk,lk->abil", F, S, F)
    return np.asarray(out.transpose(0, 2, 1, 3).reshape(3 * k, 3 * k))


def block_responses(nav: Navigation, blocks: ArrayLike) -> NDArray[np.float64]:
    """Response of the observations to a unit error held over each block (6, 3k, nb).

    Row ``3 i + axis`` of channel ``ch``: the pseudo-velocity at the end of observation block i
    per unit rate [rad/s] (gyros) or specific force [m/s^2] (accelerometers) of that channel
    over block j (zero for blocks after the observation).
    """
    b = np.asarray(blocks, dtype=np.intp)
    m, dt, nb = nav.block, nav.dt_s, nav.n_blocks
    Cn = nav.C_nb.reshape(nb, m, 3, 3)
    idx = np.arange(nb * m, dtype=float).reshape(nb, m)
    S0 = Cn.sum(axis=1)  # (nb, 3, 3): [axis, channel]
    S1 = np.einsum("bmij,bm->bij", Cn, idx)
    o = (b + 1) * m - 1.0
    before = (np.arange(nb)[None, :] <= b[:, None]).astype(float)  # (k, nb)
    F = _skew([0.0, 0.0, nav.gravity_m_s2])
    out = np.zeros((6, 3 * b.size, nb))
    for ch in range(3):
        g = (o[:, None, None] + 0.5) * S0[None, :, :, ch] - S1[None, :, :, ch]  # (k, nb, 3)
        resp = -dt**2 * np.einsum("ij,kbj->kib", F, g) * before[:, None, :]
        out[ch] = resp.reshape(3 * b.size, nb)
        acc = dt * np.transpose(S0[:, :, ch])[None, :, :] * before[:, None, :]  # (k, 3, nb)
        out[3 + ch] = acc.reshape(3 * b.size, nb)
    return out


def correlated_covariance(responses: NDArray[np.float64], model: str, level: ArrayLike, *,
                          block_s: float, bias_time_scale: float = 2.0
                          ) -> NDArray[np.float64]:
    """Covariance of the observations under a slow bias process on each channel.

    Parameters
    ----------
    responses : ndarray, shape (6, 3k, nb)
        :func:`block_responses`.
    model : {"random-walk", "flicker"}
        :mod:`inertest.estimation.noise_models`' model of the bias over the blocks.
    level : array_like, shape (6,)
        Per channel: the rate random walk density ``K`` [unit/s/sqrt(s)]: the bias wanders
        with variance ``K^2 t`` (IEEE Std 952-1997 Annex C ``sigma_A = K sqrt(tau/3)``); or the
        bias instability ``B`` [unit/s]: flicker with one-sided PSD ``B^2 / (pi f)``, the
        Allan floor ``0.664 B`` (IEEE 952 C.1).
    block_s : float
        Block length [s].
    bias_time_scale : float
        Of the flicker model (test durations).
    """
    lv = np.asarray(level, dtype=float)
    _, rows, nb = responses.shape
    out = np.zeros((rows, rows))
    noise = MODELS[model]
    for ch in range(6):
        if lv[ch] == 0:
            continue
        L = responses[ch]
        if model == "random-walk":
            # Cov of block means = K^2 h (min(i, j) + 1): unit steps per block, scaled
            KL = noise.row_apply(L.T.copy()) * lv[ch] ** 2 * block_s
        elif model == "flicker":
            s = check_bias_time_scale(bias_time_scale)
            c0 = float(flicker_row_covariance(nb, s)[0])
            KL = noise.row_apply(L.T.copy(), bias_time_scale=s) * lv[ch] ** 2 / np.pi * c0
        else:
            raise InputError(f"no bias process {model!r}; use random-walk or flicker")
        out += L @ KL
    return 0.5 * (out + out.T)
