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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import DIRECTIONS_ENU, Site, earth_rate_enu, specific_force_enu
from inertest.equipment.directions import triad_axes
from inertest.equipment.motion import Inputs, StaticPositions
from inertest.equipment.type_b import TypeBSource, tilt_rotation, type_b_error
from inertest.errors import InputError
from inertest.units import DEG_TO_RAD

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
    return triad_axes(letters, axes="".join(AXES), what=f'attitude "{"".join(letters)}"').T


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


class TurnProfile(Protocol):
    """Angle history of one turn: what :class:`Turns` and :func:`rotation_earth_angle` need.

    :class:`RotationProfile` (trapezoid in rate) and
    :class:`inertest.equipment.ferraris_session.RaisedCosineProfile` implement it.
    """

    @property
    def angle_rad(self) -> float:
        """Total rotation angle [rad] (signed by the profile's own convention, > 0 here)."""
        ...

    @property
    def duration_s(self) -> float:
        """Time from start to stop [s]."""
        ...

    def angle(self, t: ArrayLike) -> NDArray[np.float64]:
        """Angle turned at time ``t`` after the start [rad]."""
        ...

    def rate(self, t: ArrayLike) -> NDArray[np.float64]:
        """Rate at time ``t`` after the start [rad/s]."""
        ...

    def quadrature(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Nodes [s] and weights [s] integrating smooth functions of the angle over the turn."""
        ...


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
    profile: TurnProfile,
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
    profile: TurnProfile,
    window_s: float,
    latitude_rad: float,
) -> NDArray[np.float64]:
    """Integral of the true body rate over a rotation's window [rad], shape (3,).

    ``direction * angle e_j`` (the table) plus :func:`rotation_earth_angle` (the Earth).
    """
    out = rotation_earth_angle(C_nb0, axis, direction, profile, window_s, latitude_rad)
    out[axis] += direction * profile.angle_rad
    return out


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
    profile: TurnProfile
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


def _check_attitude(C: ArrayLike, what: str) -> NDArray[np.float64]:
    m = np.asarray(C, dtype=float)
    if m.shape != (3, 3) or not np.allclose(m.T @ m, np.eye(3), atol=1e-9) or (
            np.linalg.det(m) < 0):
        raise InputError(f"{what} must be a right-handed rotation matrix (3, 3)")
    return m


def _frame_with_x_along(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """A right-handed ``C_ni`` whose first axis (x, or an SDF gyro's I) is ``a``."""
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    y = np.cross(a, helper)
    y /= np.linalg.norm(y)
    return np.column_stack([a, y, np.cross(a, y)])


def rate_label(rate_rad_s: float) -> str:
    """Segment label of a constant table rate: ``"rate 10 deg/s"``."""
    return f"rate {rate_rad_s / DEG_TO_RAD:.9g} deg/s"


#: Type-B errors a rate table at constant rates accepts (:mod:`inertest.equipment.type_b`),
#: applied by :meth:`ConstantRates.inputs_at_rate`.
TYPE_B: tuple[TypeBSource, ...] = (
    TypeBSource("rate", "1", "rate accuracy: every table rate scaled by (1 + error)"),
    TypeBSource("tilt", "rad", "table axis alignment: axis and instrument tilted together"),
)


@dataclass(frozen=True)
class ConstantRates:
    """A single-axis rate table at constant rates: a :class:`~inertest.equipment.motion.Motion`.

    Each segment is one commanded rate ``w`` [rad/s] about the fixed ENU table axis ``a``,
    starting (``t = 0``) with the instrument in attitude ``C_ni0``::

        C_ni(t) = R_a(w t) C_ni0                 (right-handed about a, in ENU)
        omega_i = C_ni(t)^T (w a + W_ie_n)       (table rate plus Earth rate)
        f_i     = C_ni(t)^T (0, 0, g)            (at rest on the table: +g along up)

    Attributes
    ----------
    site : Site
    axis_enu : ndarray, shape (3,)
        Table axis (unit vector, ENU; :func:`direction_vector`).
    rates_rad_s : tuple of float
        Commanded rates [rad/s], signed; segment labels by :func:`rate_label`.
    C_ni0 : ndarray (3, 3) or None
        Instrument attitude at ``t = 0``; default: instrument x (an SDF gyro's input axis I)
        along the table axis.
    type_b : mapping of str to float
        The table's Type-B errors [SI] (:data:`TYPE_B`: rate scale, axis tilt); empty for the
        nominal table.
    """

    site: Site
    axis_enu: NDArray[np.float64]
    rates_rad_s: tuple[float, ...]
    C_ni0: NDArray[np.float64] | None = None
    type_b: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        a = direction_vector(tuple(np.asarray(self.axis_enu, dtype=float)))
        object.__setattr__(self, "axis_enu", a)
        c0 = _frame_with_x_along(a) if self.C_ni0 is None else _check_attitude(
            self.C_ni0, "rate-table start attitude C_ni0")
        object.__setattr__(self, "C_ni0", c0)
        rates = tuple(float(r) for r in self.rates_rad_s)
        if not rates or not np.all(np.isfinite(rates)):
            raise InputError("rate table needs at least one finite rate [rad/s]")
        object.__setattr__(self, "rates_rad_s", rates)

    @property
    def segments(self) -> tuple[str, ...]:
        """One label per distinct rate, in plan order."""
        return tuple(dict.fromkeys(rate_label(r) for r in self.rates_rad_s))

    def rate_of(self, segment: str) -> float:
        """Table rate of a segment [rad/s]."""
        for r in self.rates_rad_s:
            if rate_label(r) == segment:
                return r
        raise InputError(f"unknown rate-table segment {segment!r}; the plan has "
                         f"{', '.join(self.segments)}")

    def inputs(self, segment: str, t: ArrayLike = 0.0) -> Inputs:
        """Inputs at times ``t`` [s] since the segment's start, one row per element of ``t``."""
        return self.inputs_at_rate(self.rate_of(segment), t)

    def inputs_at_rate(self, rate_rad_s: float, t: ArrayLike = 0.0) -> Inputs:
        """Inputs at table rate ``rate_rad_s`` [rad/s] and times ``t`` [s]."""
        tt = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
        # Type-B errors (zero on the nominal table): rate scale, the axis tilted with the mount.
        rate_rad_s = rate_rad_s * (1.0 + type_b_error(self.type_b, "rate"))
        tilt = tilt_rotation(type_b_error(self.type_b, "tilt"), self.axis_enu)
        axis = tilt @ self.axis_enu
        C0 = tilt @ np.asarray(self.C_ni0, dtype=float)
        R = Rotation.from_rotvec(np.outer(rate_rad_s * tt, axis)).as_matrix()
        C = R @ C0
        w_n = rate_rad_s * axis + earth_rate_enu(self.site.latitude_rad)
        f_n = specific_force_enu(self.site.gravity_m_s2)
        return Inputs(C, np.einsum("kji,j->ki", C, w_n), np.einsum("kji,j->ki", C, f_n))


@dataclass(frozen=True)
class Turns:
    """Whole turns of a triad about its body axes: a :class:`~inertest.equipment.motion.Motion`.

    Each segment is one turn (:class:`TableTurn`): at rest in ``C_nb0`` for ``start_s``, then
    a turn about body axis ``j`` by ``direction * profile.angle_rad`` following ``profile``
    (trapezoid :class:`RotationProfile` or the raised cosine of a hand-made Ferraris turn),
    then at rest in the end attitude::

        C_ni(t) = C_nb0 R_j(direction theta(t - start_s))
        omega_i = direction theta_dot e_j + C_ni(t)^T W_ie_n
        f_i     = C_ni(t)^T (0, 0, g)

    Attributes
    ----------
    site : Site
    starts : mapping of str to (ndarray (3, 3), int, int)
        Per segment label: start attitude ``C_nb0``, body axis (0, 1, 2), direction (+1, -1).
    profile : TurnProfile
    start_s : float
        Rest before each turn [s].
    """

    site: Site
    starts: Mapping[str, tuple[NDArray[np.float64], int, int]]
    profile: TurnProfile
    start_s: float = 0.0

    def __post_init__(self) -> None:
        for label, (C0, axis, direction) in self.starts.items():
            _check_attitude(C0, f"start attitude of turn {label!r}")
            if axis not in (0, 1, 2) or direction not in (1, -1):
                raise InputError(f"turn {label!r}: axis must be 0, 1 or 2 and direction +1 or -1"
                                 f", got {axis!r}, {direction!r}")

    @property
    def segments(self) -> tuple[str, ...]:
        """Turn labels in plan order."""
        return tuple(self.starts)

    def turn(self, segment: str) -> TableTurn:
        """The :class:`TableTurn` of a segment."""
        try:
            C0, axis, direction = self.starts[segment]
        except KeyError:
            raise InputError(f"unknown turn {segment!r}; the plan has "
                             f"{', '.join(self.segments)}") from None
        return TableTurn(np.asarray(C0, dtype=float), axis, direction, self.profile,
                         self.site.latitude_rad, self.start_s)

    def inputs(self, segment: str, t: ArrayLike = 0.0) -> Inputs:
        """Inputs at times ``t`` [s] since the segment's start (rest, turn, rest)."""
        tt = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
        tr = self.turn(segment)
        C = tr.attitude(tt).as_matrix()
        f = np.einsum("kji,j->ki", C, specific_force_enu(self.site.gravity_m_s2))
        return Inputs(C, tr.body_rate(tt), f)

    def body_angle(self, segment: str, window_s: float) -> NDArray[np.float64]:
        """Integral of ``omega_i`` over a window of ``window_s`` [s] holding the turn [rad], (3,).

        :func:`body_angle`: the table angle ``direction * angle_rad e_j`` plus the Earth-rate
        angle by Gauss-Legendre over the profile's phases (exact to rounding for a smooth
        integrand), independent of where the rest lies in the window.
        """
        tr = self.turn(segment)
        return body_angle(tr.C_nb0, tr.axis, tr.direction, self.profile, window_s,
                          self.site.latitude_rad)


#: The ``axis`` of a counting window in which the table holds the triad still.
STATIC = "static"


@dataclass(frozen=True)
class TurnTable:
    """A two-axis table that turns a triad through whole turns about its body axes.

    The 360-degree rotation test (seed ``003_f374f866dfe7c99f.txt``) counts each gyro over a
    window holding one whole turn (:class:`Turns`) or over a static window in one attitude.

    Attributes
    ----------
    site : Site
    profile : TurnProfile
        The table's rotation profile (:class:`RotationProfile`).
    """

    site: Site
    profile: TurnProfile

    def window_angle(self, attitude: str, axis: str, direction: float, window_s: float
                     ) -> NDArray[np.float64]:
        """Integral of the body rate over a counting window [rad], shape (3,).

        Parameters
        ----------
        attitude : str
            Start attitude, direction letters of x, y, z (``"UEN"``, :func:`triad_attitude`).
        axis : str
            Body axis turned about (``"x"``, ``"y"``, ``"z"``), or :data:`STATIC`.
        direction : float
            +1 or -1 (the sense of the turn about ``axis``); 0 for a static window.
        window_s : float
            Window length [s].

        Returns
        -------
        ndarray, shape (3,)
            A turn: the table angle plus the Earth-rate angle of the profile
            (:meth:`Turns.body_angle`); static: the Earth rate times the window.
        """
        C = triad_attitude(attitude)
        if axis == STATIC:
            rest = StaticPositions({attitude: C}, self.site)
            return rest.inputs(attitude).omega_i[0] * window_s
        turns = Turns(self.site, {"turn": (C, axis_index(axis), int(direction))}, self.profile)
        return turns.body_angle("turn", window_s)
