"""Rate table and two-axis turntable: axis orientation, Earth rate on the axes, rotation histories.

Frames: local level ENU (x east, y north, z up). A triad's attitude is ``C_nb`` (maps body
vectors to ENU; its columns are the triad's x, y, z axes in ENU), given in plans and data as three
direction letters for x, y, z (E, W, N, S, U, D; S = south), e.g. ``"ENU"`` (z up) or ``"UEN"``
(x up). A single-axis rate table turns about a fixed axis ``a`` (a unit ENU vector, or a letter);
a positive table rate turns right-handed about ``a``.

On a two-axis turntable (seed ``003_f374f866dfe7c99f.txt``, sec. 1.2) the outer axis sets one of
the triad's axes along the inner (rotation) axis, and the inner axis turns the triad through
exactly 360 deg about that body axis. While it turns, the triad's body rate is the table rate
along the axis plus the Earth rate, ``w_b(t) = theta_dot e_j + C_bn(t) W_ie_n``, with
``C_nb(t) = C_nb0 R_j(theta(t))`` (the body turns about its own axis ``j``).

Rotation profile: trapezoidal in rate (constant angular acceleration ``alpha`` up to the rate
``w``, then constant rate, then constant deceleration) or, with ``alpha = None``, a constant rate
from start to stop. The counting window of a rotation may be longer than the rotation; the rest of
the window is spent at rest in the start (= end) attitude.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import DIRECTIONS_ENU, earth_rate_enu
from inertest.errors import InputError

AXES = ("x", "y", "z")
#: Gauss-Legendre nodes per profile phase for the Earth-rate integral (the integrand is smooth).
_GL_NODES = 48


def direction_vector(spec: str | Sequence[float]) -> NDArray[np.float64]:
    """Unit ENU vector of a table axis given as a letter (E, W, N, S, U, D) or three numbers."""
    if isinstance(spec, str):
        key = spec.strip().upper()
        if key not in DIRECTIONS_ENU:
            raise InputError(
                f'table axis "{spec}" is not one of E, W, N, S, U, D (S = south) or an ENU vector'
            )
        return DIRECTIONS_ENU[key].copy()
    try:
        v = np.asarray(spec, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"table axis {spec!r} must be a letter or three numbers (ENU)") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) == 0:
        raise InputError(f"table axis {spec!r} must be a non-zero ENU vector of three numbers")
    return v / np.linalg.norm(v)


def earth_rate_along(axis_enu: ArrayLike, latitude_rad: float) -> float:
    """Earth rate along a fixed ENU axis [rad/s]: ``a . (0, W cos L, W sin L)``."""
    return float(np.asarray(axis_enu, dtype=float) @ earth_rate_enu(latitude_rad))


def triad_attitude(directions: str | Sequence[str]) -> NDArray[np.float64]:
    """``C_nb`` of a triad whose x, y, z axes point along three local directions.

    Parameters
    ----------
    directions : str or sequence of 3 str
        Letters for x, y, z, e.g. ``"ENU"`` or ``["E", "N", "U"]``.

    Returns
    -------
    ndarray, shape (3, 3)
        Columns: the triad's x, y, z axes in ENU.

    Raises
    ------
    InputError
        Unknown letter, axes not perpendicular, or a left-handed triad (with the fix).
    """
    letters = [str(c).strip().upper() for c in directions]
    if len(letters) != 3:
        raise InputError(
            f"attitude {directions!r} must give three directions for x, y, z, e.g. \"ENU\""
        )
    for axis, d in zip(AXES, letters, strict=True):
        if d not in DIRECTIONS_ENU:
            raise InputError(
                f'{axis} axis direction "{d}" in attitude "{"".join(letters)}" is not one of '
                "E, W, N, S, U, D (S = south)"
            )
    x, y, z = (DIRECTIONS_ENU[d] for d in letters)
    label = "".join(letters)
    if abs(x @ y) > 0.5 or abs(y @ z) > 0.5 or abs(z @ x) > 0.5:
        raise InputError(
            f'attitude "{label}" is not an orthogonal triad: x, y, z must point along different '
            "axes of E/W, N/S, U/D"
        )
    if np.cross(x, y) @ z < 0:
        raise InputError(
            f'attitude "{label}" is left-handed; with x={letters[0]}, y={letters[1]} the z axis '
            f"points {_letter(np.cross(x, y))}"
        )
    return np.column_stack([x, y, z])


def _letter(v: NDArray[np.float64]) -> str:
    return next(k for k, u in DIRECTIONS_ENU.items() if u @ v > 0.5)


def axis_index(axis: str) -> int:
    """0, 1, 2 for ``"x"``, ``"y"``, ``"z"`` (case-insensitive)."""
    key = str(axis).strip().lower()
    if key not in AXES:
        raise InputError(f'rotation axis "{axis}" is not one of x, y, z')
    return AXES.index(key)


def vertical_axis(C_nb: NDArray[np.float64]) -> int | None:
    """Index of the triad axis that is vertical (up or down) in attitude ``C_nb``, if any."""
    up = np.abs(C_nb[2])
    j = int(np.argmax(up))
    return j if up[j] > 1 - 1e-9 else None


@dataclass(frozen=True)
class RotationProfile:
    """Angle history of one table rotation through ``angle_rad`` (default 360 deg).

    Attributes
    ----------
    rate_rad_s : float
        Constant (plateau) table rate magnitude [rad/s], > 0.
    accel_rad_s2 : float or None
        Angular acceleration and deceleration magnitude [rad/s^2]; None: the rate starts and
        stops at once.
    angle_rad : float
        Total rotation angle [rad], > 0.
    """

    rate_rad_s: float
    accel_rad_s2: float | None = None
    angle_rad: float = 2 * np.pi

    def __post_init__(self) -> None:
        if not np.isfinite(self.rate_rad_s) or self.rate_rad_s <= 0:
            raise InputError(f"table rate must be positive, got {self.rate_rad_s} rad/s")
        if self.accel_rad_s2 is not None and (
            not np.isfinite(self.accel_rad_s2) or self.accel_rad_s2 <= 0
        ):
            raise InputError(f"table acceleration must be positive, got {self.accel_rad_s2}")
        if not np.isfinite(self.angle_rad) or self.angle_rad <= 0:
            raise InputError(f"rotation angle must be positive, got {self.angle_rad} rad")

    @property
    def _phases(self) -> tuple[float, float, float]:
        """(acceleration time, plateau time, peak rate) [s, s, rad/s]."""
        w, a, th = self.rate_rad_s, self.accel_rad_s2, self.angle_rad
        if a is None:
            return 0.0, th / w, w
        if w * w / a >= th:  # triangular profile: the plateau rate is never reached
            peak = float(np.sqrt(a * th))
            return peak / a, 0.0, peak
        return w / a, th / w - w / a, w

    @property
    def duration_s(self) -> float:
        """Time from start to stop [s]."""
        ta, tc, _ = self._phases
        return 2 * ta + tc

    def angle(self, t: ArrayLike) -> NDArray[np.float64]:
        """Rotation angle at time ``t`` after the start [rad] (0 before, ``angle_rad`` after)."""
        tt: NDArray[np.float64] = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        ta, tc, w = self._phases
        if ta == 0.0:
            return w * tt
        a = w / ta
        up = 0.5 * a * np.minimum(tt, ta) ** 2
        flat = w * np.clip(tt - ta, 0.0, tc)
        td = np.clip(tt - ta - tc, 0.0, ta)
        down = w * td - 0.5 * a * td**2
        return up + flat + down

    def rate(self, t: ArrayLike) -> NDArray[np.float64]:
        """Table rate magnitude at time ``t`` [rad/s]."""
        t = np.asarray(t, dtype=float)
        ta, tc, w = self._phases
        inside = (t >= 0) & (t <= self.duration_s)
        if ta == 0.0:
            return np.where(inside, w, 0.0)
        a = w / ta
        r = np.minimum(np.minimum(a * t, w), a * (self.duration_s - t))
        return np.where(inside, np.clip(r, 0.0, None), 0.0)

    def quadrature(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gauss-Legendre nodes and weights over each phase of the rotation [s]."""
        ta, tc, _ = self._phases
        x, w = np.polynomial.legendre.leggauss(_GL_NODES)
        nodes, weights = [], []
        start = 0.0
        for length in (ta, tc, ta):
            if length > 0:
                nodes.append(start + 0.5 * length * (x + 1))
                weights.append(0.5 * length * w)
            start += length
        return np.concatenate(nodes), np.concatenate(weights)


