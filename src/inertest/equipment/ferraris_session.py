"""Kinematics of a Ferraris calibration session: six static faces and three hand-made turns.

No turntable: the IMU case is set by hand on a (nominally level) table on each of its six faces,
then turned once about each of its axes (Ferraris et al., 1995, "Procedure for effortless in-field
calibration of three-axial rate gyro and accelerometers", Sensors and Materials 7(5), 311-330;
the session layout of ``imucal.FerrarisCalibration``).

Parts (the ``part`` column of a recording):

========  ===================================================================================
``x_p``   +x axis up: the x accelerometer reads +g (specific force +g along +x)
``x_a``   +x axis down: the x accelerometer reads -g
``y_p``, ``y_a``, ``z_p``, ``z_a``   the same for y and z
``x_rot`` a turn about the body x axis (x vertical), by ``rotation_deg`` (right-handed about +x)
``y_rot``, ``z_rot``   the same about y and z
========  ===================================================================================

Frame: the body frame is the IMU case's orthogonal frame defined by its faces (the reference
axes of the calibration), SI units.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site
from inertest.equipment.motion import StaticPositions
from inertest.equipment.rate_table import Turns
from inertest.errors import InputError

AXES = ("x", "y", "z")
#: Static faces in session order: (label, axis index, sign of the axis relative to up).
FACES: tuple[tuple[str, int, int], ...] = tuple(
    (f"{a}_{s}", i, +1 if s == "p" else -1) for i, a in enumerate(AXES) for s in ("p", "a")
)
FACE_LABELS: tuple[str, ...] = tuple(f[0] for f in FACES)
#: Turns: (label, axis index).
TURNS: tuple[tuple[str, int], ...] = tuple((f"{a}_rot", i) for i, a in enumerate(AXES))
TURN_LABELS: tuple[str, ...] = tuple(t[0] for t in TURNS)
PARTS: tuple[str, ...] = FACE_LABELS + TURN_LABELS


def face_specific_force(
    axis: int, sign: int, gravity_m_s2: float, tilt_rad: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Specific force on the body axes [m/s^2] on a face, shape (3,).

    ``sign * g * e_axis`` for a level face; ``tilt_rad`` (rotation vector [rad], shape (3,),
    its component along ``axis`` ignored) tilts the face by a small angle.
    """
    f = np.zeros(3)
    f[axis] = sign * gravity_m_s2
    if tilt_rad is None:
        return f
    t = np.array(tilt_rad, dtype=float)
    t[axis] = 0.0
    return Rotation.from_rotvec(t).apply(f)


def face_attitude(axis: int, sign: int, heading_rad: float = 0.0) -> NDArray[np.float64]:
    """``C_nb`` (body to ENU), shape (3, 3), of a level face: body ``axis`` along ``sign`` x up.

    The next body axis (cyclically) points along ``(cos h, sin h, 0)`` in ENU (``h`` measured
    from east towards north); the third completes the right-handed triad.
    """
    up = np.array([0.0, 0.0, float(sign)])
    h = np.array([np.cos(heading_rad), np.sin(heading_rad), 0.0])
    C = np.zeros((3, 3))
    C[:, axis] = up
    C[:, (axis + 1) % 3] = h
    C[:, (axis + 2) % 3] = np.cross(up, h)
    return C


def turn_rate_profile(
    axis: int, angle_rad: float, duration_s: float, rate_hz: float, rest_s: float = 0.0
) -> NDArray[np.float64]:
    """Body rate [rad/s], shape (n, 3), of a turn about ``axis`` with rest before and after.

    The rate is a raised cosine ``angle/T (1 - cos(2 pi t/T))`` over ``T = duration_s``; its
    samples at ``t = k / rate_hz``, k = 0..N-1 (N = T rate_hz, an integer) sum to exactly
    ``angle * rate_hz``, so the sampled turn integrates exactly to ``angle``.
    """
    n_turn = int(round(duration_s * rate_hz))
    if n_turn < 2 or abs(n_turn - duration_s * rate_hz) > 1e-9 * n_turn:
        raise InputError(
            f"turn duration {duration_s:g} s times sample rate {rate_hz:g} Hz must be a whole "
            "number of samples (>= 2)"
        )
    n_rest = int(round(rest_s * rate_hz))
    k = np.arange(n_turn)
    w = angle_rad / duration_s * (1.0 - np.cos(2.0 * np.pi * k / n_turn))
    out = np.zeros((n_turn + 2 * n_rest, 3))
    out[n_rest : n_rest + n_turn, axis] = w
    return out


