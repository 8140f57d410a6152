"""An independent simulator of a strapdown IMU turned on a two-axis table (for the tests).

Written apart from :mod:`inertest.procedures.systematic` and the modules it uses (no import of
inertest's turn sequence, IMU model or navigation): the physics directly.

* Kinematics: the unit rests, then turns about its own axes (the table's inner axis carries
  it) with a *trapezoidal* rate profile (constant angular acceleration over ``ramp_s``, then a
  constant rate), at a site with the Earth turning: ``C_nb(t) = C_k R_j(theta(t))``,
  ``w_b = theta' e_j + C_bn W_ie``, ``dw_b = theta'' e_j - theta' e_j x (C_bn W_ie)``,
  ``f_b = C_bn (0, 0, g)`` at the table's centre.
* Gyro: ``raw = S_g w + b_g``. Accelerometer i sits at ``r_i`` (body axes) and reads the specific
  force *there*, ``f + dw x r_i + w x (w x r_i)``, along its own sensitive axis (row i of
  ``I + M_a``), with a second-order term ``k2_i u_i^2`` and its scale factor and bias, sampled
  ``tau`` seconds *late* (a true delay of the accelerometer's integration window, not a first-
  order model of it).
* Increments: 4-point Gauss-Legendre over each sample's window of those rates.
* Noise: white (angle / velocity random walk densities) and a random walk of every bias
  (rate random walk densities), one draw per sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

OMEGA = 7.2921151467e-5  # rad/s
DEG = np.pi / 180


@dataclass(frozen=True)
class Truth:
    """The simulated unit (SI): forward matrices, biases, second order, positions, delay."""

    S_g: np.ndarray
    b_g: np.ndarray
    S_a: np.ndarray
    b_a: np.ndarray
    k2: np.ndarray
    r: np.ndarray          # rows: position of the x, y, z accelerometer [m]
    tau: float             # accelerometer delay [s]


def profile(t, angle, duration, ramp):
    """Angle, rate, acceleration of a trapezoidal turn at times t after its start."""
    w = angle / (duration - ramp)
    a = w / ramp
    t = np.clip(t, 0.0, duration)
    up = np.minimum(t, ramp)
    flat = np.clip(t - ramp, 0.0, duration - 2 * ramp)
    down = np.clip(t - (duration - ramp), 0.0, ramp)
    theta = 0.5 * a * up**2 + w * flat + w * down - 0.5 * a * down**2
    rate = np.where(t < ramp, a * t, np.where(t > duration - ramp, a * (duration - t), w))
    acc = np.where(t < ramp, a, np.where(t > duration - ramp, -a, 0.0))
    inside = (t > 0) & (t < duration)
    return theta, rate * inside, acc * inside


class Sequence:
    """Rest ``first_s``; then for each (axis, angle) a turn of ``turn_s`` and a rest ``dwell_s``."""

    def __init__(self, C0, turns, *, first_s, dwell_s, turn_s, ramp_s, latitude_deg, gravity):
        self.C0 = np.asarray(C0, dtype=float)
        self.turns = list(turns)
        self.first_s, self.dwell_s, self.turn_s, self.ramp_s = first_s, dwell_s, turn_s, ramp_s
        lat = latitude_deg * DEG
        self.w_ie = OMEGA * np.array([0.0, np.cos(lat), np.sin(lat)])
        self.g = gravity
        self.starts = first_s + np.arange(len(self.turns)) * (turn_s + dwell_s)
        self.duration = first_s + len(self.turns) * (turn_s + dwell_s)
        att = [self.C0]
        for axis, ang in self.turns:
            att.append(att[-1] @ Rotation.from_rotvec(np.eye(3)[axis] * ang).as_matrix())
        self.attitudes = np.array(att)

    def motion(self, t):
        """C_nb (n, 3, 3), w_b, dw_b, f_b (n, 3) at times t."""
        t = np.asarray(t, dtype=float)
        k = np.searchsorted(self.starts, t, side="right") - 1
        C = self.attitudes[np.maximum(k, 0)].copy()
        w_turn = np.zeros((t.size, 3))
        a_turn = np.zeros((t.size, 3))
        for j, (axis, ang) in enumerate(self.turns):
            sel = k == j
            if not sel.any():
                continue
            th, rt, ac = profile(t[sel] - self.starts[j], ang, self.turn_s, self.ramp_s)
            C[sel] = C[sel] @ Rotation.from_rotvec(np.outer(th, np.eye(3)[axis])).as_matrix()
            w_turn[sel, axis] = rt
            a_turn[sel, axis] = ac
        Cbn = np.transpose(C, (0, 2, 1))
        we = Cbn @ self.w_ie
        w = w_turn + we
        dw = a_turn - np.cross(w_turn, we)
        f = Cbn @ np.array([0.0, 0.0, self.g])
        return C, w, dw, f


def increments(seq: Sequence, truth: Truth, rate_hz: float):
    """Noise-free raw increments (n, 3) of the gyros [rad] and accelerometers [m/s]."""
    dt = 1.0 / rate_hz
    n = int(round(seq.duration * rate_hz))
    x, wq = np.polynomial.legendre.leggauss(4)
    s = (np.arange(n)[:, None] + 0.5 * (x[None, :] + 1)) * dt  # nodes in each window
    _, w, _, _ = seq.motion(s.ravel())
    gyr = w @ truth.S_g.T + truth.b_g
    _, w2, dw2, f2 = seq.motion(s.ravel() - truth.tau)  # the accelerometers, late
    # accelerometer i: the specific force at its own position along its own axis (row i of
    # S_a over its scale factor)
    K = np.diag(truth.S_a)
    axes = truth.S_a / K[:, None]
    u = np.empty_like(f2)
    for i in range(3):
        fi = f2 + np.cross(dw2, truth.r[i]) + np.cross(w2, np.cross(w2, truth.r[i]))
        u[:, i] = fi @ axes[i]
    acc = K * (u + truth.k2 * u**2) + truth.b_a
    dth = (gyr.reshape(n, 4, 3) * wq[None, :, None]).sum(axis=1) * dt / 2
    dv = (acc.reshape(n, 4, 3) * wq[None, :, None]).sum(axis=1) * dt / 2
    return dth, dv


def add_noise(dth, dv, rate_hz, rng, *, arw, vrw, rrw_g=0.0, rrw_a=0.0):
    """White noise (densities ``arw`` [rad/sqrt(s)], ``vrw`` [m/s/sqrt(s)]) and bias random walks
    (``rrw_g`` [rad/s/sqrt(s)], ``rrw_a`` [m/s^2/sqrt(s)]) added to the increments."""
    dt = 1.0 / rate_hz
    n = dth.shape[0]
    out_g = dth + rng.normal(0.0, arw * np.sqrt(dt), (n, 3))
    out_a = dv + rng.normal(0.0, vrw * np.sqrt(dt), (n, 3))
    if rrw_g:
        out_g += np.cumsum(rng.normal(0.0, rrw_g * np.sqrt(dt), (n, 3)), axis=0) * dt
    if rrw_a:
        out_a += np.cumsum(rng.normal(0.0, rrw_a * np.sqrt(dt), (n, 3)), axis=0) * dt
    return out_g, out_a


def columns(dth, dv, rate_hz):
    """The increment columns the systematic procedure reads."""
    n = dth.shape[0]
    d = {"t_s": (np.arange(n) + 1) / rate_hz}
    for k, a in enumerate("xyz"):
        d[f"dtheta_{a}"] = dth[:, k]
    for k, a in enumerate("xyz"):
        d[f"dv_{a}"] = dv[:, k]
    return d