def turn(axis: int, angle_rad: ArrayLike) -> Rotation:
    """Right-handed rotation(s) by ``angle_rad`` about body axis ``axis`` (0, 1, 2)."""
    ang = np.atleast_1d(np.asarray(angle_rad, dtype=float))
    rv = np.zeros((ang.size, 3))
    rv[:, axis] = ang
    return Rotation.from_rotvec(rv)


def rotation_earth_angle(
    C_nb0: ArrayLike,
    axis: int,
    direction: int,
    profile: RotationProfile,
    window_s: float,
    latitude_rad: float,
) -> NDArray[np.float64]:
    """Earth-rate angle on the triad's axes over the counting window of one rotation [rad].

    Parameters
    ----------
    C_nb0 : array_like, shape (3, 3)
        Attitude at the start (and, after a whole turn, the end) of the rotation.
    axis : int
        Body axis turned about (0, 1, 2 for x, y, z).
    direction : int
        +1 (right-handed about the body axis) or -1.
    profile : RotationProfile
    window_s : float
        Counting window [s], at least the rotation time; the rest is at rest in the start attitude.
    latitude_rad : float

    Returns
    -------
    ndarray, shape (3,)
        ``int_window C_bn(t) W_ie_n dt`` on the body axes [rad].

    Notes
    -----
    The component along the rotation axis is ``(e_j . C_bn0 W_ie_n) * window`` exactly. The
    perpendicular part turns with the table; for a constant-rate whole turn it averages to zero
    over the rotation, leaving only the at-rest part of the window.
    """
    C0 = np.asarray(C_nb0, dtype=float)
    if window_s < profile.duration_s * (1 - 1e-12):
        raise InputError(
            f"counting window {window_s:g} s is shorter than the rotation time "
            f"{profile.duration_s:g} s; the window must contain the whole rotation"
        )
    w_b0 = C0.T @ earth_rate_enu(latitude_rad)
    t, wq = profile.quadrature()
    turned = turn(axis, direction * profile.angle(t)).inv().apply(w_b0)  # C_bn(t) W_ie_n
    return wq @ turned + w_b0 * (window_s - profile.duration_s)


