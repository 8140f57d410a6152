"""An independent nonlinear strapdown navigator: the reference for the linear INS error model.

Written for the tests only; it shares no code with ``inertest.ins`` or
``inertest.studies.rotation_modulation``. Spherical rotating Earth of radius ``R`` with a
gravity vector of constant magnitude ``g`` along the local down (the plumb-bob gravity, so an
IMU at rest feels ``f^n = [0, 0, +g]``), Earth rate ``W`` about the polar axis.

Truth
    The IMU sits at latitude ``L0``, longitude 0, at rest on the Earth. Its body frame turns
    about the local up axis at the mount rate ``r``: ``C_b^n(t) = R_z(heading + r t)``. The
    body attitude in the inertial frame is ``C_b^i(t) = R_z(W t) C_n^e C_b^n(t)`` (ECEF ``e``
    and inertial ``i`` frames coincide at ``t = 0``; ``C_n^e`` has the ENU axes at ``L0`` as
    columns). Ideal gyro output over a step: the rotation vector of
    ``C_b^i(t_k)^T C_b^i(t_k+1)`` (exact incremental rotation, coning included); ideal
    accelerometer output: ``C_n^b(t_mid) f^n dt``.
Sensor errors (output errors, the package convention)
    ``gyro increment = alpha + eps dt + M_g alpha`` and ``accel increment = dv (1 + k_a) + b dt``:
    the drift ``eps``, bias ``b``, gyro matrix ``M_g`` (scale factors on the diagonal,
    misalignment off it) and accelerometer scale factors ``k_a`` add to the true outputs.
Navigator (computed ENU frame at the computed position)
    ``C <- R(-zeta) C R(alpha_out)`` with ``zeta = (w_ie^n + w_en^n) dt`` (rotations through
    :class:`scipy.spatial.transform.Rotation`); ``v <- v + C_mid dv_out + (g^n - (2 w_ie^n +
    w_en^n) x v) dt``; ``L <- L + v_N dt / R``, ``lambda <- lambda + v_E dt / (R cos L)``, with
    the transport rate ``w_en^n = (-v_N / R, v_E / R, v_E tan L / R)`` and midpoint values
    extrapolated from the two previous steps. The vertical channel is held at the truth
    (vertical velocity 0, as with an ideal height reference): the linear model has no vertical
    channel either.
Errors
    ``dV = v_computed - v_true``, ``dL``, ``dlambda`` likewise, and the attitude error ``phi``
    with ``C_b^n(computed) = (I - phi x) C_b^n(true)``, i.e.
    ``phi = -rotvec(C_computed C_true^T)``. The error-free run (case 0) is subtracted, which
    removes the (tiny) algorithm errors common to all cases.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class SensorErrors:
    """Output errors of the IMU in the body frame, SI."""

    gyro_drift: np.ndarray = field(default_factory=lambda: np.zeros(3))  # rad/s
    gyro_matrix: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # -
    accel_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))  # m/s^2
    accel_scale: np.ndarray = field(default_factory=lambda: np.zeros(3))  # -


def navigate(
    errors: list[SensorErrors],
    *,
    latitude_rad: float,
    radius_m: float,
    gravity_m_s2: float,
    earth_rate_rad_s: float,
    duration_s: float,
    dt_s: float,
    mount_rate_rad_s: float = 0.0,
    heading_rad: float = 0.0,
    every: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """Navigation errors of each error case (m, n, 7) at times t (n,), in the order
    ``[dVE, dVN, dL, dlambda, phiE, phiN, phiU]`` (m/s, m/s, rad x 5)."""
    lat0, rad, g, w = latitude_rad, radius_m, gravity_m_s2, earth_rate_rad_s
    n_steps = int(round(duration_s / dt_s))
    t = np.arange(n_steps + 1) * dt_s
    # ---- truth: body attitude in the inertial frame, exact increments
    sl, cl = math.sin(lat0), math.cos(lat0)
    c_ne = np.array([[0.0, -sl, cl], [1.0, 0.0, 0.0], [0.0, cl, sl]])  # columns E, N, U
    r_ne = Rotation.from_matrix(c_ne)
    r_bn = Rotation.from_rotvec(np.outer(heading_rad + mount_rate_rad_s * t, [0.0, 0.0, 1.0]))
    r_ei = Rotation.from_rotvec(np.outer(w * t, [0.0, 0.0, 1.0]))
    r_bi = r_ei * r_ne * r_bn
    alpha = (r_bi[:-1].inv() * r_bi[1:]).as_rotvec()  # (N, 3), body increments [rad]
    f_n = np.array([0.0, 0.0, g])
    t_mid = t[:-1] + 0.5 * dt_s
    r_bn_mid = Rotation.from_rotvec(np.outer(heading_rad + mount_rate_rad_s * t_mid,
                                             [0.0, 0.0, 1.0]))
    dv_b = r_bn_mid.inv().apply(f_n) * dt_s  # (N, 3) [m/s]
    # ---- outputs with errors: cases 0 (error-free) + the given ones
    cases = [SensorErrors(), *errors]
    m = len(cases)
    a_out = np.stack([alpha + e.gyro_drift * dt_s + alpha @ np.asarray(e.gyro_matrix).T
                      for e in cases], axis=1)  # (N, m, 3)
    dv_out = np.stack([dv_b * (1 + e.accel_scale) + e.accel_bias * dt_s for e in cases],
                      axis=1)
    body_step = Rotation.from_rotvec(a_out.reshape(-1, 3)).as_matrix().reshape(n_steps, m, 3, 3)
    body_half = Rotation.from_rotvec(a_out.reshape(-1, 3) / 2).as_matrix().reshape(
        n_steps, m, 3, 3)
    # ---- navigator
    c = np.broadcast_to(r_bn[0].as_matrix(), (m, 3, 3)).copy()
    v = np.zeros((m, 3))
    v_prev = v.copy()
    lat = np.full(m, lat0)
    lat_prev = lat.copy()
    lon = np.zeros(m)
    g_n = np.array([0.0, 0.0, -g])
    keep = np.arange(0, n_steps + 1, every)
    hist_c = np.empty((keep.size, m, 3, 3))
    hist_v = np.empty((keep.size, m, 3))
    hist_p = np.empty((keep.size, m, 2))
    j = 0
    for k in range(n_steps + 1):
        if k % every == 0:
            hist_c[j], hist_v[j], hist_p[j] = c, v, np.column_stack([lat, lon])
            j += 1
        if k == n_steps:
            break
        v_mid = 1.5 * v - 0.5 * v_prev
        lat_mid = 1.5 * lat - 0.5 * lat_prev
        w_ie = w * np.column_stack([np.zeros(m), np.cos(lat_mid), np.sin(lat_mid)])
        w_en = np.column_stack([-v_mid[:, 1] / rad, v_mid[:, 0] / rad,
                                v_mid[:, 0] * np.tan(lat_mid) / rad])
        zeta = (w_ie + w_en) * dt_s
        nav_step = Rotation.from_rotvec(-zeta).as_matrix()
        nav_half = Rotation.from_rotvec(-zeta / 2).as_matrix()
        c_mid = nav_half @ c @ body_half[k]
        c = nav_step @ c @ body_step[k]
        dv_n = np.einsum("mij,mj->mi", c_mid, dv_out[k])
        v_prev, lat_prev = v, lat
        v = v + dv_n + (g_n - np.cross(2 * w_ie + w_en, v_mid)) * dt_s
        v[:, 2] = 0.0  # vertical channel held at the truth
        lat = lat + v_mid[:, 1] / rad * dt_s
        lon = lon + v_mid[:, 0] / (rad * np.cos(lat_mid)) * dt_s
    # ---- errors relative to the error-free run
    out = np.empty((m - 1, keep.size, 7))
    ref_c = hist_c[:, 0]
    for i in range(1, m):
        out[i - 1, :, 0:2] = hist_v[:, i, :2] - hist_v[:, 0, :2]
        out[i - 1, :, 2:4] = hist_p[:, i] - hist_p[:, 0]
        rel = Rotation.from_matrix(hist_c[:, i] @ ref_c.transpose(0, 2, 1))
        out[i - 1, :, 4:7] = -rel.as_rotvec()
    return t[keep], out