def faces_motion(site: Site, heading_rad: float = 0.0) -> StaticPositions:
    """The six level faces as a :class:`~inertest.equipment.motion.Motion` (labels ``x_p``...).

    ``C_ni`` of each face is :func:`face_attitude` at ``heading_rad``; at rest
    ``f_i = C_ni^T (0, 0, g)`` (``sign * g`` along the face's axis) and
    ``omega_i = C_ni^T W_ie_n``.
    """
    return StaticPositions(
        {label: face_attitude(axis, sign, heading_rad) for label, axis, sign in FACES}, site)


#: Gauss-Legendre nodes over a raised-cosine turn for the Earth-rate integral.
_GL_NODES = 64


@dataclass(frozen=True)
class RaisedCosineProfile:
    """A hand-made turn: rate ``angle/T (1 - cos(2 pi t/T))`` over ``T = duration_s``.

    The continuous profile of :func:`turn_rate_profile`: angle
    ``theta(t) = angle (t/T - sin(2 pi t/T)/(2 pi))``, 0 before and ``angle_rad`` after.

    Attributes
    ----------
    angle_rad : float
        Turn angle [rad], > 0 (the direction is the turn's).
    duration_s : float
        Turn time ``T`` [s], > 0.
    """

    angle_rad: float
    duration_s: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.angle_rad) and self.angle_rad > 0):
            raise InputError(f"turn angle must be positive, got {self.angle_rad} rad")
        if not (np.isfinite(self.duration_s) and self.duration_s > 0):
            raise InputError(f"turn duration must be positive, got {self.duration_s} s")

    def angle(self, t: ArrayLike) -> NDArray[np.float64]:
        """Angle turned at ``t`` [s] after the start [rad]."""
        x = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s) / self.duration_s
        out: NDArray[np.float64] = self.angle_rad * (x - np.sin(2 * np.pi * x) / (2 * np.pi))
        return out

    def rate(self, t: ArrayLike) -> NDArray[np.float64]:
        """Rate at ``t`` [s] after the start [rad/s]."""
        tt = np.asarray(t, dtype=float)
        inside = (tt >= 0) & (tt <= self.duration_s)
        w = self.angle_rad / self.duration_s * (1 - np.cos(2 * np.pi * tt / self.duration_s))
        out: NDArray[np.float64] = np.where(inside, w, 0.0)
        return out

    def quadrature(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gauss-Legendre nodes and weights over the turn [s]."""
        x, w = np.polynomial.legendre.leggauss(_GL_NODES)
        return 0.5 * self.duration_s * (x + 1), 0.5 * self.duration_s * w


def turns_motion(
    site: Site, angle_rad: float, duration_s: float, rest_s: float = 0.0,
    heading_rad: float = 0.0,
) -> Turns:
    """The three turns (``x_rot``, ``y_rot``, ``z_rot``) as a :class:`~.motion.Motion`.

    Each turn starts in the axis-up face (:func:`face_attitude` at ``heading_rad``), rests
    ``rest_s``, turns by ``angle_rad`` (signed, right-handed about the +axis) over
    ``duration_s`` with the raised-cosine rate (:class:`RaisedCosineProfile`), and rests.
    """
    direction = 1 if angle_rad > 0 else -1
    starts = {label: (face_attitude(axis, +1, heading_rad), axis, direction)
              for label, axis in TURNS}
    return Turns(site, starts, RaisedCosineProfile(abs(angle_rad), duration_s), rest_s)


@dataclass(frozen=True)
class FerrarisSession:
    """A Ferraris session's motion: the six level faces and the three turns.

    Attributes
    ----------
    site : Site
    angle_rad : float
        Signed turn angle [rad] (right-handed about the +axis).
    turn_duration_s : float
        Duration of each raised-cosine turn [s].
    rest_s : float
        Rest before and after each turn [s].
    heading_rad : float
        Heading of the faces [rad].
    """

    site: Site
    angle_rad: float
    turn_duration_s: float
    rest_s: float = 0.0
    heading_rad: float = 0.0

    @functools.cached_property
    def faces(self) -> StaticPositions:
        """The six level faces (:func:`faces_motion`)."""
        return faces_motion(self.site, self.heading_rad)

    @functools.cached_property
    def turns(self) -> Turns:
        """The three turns (:func:`turns_motion`)."""
        return turns_motion(self.site, self.angle_rad, self.turn_duration_s, self.rest_s,
                            self.heading_rad)