def body_angle(
    C_nb0: ArrayLike,
    axis: int,
    direction: int,
    profile: RotationProfile,
    window_s: float,
    latitude_rad: float,
) -> NDArray[np.float64]:
    """Integral of the true body rate over a rotation's window [rad], shape (3,).

    ``direction * angle e_j`` (the table) plus :func:`rotation_earth_angle` (the Earth).
    """
    out = rotation_earth_angle(C_nb0, axis, direction, profile, window_s, latitude_rad)
    out[axis] += direction * profile.angle_rad
    return out


def static_body_angle(C_nb: ArrayLike, window_s: float, latitude_rad: float) -> NDArray[np.float64]:
    """Earth-rate angle on the triad's axes over ``window_s`` at rest in attitude ``C_nb`` [rad]."""
    return np.asarray(C_nb, dtype=float).T @ earth_rate_enu(latitude_rad) * float(window_s)


def attitude_history(
    C_nb0: ArrayLike, axis: int, direction: int, angle_rad: ArrayLike
) -> Rotation:
    """``C_nb(t) = C_nb0 R_j(direction * theta(t))`` for table angles ``theta`` [rad]."""
    return Rotation.from_matrix(np.asarray(C_nb0, dtype=float)) * turn(
        axis, direction * np.asarray(angle_rad, dtype=float)
    )


@dataclass(frozen=True)
class TableTurn:
    """One turn of a triad about its body axis on a two-axis table, as a time-varying frame.

    Attributes
    ----------
    C_nb0 : ndarray, shape (3, 3)
        Attitude at the start of the turn.
    axis : int
        Body axis turned about (0, 1, 2).
    direction : int
        +1 or -1.
    profile : RotationProfile
    latitude_rad : float
    start_s : float
        Time the turn starts [s] (at rest in ``C_nb0`` before, and after the turn).
    """

    C_nb0: NDArray[np.float64]
    axis: int
    direction: int
    profile: RotationProfile
    latitude_rad: float
    start_s: float = 0.0

    def angle(self, t: ArrayLike) -> NDArray[np.float64]:
        """Signed table angle at time ``t`` [rad]."""
        return self.direction * self.profile.angle(np.asarray(t, dtype=float) - self.start_s)

    def attitude(self, t: ArrayLike) -> Rotation:
        """``C_nb(t)`` (local level, Earth-fixed)."""
        return attitude_history(self.C_nb0, self.axis, 1, self.angle(t))

    def body_rate(self, t: ArrayLike) -> NDArray[np.float64]:
        """True body rate ``theta_dot e_j + C_bn(t) W_ie_n`` [rad/s], shape (n, 3)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = self.attitude(t).inv().apply(earth_rate_enu(self.latitude_rad))
        w[:, self.axis] += self.direction * self.profile.rate(t - self.start_s)
        return w
