"""A turn sequence on a multi-axis table: dwells at rest joined by turns about body axes.

The systematic calibration of a strapdown IMU (:mod:`inertest.procedures.systematic`) turns the
unit through a sequence of attitudes (the 19-position scheme of Xie Bo, JCIT 2011; the
9-position scheme; continuous turns): the unit rests for ``first_dwell_s``, then each turn
rotates it by ``angle_rad`` about one of its own axes (a two- or three-axis table's inner axes
carry the unit, so the turn axis is fixed to the body, as in PSINS ``imu/attrottt.m``) over
``turn_s`` with the raised-cosine rate ``angle/T (1 - cos(2 pi t/T))``, and it rests for
``dwell_s`` before the next turn.

Kinematics at the site (local frame ENU, the unit's reference point at the table's centre)::

    C_nb(t) = C_k R_j(theta(t))          omega_b = theta' e_j + C_bn W_ie
    domega_b = theta'' e_j - theta' e_j x (C_bn W_ie)          f_b = C_bn (0, 0, g)

``C_k`` the attitude at the start of turn k; ``initial_attitude`` as PSINS gives it (pitch,
roll, yaw; ``C_nb = R_z(yaw) R_x(pitch) R_y(roll)``, yaw counter-clockwise from north).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site, earth_rate_enu, specific_force_enu
from inertest.errors import PlanError

AXES = ("x", "y", "z")


def parse_turn(text: str) -> tuple[int, int]:
    """``"+y"`` / ``"y"`` / ``"-x"`` -> (axis index, sign); anything else a PlanError."""
    s = str(text).strip().lower()
    sign = -1 if s.startswith("-") else 1
    body = s.lstrip("+-")
    if body not in AXES or len(s) - len(body) > 1:
        raise PlanError(f'turn "{text}" is not a body axis; write each turn as "+x", "-y", "z"'
                        " (right-handed about that axis of the unit)")
    return AXES.index(body), sign


def attitude_from_pitch_roll_yaw(pitch_roll_yaw_deg: Sequence[float]) -> NDArray[np.float64]:
    """``C_nb = R_z(yaw) R_x(pitch) R_y(roll)`` (PSINS ``a2mat``; ENU, angles in degrees)."""
    p, r, y = (float(v) for v in pitch_roll_yaw_deg)
    return np.asarray(Rotation.from_euler("ZXY", [y, p, r], degrees=True).as_matrix())


@dataclass(frozen=True)
class Turn:
    """One turn: ``angle_rad`` (signed, right-handed about body ``axis``) over ``duration_s``."""

    axis: int
    angle_rad: float
    duration_s: float

    def angle(self, tau: NDArray[np.float64]) -> NDArray[np.float64]:
        """Angle turned ``tau`` [s] after the start [rad] (raised-cosine rate)."""
        x = np.clip(tau, 0.0, self.duration_s) / self.duration_s
        return np.asarray(self.angle_rad * (x - np.sin(2 * np.pi * x) / (2 * np.pi)))

    def rate(self, tau: NDArray[np.float64]) -> NDArray[np.float64]:
        """Turn rate [rad/s]."""
        inside = (tau >= 0) & (tau <= self.duration_s)
        w = self.angle_rad / self.duration_s * (1 - np.cos(2 * np.pi * tau / self.duration_s))
        return np.asarray(np.where(inside, w, 0.0))

    def acceleration(self, tau: NDArray[np.float64]) -> NDArray[np.float64]:
        """Turn acceleration [rad/s^2]."""
        inside = (tau >= 0) & (tau <= self.duration_s)
        a = (self.angle_rad / self.duration_s * 2 * np.pi / self.duration_s
             * np.sin(2 * np.pi * tau / self.duration_s))
        return np.asarray(np.where(inside, a, 0.0))


@dataclass(frozen=True)
class Kinematics:
    """The unit's motion at ``n`` instants (body axes, SI).

    ``C_nb`` (n, 3, 3) body to ENU; ``omega`` inertial rate [rad/s]; ``domega`` its
    derivative [rad/s^2]; ``force`` specific force at the reference point [m/s^2].
    """

    C_nb: NDArray[np.float64]
    omega: NDArray[np.float64]
    domega: NDArray[np.float64]
    force: NDArray[np.float64]


@dataclass(frozen=True)
class TurnSequence:
    """Dwells and turns of a systematic calibration at a site (module docstring).

    Attributes
    ----------
    site : Site
    C_nb0 : ndarray, shape (3, 3)
        Attitude of the first dwell.
    turns : tuple of Turn
    first_dwell_s, dwell_s : float
        Time at rest before the first turn, and after each turn [s].
    """

    site: Site
    C_nb0: NDArray[np.float64]
    turns: tuple[Turn, ...]
    first_dwell_s: float
    dwell_s: float

    def __post_init__(self) -> None:
        if not self.turns:
            raise PlanError("a turn sequence needs at least one turn")
        if not (self.first_dwell_s > 0 and self.dwell_s > 0):
            raise PlanError("dwell times must be positive")

    @property
    def turn_starts_s(self) -> NDArray[np.float64]:
        """Start time of each turn [s]."""
        lengths = np.array([t.duration_s + self.dwell_s for t in self.turns])
        return np.asarray(self.first_dwell_s + np.concatenate([[0.0], np.cumsum(lengths)[:-1]]))

    @property
    def duration_s(self) -> float:
        """Whole sequence [s]."""
        return float(self.turn_starts_s[-1] + self.turns[-1].duration_s + self.dwell_s)

    def dwells(self) -> NDArray[np.float64]:
        """``[start, end]`` of each dwell [s], shape (turns + 1, 2)."""
        starts = self.turn_starts_s
        ends = starts + np.array([t.duration_s for t in self.turns])
        return np.column_stack([np.r_[0.0, ends], np.r_[starts, self.duration_s]])

    def dwell_attitudes(self) -> NDArray[np.float64]:
        """``C_nb`` of each dwell, shape (turns + 1, 3, 3)."""
        out = [np.asarray(self.C_nb0, dtype=float)]
        for t in self.turns:
            rv = np.zeros(3)
            rv[t.axis] = t.angle_rad
            out.append(out[-1] @ Rotation.from_rotvec(rv).as_matrix())
        return np.asarray(out)

    def kinematics(self, t: ArrayLike) -> Kinematics:
        """Attitude, rate, angular acceleration and specific force at times ``t`` [s]."""
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        starts = self.turn_starts_s
        k = np.searchsorted(starts, tt, side="right") - 1  # last turn started (-1: none)
        C_start = self.dwell_attitudes()
        C0 = C_start[np.clip(k, 0, None)]
        C0[k < 0] = C_start[0]
        n = tt.size
        angle = np.zeros(n)
        rate = np.zeros(n)
        accel = np.zeros(n)
        axis = np.zeros(n, dtype=np.intp)
        for j, turn in enumerate(self.turns):
            sel = k == j
            if not np.any(sel):
                continue
            tau = tt[sel] - starts[j]
            angle[sel] = turn.angle(tau)
            rate[sel] = turn.rate(tau)
            accel[sel] = turn.acceleration(tau)
            axis[sel] = turn.axis
        rv = np.zeros((n, 3))
        rv[np.arange(n), axis] = angle
        C = C0 @ Rotation.from_rotvec(rv).as_matrix()
        w_ie_b = np.einsum("nji,j->ni", C, earth_rate_enu(self.site.latitude_rad))
        e = np.zeros((n, 3))
        e[np.arange(n), axis] = 1.0
        omega = rate[:, None] * e + w_ie_b
        domega = accel[:, None] * e - rate[:, None] * np.cross(e, w_ie_b)
        force = np.einsum("nji,j->ni", C, specific_force_enu(self.site.gravity_m_s2))
        return Kinematics(C_nb=C, omega=omega, domega=domega, force=force)
