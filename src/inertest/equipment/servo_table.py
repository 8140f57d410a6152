"""Servo turntable: a single-axis table driven by the gyro's own output (long-term drift test).

Seed ``000_dad8be616c6569c7.txt`` (section on 转台伺服试验) and IEEE Std 517-1974, the classical
long-term drift test of a floated gyro: the gyro is mounted with its input axis I along the table
axis, and its output drives the table motor so that the output stays at null. The inertial rate
about I then cancels the drift, ``w_I + drift(f) = 0``, with ``w_I = (W + dtheta/dt a) . I``, so
the table angle runs at::

    dtheta/dt = -(W . a) - s * drift(f(theta))

with ``a`` the unit +table axis in ENU, ``W`` the Earth rate, ``s = +1`` when I points along
+a and ``-1`` along -a, and ``drift`` the SDF static drift model of
:mod:`inertest.models.sdf_gyro` (f in g0). The table simulates the azimuth or polar axis of a
platform INS: the encoder angle against time carries the drift.

Table axes (``table_axis``):

``polar``
    ``a = (0, cos L, sin L)`` in ENU, toward the north celestial pole; I senses the full Earth
    rate and O, S turn through the gravity component ``g cos L`` normal to the axis.
``vertical``
    ``a = (0, 0, 1)`` (up); O and S stay horizontal, so only ``fI = s g`` acts.

Mountings are named ``I<sign><O direction>[<S direction>]``: ``I+`` or ``I-`` for I along +a or
-a, then the direction of O at table angle 0. Polar table: ``H`` / ``L`` the direction normal to
the axis with the largest / smallest up component, ``(0, -sin L, cos L)`` and its negative, ``E``
/ ``W`` east / west. Vertical table: ``N``, ``S``, ``E``, ``W``. S = I x O (right-handed); an
optional third letter names S and is checked. The table angle theta is right-handed about +a and
cumulative (unwrapped); the instrument axes at theta are the axes at 0 rotated by theta about a.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from inertest.earth import Site, earth_rate_enu, polar_axis_enu
from inertest.equipment.motion import Inputs
from inertest.errors import InputError
from inertest.models.sdf_gyro import drift_regressors
from inertest.units import G0

#: Table axes a servo table may have.
TABLE_AXES: tuple[str, ...] = ("polar", "vertical")
#: Letters naming directions normal to the table axis, per table axis.
DIRECTIONS: dict[str, tuple[str, ...]] = {"polar": ("H", "L", "E", "W"),
                                          "vertical": ("N", "S", "E", "W")}
#: Relative and absolute tolerances of the servo-loop integration (angle in rad).
RTOL, ATOL = 1e-12, 1e-13

_LABEL = re.compile(r"^([A-Za-z])([+-])?([A-Za-z])?([A-Za-z])?$")


def axis_enu(table_axis: str, latitude_rad: float) -> NDArray[np.float64]:
    """Unit +table axis ``a`` in ENU: the north celestial pole (polar) or up (vertical)."""
    if table_axis == "polar":
        return polar_axis_enu(latitude_rad)
    if table_axis == "vertical":
        return np.array([0.0, 0.0, 1.0])
    raise InputError(f'unknown table_axis "{table_axis}"; use one of {", ".join(TABLE_AXES)}')


def direction_enu(letter: str, table_axis: str, latitude_rad: float) -> NDArray[np.float64]:
    """Unit vector of a direction letter normal to the table axis, in ENU."""
    sL, cL = np.sin(latitude_rad), np.cos(latitude_rad)
    table = {
        "polar": {"H": (0.0, -sL, cL), "L": (0.0, sL, -cL), "E": (1.0, 0.0, 0.0),
                  "W": (-1.0, 0.0, 0.0)},
        "vertical": {"N": (0.0, 1.0, 0.0), "S": (0.0, -1.0, 0.0), "E": (1.0, 0.0, 0.0),
                     "W": (-1.0, 0.0, 0.0)},
    }[table_axis]
    if letter not in table:
        raise InputError(
            f'direction "{letter}" is not normal to the {table_axis} table axis; use one of '
            f'{", ".join(table)}')
    return np.array(table[letter])


@dataclass(frozen=True)
class Mounting:
    """One mounting of the gyro on the servo table.

    Attributes
    ----------
    label : str
        ``I+H``, ``I-E``, ... (see the module docstring).
    sign : int
        ``+1`` when I points along +a, ``-1`` along -a.
    C_ni0 : ndarray, shape (3, 3)
        Instrument axes (I, O, S columns) in ENU at table angle 0.
    """

    label: str
    sign: int
    C_ni0: NDArray[np.float64] = field(repr=False)


def parse_mounting(label: str, table_axis: str, latitude_rad: float) -> Mounting:
    """Read a mounting label; one-line errors for I off the axis or a left-handed triad."""
    dirs = DIRECTIONS.get(table_axis)
    if dirs is None:
        raise InputError(f'unknown table_axis "{table_axis}"; use one of {", ".join(TABLE_AXES)}')
    m = _LABEL.match(str(label).strip())
    if m is None:
        raise InputError(
            f'mounting "{label}" is not of the form I<+|-><O direction>, e.g. "I+{dirs[0]}"')
    axis, sign, o_dir, s_dir = m.groups()
    if axis.upper() != "I":
        raise InputError(
            f'mounting "{label}" puts {axis.upper()} along the table axis; the servo test needs '
            f'the input axis I along it (I+{dirs[0]}, I-{dirs[0]}, ...)')
    if sign is None or o_dir is None:
        raise InputError(
            f'mounting "{label}" needs the sign of I and the direction of O, e.g. "I+{dirs[0]}"')
    o_dir = o_dir.upper()
    if o_dir not in dirs:
        raise InputError(
            f'mounting "{label}": O direction "{o_dir}" is not normal to the {table_axis} table '
            f'axis; use one of {", ".join(dirs)}')
    s = 1 if sign == "+" else -1
    i_enu = s * axis_enu(table_axis, latitude_rad)
    o_enu = direction_enu(o_dir, table_axis, latitude_rad)
    s_enu = np.cross(i_enu, o_enu)
    if s_dir is not None:
        s_dir = s_dir.upper()
        given = direction_enu(s_dir, table_axis, latitude_rad) if s_dir in dirs else None
        if given is None or not np.allclose(given, s_enu, atol=1e-9):
            right = next(d for d in dirs
                         if np.allclose(direction_enu(d, table_axis, latitude_rad), s_enu))
            raise InputError(
                f'mounting "{label}" is left-handed or inconsistent: with I{sign} and O to '
                f'{o_dir}, S = I x O points {right}; write "I{sign}{o_dir}{right}" or '
                f'"I{sign}{o_dir}"')
    return Mounting(f"I{sign}{o_dir}", s, np.column_stack([i_enu, o_enu, s_enu]))


@dataclass(frozen=True)
class ServoTable:
    """A servo table at a site, with its mountings: a :class:`~inertest.equipment.motion.Motion`.

    Segments are the mountings. Without a trajectory the table is taken to run as with a
    drift-free gyro, ``theta(t) = -(W . a) t``; :meth:`with_trajectories` attaches the angle
    histories of a real (or simulated) run.

    Attributes
    ----------
    site : Site
    table_axis : {"polar", "vertical"}
    mountings : tuple of str
        Mounting labels (segments), see :func:`parse_mounting`.
    trajectories : mapping, optional
        Per mounting, ``theta(t)`` [rad] and ``dtheta/dt(t)`` [rad/s] as callables of the time
        since the mounting's start [s].
    """

    site: Site
    table_axis: str
    mountings: tuple[str, ...]
    trajectories: Mapping[str, tuple[Callable, Callable]] | None = field(default=None,
                                                                         repr=False)

    def __post_init__(self) -> None:
        labels = [self.mounting(m).label for m in self.mountings]
        if len(set(labels)) != len(labels):
            raise InputError(f"mountings repeat: {', '.join(self.mountings)}")

    @property
    def segments(self) -> tuple[str, ...]:
        """Mounting labels in plan order."""
        return tuple(self.mountings)

    @property
    def axis_enu(self) -> NDArray[np.float64]:
        """Unit +table axis ``a`` in ENU."""
        return axis_enu(self.table_axis, self.site.latitude_rad)

    @property
    def earth_rate_along_axis(self) -> float:
        """``W . a`` [rad/s]: the Earth rate the servo must cancel (full Earth rate when polar)."""
        return float(earth_rate_enu(self.site.latitude_rad) @ self.axis_enu)

    def mounting(self, label: str) -> Mounting:
        """The parsed :class:`Mounting` of a label."""
        return parse_mounting(label, self.table_axis, self.site.latitude_rad)

    def attitude(self, segment: str, theta_rad: ArrayLike) -> NDArray[np.float64]:
        """``C_ni`` (I, O, S columns in ENU) at table angles theta [rad], shape (n, 3, 3)."""
        th = np.atleast_1d(np.asarray(theta_rad, dtype=float))
        rot = Rotation.from_rotvec(th[:, None] * self.axis_enu[None, :])
        return np.asarray(rot.as_matrix() @ self.mounting(segment).C_ni0)

    def specific_force_g(self, segment: str, theta_rad: ArrayLike) -> NDArray[np.float64]:
        """Specific force along (I, O, S) [g0] at table angles theta [rad], shape (n, 3).

        Closed form (Rodrigues): the up vector seen from the table turned by theta is
        ``u(theta) = (up . a) a + cos(theta) (up - (up . a) a) - sin(theta) (a x up)``, and
        ``f = (g/g0) C_ni0^T u(theta)``.
        """
        th = np.atleast_1d(np.asarray(theta_rad, dtype=float))
        a = self.axis_enu
        up = np.array([0.0, 0.0, 1.0])
        along = (up @ a) * a
        u = (along[None, :] + np.cos(th)[:, None] * (up - along)[None, :]
             - np.sin(th)[:, None] * np.cross(a, up)[None, :])
        return np.asarray(self.site.gravity_m_s2 / G0 * u @ self.mounting(segment).C_ni0)

    def inputs_at_angle(
        self, segment: str, theta_rad: ArrayLike, table_rate_rad_s: ArrayLike = 0.0
    ) -> Inputs:
        """Inputs at table angles theta [rad] turning at ``table_rate_rad_s`` about +a."""
        C = self.attitude(segment, theta_rad)
        n = C.shape[0]
        rate = np.broadcast_to(np.asarray(table_rate_rad_s, dtype=float), (n,))
        w_n = earth_rate_enu(self.site.latitude_rad)[None, :] + rate[:, None] * self.axis_enu
        w = np.einsum("nji,nj->ni", C, w_n)
        return Inputs(C, w, self.specific_force_g(segment, theta_rad) * G0)

    def inputs(self, segment: str, t: ArrayLike) -> Inputs:
        """Inputs of ``segment`` at times ``t`` [s] since its start (Motion protocol)."""
        if segment not in self.mountings:
            raise InputError(f"unknown mounting {segment!r}; the plan has "
                             f"{', '.join(self.mountings)}")
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        if self.trajectories is not None and segment in self.trajectories:
            theta_of, rate_of = self.trajectories[segment]
            return self.inputs_at_angle(segment, theta_of(tt), rate_of(tt))
        rate = -self.earth_rate_along_axis
        return self.inputs_at_angle(segment, rate * tt, rate)

    def with_trajectories(
        self, trajectories: Mapping[str, tuple[Callable, Callable]]
    ) -> ServoTable:
        """The same table with the angle histories of a run attached."""
        return ServoTable(self.site, self.table_axis, self.mountings, dict(trajectories))

    def drift_harmonics(
        self, segment: str, coefficients_si: ArrayLike
    ) -> NDArray[np.float64]:
        """Drift against table angle as ``B0, S1, C1, S2, C2`` [rad/s] (exact).

        The drift is quadratic in ``f`` and ``f`` is affine in ``cos(theta)``, ``sin(theta)``,
        so ``drift(theta) = B0 + S1 sin + C1 cos + S2 sin 2theta + C2 cos 2theta`` exactly; the
        terms are found from eight equally spaced angles.
        """
        th = np.arange(8) * np.pi / 4
        d = drift_regressors(self.specific_force_g(segment, th)) @ np.asarray(coefficients_si)
        H = np.column_stack([np.ones(8), np.sin(th), np.cos(th), np.sin(2 * th),
                             np.cos(2 * th)])
        return np.asarray(np.linalg.lstsq(H, d, rcond=None)[0])

    def servo_angle(
        self,
        segment: str,
        t_s: ArrayLike,
        coefficients_si: ArrayLike,
        *,
        theta0_rad: float = 0.0,
        extra_drift: Callable[[float], float] | None = None,
    ) -> NDArray[np.float64]:
        """Table angle theta(t) [rad] of the servo loop, integrated from theta0 at ``t_s[0]``.

        Parameters
        ----------
        segment : str
            Mounting.
        t_s : array_like, shape (n,)
            Increasing times [s].
        coefficients_si : array_like, shape (10,)
            Drift coefficients [rad/s per g^k] in the order of
            :data:`~inertest.models.sdf_gyro.COEFFICIENTS`.
        theta0_rad : float
            Angle at ``t_s[0]`` [rad].
        extra_drift : callable, optional
            A further drift ``b(t)`` [rad/s] (random drift), added to the static drift.

        Returns
        -------
        ndarray, shape (n,)
            Cumulative table angle [rad].

        Notes
        -----
        ``dtheta/dt = -(W . a) - s (drift(theta) + b(t))`` integrated by
        ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12, atol 1e-13 rad); the static drift is
        evaluated from its exact harmonic form (:meth:`drift_harmonics`).
        """
        t = np.asarray(t_s, dtype=float)
        if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
            raise InputError("servo_angle needs at least two strictly increasing times")
        h = self.drift_harmonics(segment, coefficients_si)
        s = self.mounting(segment).sign
        wa = self.earth_rate_along_axis

        def rhs(tt: float, y: NDArray[np.float64]) -> list[float]:
            th = y[0]
            d = (h[0] + h[1] * np.sin(th) + h[2] * np.cos(th) + h[3] * np.sin(2 * th)
                 + h[4] * np.cos(2 * th))
            if extra_drift is not None:
                d += extra_drift(tt)
            return [-wa - s * d]

        max_step = float(np.min(np.diff(t))) if extra_drift is not None else np.inf
        sol = solve_ivp(rhs, (t[0], t[-1]), [theta0_rad], method="DOP853", t_eval=t,
                        rtol=RTOL, atol=ATOL, max_step=max_step)
        if not sol.success:  # pragma: no cover - smooth scalar ODE
            raise InputError(f"servo-loop integration failed: {sol.message}")
        return np.asarray(sol.y[0])
