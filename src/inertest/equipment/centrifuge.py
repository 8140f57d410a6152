"""Dual-axis precision centrifuge with a counter-rotating azimuth platform: the ideal machine.

Seed ``004_f16e7c07e7c35fdc.txt`` (Sun, Ren & Wang), sec. 1-3. The main axis turns the arm by
``alpha = w t`` about the local vertical; the azimuth (platform) axis at the arm end turns by
``beta = -alpha`` so the instrument keeps a fixed attitude relative to the ground while the
centripetal specific force ``R w^2`` rotates around it.

Conventions (ideal machine)
---------------------------
Platform frame P, fixed to the ground: ``x_P`` along the arm at ``t = 0``, pointing to the
azimuth ``platform_heading`` (clockwise from north), ``z_P`` up, ``y_P = z_P x x_P``. The arm
angle ``alpha = w t`` is right-handed about ``z_P``: the signed main-axis rate ``w`` is positive
when the arm turns counter-clockwise seen from above and negative when it turns clockwise (every
function here accepts both senses). Specific force in P (centripetal plus the reaction to
gravity)::

    f_P = -R w^2 (cos alpha, sin alpha, 0) + (0, 0, g)

The gyro axes (I, O, S) are right-handed, ``I x O = S``. The nine attitudes are three mountings
(rows I, O, S in P at fixture angle 0) each at fixture angles 0, +45, -45 deg, the fixture turning
right-handed about ``y_P``:

=========  ==========================
positions  fixture 0
=========  ==========================
1, 2, 3    I = x_P, O = y_P, S = z_P
4, 5, 6    I = y_P, O = z_P, S = x_P
7, 8, 9    I = z_P, O = x_P, S = y_P
=========  ==========================

The imperfect machine
---------------------
:func:`centrifuge_motion` / :func:`instrument_inputs` evaluate the full chain of homogeneous
transforms of seed 004 (eqs. 1-8) exactly, vectorised over time: dynamic radius error, dynamic
misalignment of the arm end, parallelism and first-harmonic wobble of the azimuth axis, fixture
eccentricity (:class:`CentrifugeErrors`) and the non-synchronisation ``beta = -alpha + dgamma(t)``
(:class:`PhaseTracking`, :class:`RateTracking`, :class:`MeasuredDgamma`). With every error zero
and the Earth-rate acceleration terms left out they reduce to :func:`ideal_inputs` (tested).

:class:`CentrifugeRuns` is the machine as a :class:`~inertest.equipment.motion.Motion`: one
segment per run (position, signed rate), inputs from :func:`centrifuge_motion`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from inertest.earth import Site, earth_rate_enu
from inertest.equipment.motion import Inputs, run_starts
from inertest.equipment.type_b import TypeBSource, type_b_error
from inertest.errors import InputError

#: Position numbers of the nine-position method.
POSITIONS: tuple[int, ...] = tuple(range(1, 10))

#: Rows I, O, S in the platform frame P for each mounting at fixture angle 0.
_MOUNTINGS = (
    np.eye(3),  # I = x_P, O = y_P, S = z_P
    np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),  # I = y_P, O = z_P, S = x_P
    np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),  # I = z_P, O = x_P, S = y_P
)
#: Fixture angle [deg] of the positions within one mounting, in order.
FIXTURE_ANGLES_DEG: tuple[float, ...] = (0.0, 45.0, -45.0)


def fixture_angle_rad(position: int) -> float:
    """Fixture angle about ``y_P`` [rad] of a position 1..9."""
    _check_position(position)
    return float(np.radians(FIXTURE_ANGLES_DEG[(position - 1) % 3]))


def mounting_axes(position: int) -> NDArray[np.float64]:
    """Rows I, O, S in P of a position's mounting at fixture angle 0 (shape (3, 3))."""
    _check_position(position)
    return _MOUNTINGS[(position - 1) // 3].copy()


def position_axes(position: int) -> NDArray[np.float64]:
    """Rows I, O, S in the platform frame P of an ideal machine at ``position`` (1..9).

    The fixture turns the mounting's axes by the position's fixture angle about ``y_P``
    (right-handed), so each row ``a`` becomes ``R_y(theta) a``.
    """
    turn = Rotation.from_rotvec([0.0, fixture_angle_rad(position), 0.0]).as_matrix()
    return mounting_axes(position) @ turn.T


def platform_to_enu(platform_heading_rad: float) -> NDArray[np.float64]:
    """Direction cosines C with ``v_ENU = C v_P`` (columns x_P, y_P, z_P in ENU)."""
    h = float(platform_heading_rad)
    x = np.array([np.sin(h), np.cos(h), 0.0])
    z = np.array([0.0, 0.0, 1.0])
    return np.column_stack([x, np.cross(z, x), z])


def ideal_specific_force_platform(
    t: ArrayLike, omega: float, radius_m: float, gravity_m_s2: float
) -> NDArray[np.float64]:
    """Specific force in P [m/s^2] on an ideal machine, ``-R w^2 (cos a, sin a, 0) + (0, 0, g)``.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time since the arm passed ``x_P`` [s].
    omega : float
        Main-axis rate ``w`` [rad/s], right-handed about up (negative: clockwise from above).
    radius_m : float
        Arm radius R to the instrument [m].
    gravity_m_s2 : float
        Local gravity [m/s^2].
    """
    a = float(omega) * np.asarray(t, dtype=float)
    centripetal = float(radius_m) * float(omega) ** 2
    return np.column_stack(
        [-centripetal * np.cos(a), -centripetal * np.sin(a), np.full(a.shape, float(gravity_m_s2))]
    )


def ideal_inputs(
    t: ArrayLike,
    omega: float,
    position: int,
    *,
    radius_m: float,
    gravity_m_s2: float,
    latitude_rad: float,
    platform_heading_rad: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Specific force and inertial angular rate on the gyro axes of an ideal machine.

    The counter-rotating platform cancels the arm's rotation exactly, so the instrument turns with
    the Earth only (seed 004, eq. 13 with ``alpha + beta = 0``).

    Returns
    -------
    f_ios : ndarray, shape (n, 3)
        Specific force along I, O, S [m/s^2].
    omega_ios : ndarray, shape (n, 3)
        Angular rate of the instrument relative to inertial space along I, O, S [rad/s].
    """
    axes = position_axes(position)
    f = ideal_specific_force_platform(t, omega, radius_m, gravity_m_s2) @ axes.T
    w_p = platform_to_enu(platform_heading_rad).T @ earth_rate_enu(latitude_rad)
    return f, np.broadcast_to(axes @ w_p, f.shape).copy()


def run_times(omega: float, sample_rate_hz: float, revolutions: int) -> NDArray[np.float64]:
    """Sample times [s] of one run of ``revolutions`` whole revolutions at ``omega`` [rad/s].

    From ``t = 0`` (arm on ``x_P``) up to and including the first sample at or after the end of
    the last revolution, so that the run spans them by the rule of
    :func:`inertest.estimation.reduction.whole_cycle_mask`. The sign of ``omega`` (the sense of
    the arm) does not matter.
    """
    n = int(np.ceil(revolutions * 2.0 * np.pi / abs(float(omega)) * sample_rate_hz)) + 1
    return np.arange(n, dtype=float) / sample_rate_hz


def _check_position(position: int) -> None:
    if int(position) != position or not 1 <= int(position) <= 9:
        raise InputError(
            f"centrifuge position {position!r} is not one of 1..9 (nine-position method)"
        )


# --------------------------------------------------------------------------------------------
# The imperfect machine: full kinematic chain (seed 004, sec. 2, eqs. 1-13), computed exactly.
# --------------------------------------------------------------------------------------------



@dataclass(frozen=True)
class PhaseTracking:
    """Bounded non-synchronisation of a phase-tracking azimuth servo.

    ``dgamma(t) = amplitude * sin(2 pi frequency t + phase)`` [rad]; the source quotes
    ``dgamma_p = 2 arcmin`` (seed 004, sec. 3).
    """

    amplitude_rad: float
    frequency_hz: float
    phase_rad: float = 0.0

    def evaluate(self, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """``dgamma, d(dgamma)/dt, d2(dgamma)/dt2`` at ``t`` [rad, rad/s, rad/s^2]."""
        w = 2.0 * np.pi * float(self.frequency_hz)
        arg = w * t + float(self.phase_rad)
        a = float(self.amplitude_rad)
        return a * np.sin(arg), a * w * np.cos(arg), -a * w * w * np.sin(arg)


@dataclass(frozen=True)
class RateTracking:
    """Accumulating non-synchronisation of a rate-tracking azimuth servo.

    ``dgamma(t) = offset + rate * t`` [rad]; the source quotes 20.7 arcmin per second
    (seed 004, sec. 3). ``rate = 0`` gives a constant angle error (the source's 200' and 1000').
    """

    rate_rad_s: float
    offset_rad: float = 0.0

    def evaluate(self, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """``dgamma, d(dgamma)/dt, d2(dgamma)/dt2`` at ``t`` [rad, rad/s, rad/s^2]."""
        r = float(self.rate_rad_s)
        return float(self.offset_rad) + r * t, np.full_like(t, r), np.zeros_like(t)


@dataclass(frozen=True)
class MeasuredDgamma:
    """A measured non-synchronisation record ``dgamma(t_k)`` [rad] (e.g. from the two encoders).

    Interpolated by a cubic spline (``scipy.interpolate.CubicSpline``), whose first and second
    derivatives give the residual rate and acceleration. Times must be strictly increasing and
    cover the simulated/fitted times.
    """

    t: NDArray[np.float64]
    dgamma_rad: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        d = np.asarray(self.dgamma_rad, dtype=float)
        if t.ndim != 1 or t.shape != d.shape or t.size < 4:
            raise InputError(
                "measured dgamma needs matching 1-D arrays t and dgamma with at least 4 samples"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(d))):
            raise InputError("measured dgamma contains non-finite values; remove or fill them")
        if np.any(np.diff(t) <= 0.0):
            raise InputError("measured dgamma times must be strictly increasing; sort the record")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "dgamma_rad", d)

    def evaluate(self, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """``dgamma, d(dgamma)/dt, d2(dgamma)/dt2`` at ``t`` from the spline."""
        if t.size and (t.min() < self.t[0] - 1e-9 or t.max() > self.t[-1] + 1e-9):
            raise InputError(
                f"measured dgamma covers {self.t[0]:g}..{self.t[-1]:g} s but times "
                f"{t.min():g}..{t.max():g} s were asked; record dgamma over the whole run"
            )
        spline = self.__dict__.get("_spline")
        if spline is None:  # built once: the kinematics evaluate it block by block
            spline = CubicSpline(self.t, self.dgamma_rad)
            object.__setattr__(self, "_spline", spline)
        return spline(t), spline(t, 1), spline(t, 2)


NonSynchronisation = PhaseTracking | RateTracking | MeasuredDgamma


def _poly(coefficients: tuple[float, ...], omega: float) -> float:
    """``c1 w + c2 w^2 + ...`` (no constant term: a static part belongs to the nominal value)."""
    return float(sum(c * omega ** (k + 1) for k, c in enumerate(coefficients)))


@dataclass(frozen=True)
class CentrifugeErrors:
    """Geometric and dynamic errors of a dual-axis centrifuge (seed 004, sec. 2, eqs. 1-8).

    Attributes
    ----------
    radius_poly_m : tuple of float
        Dynamic radius error ``dR(w) = r1 w + r2 w^2 + ...`` [m, w in rad/s].
    misalignment_y_poly_rad, misalignment_z_poly_rad : tuple of float
        Dynamic misalignment of the arm end about its y and z axes,
        ``dl(w) = l1 w + l2 w^2 + ...`` [rad] (the arm end tilts, then the azimuth axis sits on it).
    parallelism_x_rad, parallelism_y_rad : float
        Parallelism errors ``dth_x1``, ``dth_y1`` of the azimuth axis to the main axis [rad].
    wobble_x_rad, wobble_y_rad : float
        First-harmonic wobble amplitudes of the azimuth axis about its x and y axes [rad]:
        ``tilt_x = wobble_x cos(beta + wobble_x_phase)``, same for y.
    wobble_x_phase_rad, wobble_y_phase_rad : float
        Wobble phases [rad]. The tilts act in the turning azimuth frame, so seen from the arm
        the tilt vector is ``Rz(beta) (tilt_x, tilt_y)``: with equal amplitudes ``a`` and
        ``wobble_y_phase = wobble_x_phase + pi/2`` it is the constant ``a (cos p, -sin p)``,
        a static parallelism error (``p = 0``: ``parallelism_x_rad = a``, tested); with
        ``- pi/2`` it turns at ``2 beta`` relative to the arm and has no static part.
    eccentricity_x_m, eccentricity_y_m : float
        Fixture eccentricity ``lx``, ``ly`` of the instrument's point in the azimuth frame [m].
    """

    radius_poly_m: tuple[float, ...] = ()
    misalignment_y_poly_rad: tuple[float, ...] = ()
    misalignment_z_poly_rad: tuple[float, ...] = ()
    parallelism_x_rad: float = 0.0
    parallelism_y_rad: float = 0.0
    wobble_x_rad: float = 0.0
    wobble_y_rad: float = 0.0
    wobble_x_phase_rad: float = 0.0
    wobble_y_phase_rad: float = 0.0
    eccentricity_x_m: float = 0.0
    eccentricity_y_m: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            vals = v if isinstance(v, tuple) else (v,)
            if not all(np.isfinite(float(x)) for x in vals):
                raise InputError(f"centrifuge error {f.name} must be finite, got {v!r}")


@dataclass(frozen=True)
class CentrifugeMotion:
    """Exact motion of the instrument on an imperfect centrifuge (all arrays over time, n samples).

    Attributes
    ----------
    attitude_p : ndarray, shape (n, 3, 3)
        Direction cosines instrument -> platform frame P (columns I, O, S in P).
    attitude : ndarray, shape (n, 3, 3)
        Direction cosines instrument -> ENU (columns I, O, S in ENU).
    omega_ios : ndarray, shape (n, 3)
        Angular rate of the instrument relative to inertial space on I, O, S [rad/s].
    f_ios : ndarray, shape (n, 3)
        Specific force on I, O, S [m/s^2].
    position_p, velocity_p, acceleration_p : ndarray, shape (n, 3)
        Position [m], velocity [m/s] and acceleration [m/s^2] of the instrument's point relative
        to P, in P (derivatives in the ground frame).
    omega_rel_p : ndarray, shape (n, 3)
        Angular rate of the instrument relative to the ground, in P [rad/s].
    """

    attitude_p: NDArray[np.float64]
    attitude: NDArray[np.float64]
    omega_ios: NDArray[np.float64]
    f_ios: NDArray[np.float64]
    position_p: NDArray[np.float64]
    velocity_p: NDArray[np.float64]
    acceleration_p: NDArray[np.float64]
    omega_rel_p: NDArray[np.float64]

    @property
    def pose(self) -> NDArray[np.float64]:
        """Homogeneous transforms instrument -> P, shape (n, 4, 4): ``[[C, p], [0, 1]]``."""
        out = np.zeros((self.position_p.shape[0], 4, 4))
        out[:, :3, :3], out[:, :3, 3], out[:, 3, 3] = self.attitude_p, self.position_p, 1.0
        return out


def centrifuge_motion(
    t: ArrayLike,
    omega: float,
    position: int,
    *,
    radius_m: float,
    gravity_m_s2: float,
    latitude_rad: float,
    platform_heading_rad: float = 0.0,
    errors: CentrifugeErrors | None = None,
    dgamma: NonSynchronisation | None = None,
    earth_rotation_in_acceleration: bool = True,
) -> CentrifugeMotion:
    """Exact kinematics of the instrument on an imperfect dual-axis centrifuge.

    The chain of homogeneous transforms (seed 004, eqs. 1-8), each link ``T = [C r; 0 1]`` mapping
    child to parent coordinates, from the ground-fixed platform frame P (see module docstring)::

        P -> Rz(alpha)                      main axis, alpha = w t
          -> Trans(R + dR(w), 0, 0)          arm end
          -> Ry(dl_y(w)) Rz(dl_z(w))         dynamic misalignment of the arm end
          -> Rx(dth_x1) Ry(dth_y1)           parallelism of the azimuth axis
          -> Rz(beta)                        azimuth axis, beta = -alpha + dgamma(t)
          -> Rx(ax cos(beta+px)) Ry(ay cos(beta+py))   first-harmonic wobble
          -> Trans(lx, ly, 0)                fixture eccentricity
          -> Ry(theta)                       fixture angle of the position
          -> mounting (rows I, O, S)         instrument

    Nothing is linearised. The chain is evaluated sample by sample in one compiled pass
    (:mod:`inertest.equipment._centrifuge_kernel`, numba) over blocks of :data:`BLOCK`
    samples, so memory beyond the outputs is O(block). Angular rate, angular acceleration,
    velocity and acceleration are propagated along the chain analytically (serial-chain
    recursion: each joint adds ``e_k dq_k/dt`` to the rate, ``e_k d2q_k/dt2 + w x e_k dq_k/dt``
    to the angular acceleration, and each offset ``r`` adds ``w' x r + w x (w x r)`` to the
    acceleration), so the residual rate ``d(dgamma)/dt`` and the wobble rates
    ``-a sin(beta + p) dbeta/dt`` are included exactly.

    Earth rotation: P turns with the Earth at ``W`` (the Earth rate in P). The inertial angular
    rate is ``W + w_rel``. With ``earth_rotation_in_acceleration`` (default) the inertial
    acceleration of the point is ``a_rel + 2 W x v_rel + W x (W x p)`` (Coriolis, ~``2 W w R``,
    and the centripetal term of the arm's offset from the main axis); the Earth's rotation of the
    centrifuge's own site is inside plumb-line gravity ``(0, 0, -g)`` in ENU. The specific force is
    ``f = a - g_vec``. ``False`` drops the two Earth terms, as the ideal closed form does.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time since the arm passed ``x_P`` [s].
    omega : float
        Main-axis rate ``w`` [rad/s], right-handed about up (negative: clockwise seen from
        above). The Earth-rate terms depend on the sense: the Coriolis term ``2 W x v`` adds
        ``2 W sin(L) w R`` to the centripetal force when ``w`` and the vertical Earth rate have
        the same sign and takes it away otherwise.
    position : int
        Position 1..9 (mounting and fixture angle).
    radius_m, gravity_m_s2, latitude_rad, platform_heading_rad : float
        Nominal arm radius [m], local gravity [m/s^2], latitude [rad], azimuth of ``x_P`` [rad].
    errors : CentrifugeErrors, optional
        Machine errors; default none.
    dgamma : PhaseTracking, RateTracking or MeasuredDgamma, optional
        Azimuth non-synchronisation ``beta = -alpha + dgamma(t)``; default none.
    earth_rotation_in_acceleration : bool
        Include the Earth-rate Coriolis and centripetal terms in the acceleration.
    """
    return _evaluate(
        t, omega, position, radius_m=radius_m, gravity_m_s2=gravity_m_s2,
        latitude_rad=latitude_rad, platform_heading_rad=platform_heading_rad, errors=errors,
        dgamma=dgamma, earth_rotation_in_acceleration=earth_rotation_in_acceleration, full=True)


#: Samples per call of the compiled chain: the only temporaries (a measured ``dgamma`` and its
#: derivatives) are O(BLOCK); the outputs are written in place.
BLOCK = 65_536


def _evaluate(
    t: ArrayLike,
    omega: float,
    position: int,
    *,
    radius_m: float,
    gravity_m_s2: float,
    latitude_rad: float,
    platform_heading_rad: float,
    errors: CentrifugeErrors | None,
    dgamma: NonSynchronisation | None,
    earth_rotation_in_acceleration: bool,
    full: bool,
    with_attitude: bool = True,
) -> Any:
    """The chain of :func:`centrifuge_motion` through the fused kernel, block by block.

    ``full``: a :class:`CentrifugeMotion`; otherwise only ``(f_ios, omega_ios, attitude)``,
    the attitude of no rows (not evaluated) when ``with_attitude`` is False.
    """
    tt = np.ascontiguousarray(np.atleast_1d(np.asarray(t, dtype=float)))
    if tt.ndim != 1 or (tt.size and not np.isfinite(tt.min() + tt.max())):
        raise InputError("times must be a finite 1-D array [s]")
    w = float(omega)
    if not np.isfinite(w):
        raise InputError(f"main-axis rate must be finite, got {omega!r}")
    for name, value in (("radius_m", radius_m), ("gravity_m_s2", gravity_m_s2),
                        ("latitude_rad", latitude_rad),
                        ("platform_heading_rad", platform_heading_rad)):
        if not np.isfinite(float(value)):
            raise InputError(f"{name} must be finite, got {value!r}")
    if not float(radius_m) > 0:
        raise InputError(f"arm radius must be positive [m], got {radius_m!r}")
    err = errors if errors is not None else CentrifugeErrors()
    fixture = np.ascontiguousarray(position_axes(position).T)
    c_pe = platform_to_enu(platform_heading_rad)
    earth_p = c_pe.T @ earth_rate_enu(latitude_rad)

    from inertest.equipment import _centrifuge_kernel as kernel  # numba: only when evaluated

    radius = float(radius_m) + _poly(err.radius_poly_m, w)
    links = np.array([_poly(err.misalignment_y_poly_rad, w),
                      _poly(err.misalignment_z_poly_rad, w),
                      err.parallelism_x_rad, err.parallelism_y_rad], dtype=float)
    wobble = np.array([err.wobble_x_rad, err.wobble_x_phase_rad, err.wobble_y_rad,
                       err.wobble_y_phase_rad], dtype=float)
    ecc = np.array([err.eccentricity_x_m, err.eccentricity_y_m], dtype=float)
    empty = np.empty(0)
    chain: Any = kernel.chain  # a numba dispatcher
    if dgamma is None:
        kind, par = kernel.DGAMMA_NONE, empty
    elif isinstance(dgamma, PhaseTracking):
        kind = kernel.DGAMMA_PHASE
        par = np.array([dgamma.amplitude_rad, 2.0 * np.pi * float(dgamma.frequency_hz),
                        dgamma.phase_rad], dtype=float)
    elif isinstance(dgamma, RateTracking):
        kind, par = kernel.DGAMMA_RATE, np.array([dgamma.rate_rad_s, dgamma.offset_rad], float)
    else:
        kind, par = kernel.DGAMMA_ARRAYS, empty
    n = tt.size
    out = [np.empty((n if with_attitude or full else 0, 3, 3)), np.empty((n, 3)),
           np.empty((n, 3))]
    extra = ([np.empty((n, 3, 3))] + [np.empty((n, 3)) for _ in range(4)] if full
             else [np.empty((0, 3, 3))] + [np.empty((0, 3)) for _ in range(4)])
    for i0 in range(0, n, BLOCK):
        i1 = min(i0 + BLOCK, n)
        tb = tt[i0:i1]
        dgs: tuple[NDArray[np.float64], ...] = (empty, empty, empty)
        if kind == kernel.DGAMMA_ARRAYS:
            assert dgamma is not None
            dgs = tuple(np.ascontiguousarray(x, dtype=float) for x in dgamma.evaluate(tb))
        chain(tb, w, radius, links, wobble, ecc, fixture, earth_p, c_pe,
                     float(gravity_m_s2), bool(earth_rotation_in_acceleration), kind, par, *dgs,
                     *(o[i0:i1] for o in out), full,
                     *(o[i0:i1] if full else o for o in extra))
    attitude, omega_ios, f_ios = out
    if not full:
        return f_ios, omega_ios, attitude
    return CentrifugeMotion(attitude_p=extra[0], attitude=attitude, omega_ios=omega_ios,
                            f_ios=f_ios, position_p=extra[1], velocity_p=extra[2],
                            acceleration_p=extra[3], omega_rel_p=extra[4])


def instrument_inputs(
    t: ArrayLike,
    omega: float,
    position: int,
    *,
    radius_m: float,
    gravity_m_s2: float,
    latitude_rad: float,
    platform_heading_rad: float = 0.0,
    errors: CentrifugeErrors | None = None,
    dgamma: NonSynchronisation | None = None,
    earth_rotation_in_acceleration: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Specific force, inertial angular rate (both on I, O, S) and attitude on a real machine.

    Thin wrapper of :func:`centrifuge_motion` (same parameters).

    Returns
    -------
    f_ios : ndarray, shape (n, 3)
        Specific force [m/s^2].
    omega_ios : ndarray, shape (n, 3)
        Angular rate relative to inertial space [rad/s] (Earth rate included).
    attitude : ndarray, shape (n, 3, 3)
        Direction cosines instrument -> ENU.
    """
    f_ios, omega_ios, attitude = _evaluate(
        t, omega, position, radius_m=radius_m, gravity_m_s2=gravity_m_s2,
        latitude_rad=latitude_rad, platform_heading_rad=platform_heading_rad, errors=errors,
        dgamma=dgamma, earth_rotation_in_acceleration=earth_rotation_in_acceleration, full=False)
    return f_ios, omega_ios, attitude


def run_labels(position: ArrayLike, omega: ArrayLike) -> NDArray[np.str_]:
    """Segment label of each (position, signed main-axis rate) row: ``"3@4.43"``.

    The rate [rad/s] is written in the shortest form that reads back to the same float, so
    runs told apart by their rate keep distinct labels.
    """
    p = np.atleast_1d(np.asarray(position))
    w = np.broadcast_to(np.asarray(omega, dtype=float), p.shape)
    keys, inverse = np.unique(np.column_stack([p.astype(float), w]), axis=0, return_inverse=True)
    names = np.array([f"{int(k[0])}@{float(k[1])!r}" for k in keys], dtype=str)
    return names[np.asarray(inverse).reshape(p.shape)]


#: Type-B errors the centrifuge accepts (:mod:`inertest.equipment.type_b`), applied by
#: :meth:`CentrifugeRuns.inputs` on top of its :class:`CentrifugeErrors`.
TYPE_B: tuple[TypeBSource, ...] = (
    TypeBSource("radius", "m", "arm radius error: added to the nominal radius"),
    TypeBSource("rate", "1", "main-axis rate accuracy: every rate scaled by (1 + error)"),
    TypeBSource("tilt", "rad", "azimuth-axis alignment: a parallelism error about x"),
)


@dataclass(frozen=True)
class CentrifugeRuns:
    """Runs of a dual-axis centrifuge as a :class:`~inertest.equipment.motion.Motion`.

    One segment per run: a position 1..9 at a signed main-axis rate [rad/s] (label
    ``"3@4.43"``, :func:`run_labels`). ``inputs(segment, t)`` evaluates the exact kinematics of
    :func:`centrifuge_motion` at times ``t`` since the arm passed ``x_P`` [s].

    Attributes
    ----------
    runs : tuple of (int, float)
        ``(position, omega)`` of each run, in plan order.
    radius_m : float
        Nominal arm radius [m].
    site : Site
        Latitude and local gravity.
    platform_heading_rad : float
        Azimuth of ``x_P`` [rad].
    errors : CentrifugeErrors, optional
        Machine errors (none: the ideal machine, Earth rotation included).
    dgamma : PhaseTracking, RateTracking or MeasuredDgamma, optional
        Azimuth non-synchronisation.
    earth_rotation_in_acceleration : bool
        Include the Earth-rate Coriolis and centripetal terms in the specific force.
    type_b : mapping of str to float
        The machine's Type-B errors [SI] (:data:`TYPE_B`: radius, rate, tilt) on top of
        ``errors``; empty for the nominal machine.
    """

    runs: tuple[tuple[int, float], ...]
    radius_m: float
    site: Site
    platform_heading_rad: float = 0.0
    errors: CentrifugeErrors | None = None
    dgamma: NonSynchronisation | None = None
    earth_rotation_in_acceleration: bool = True
    type_b: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for p, w in self.runs:
            _check_position(p)
            if not np.isfinite(w):
                raise InputError(f"main-axis rate of a run must be finite [rad/s], got {w!r}")

    @cached_property
    def segments(self) -> tuple[str, ...]:
        """Run labels in plan order."""
        return tuple(str(run_labels(p, w)[0]) for p, w in self.runs)

    def inputs(self, segment: str, t: ArrayLike) -> Inputs:
        """Exact inputs of run ``segment`` at times ``t`` [s], shape (n,)."""
        f_ios, omega_ios, attitude = instrument_inputs(t, **self._run(segment))
        return Inputs(attitude, omega_ios, f_ios)

    def rate_and_force(self, segment: str, t: ArrayLike
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Inertial angular rate and specific force on I, O, S of run ``segment`` at ``t`` [s].

        :meth:`inputs` without the attitude (not evaluated): what the drift models need.

        Returns
        -------
        omega_ios : ndarray, shape (n, 3)
            Angular rate relative to inertial space [rad/s].
        f_ios : ndarray, shape (n, 3)
            Specific force [m/s^2].
        """
        f_ios, omega_ios, _ = _evaluate(t, **self._run(segment), full=False, with_attitude=False)
        return omega_ios, f_ios

    def _run(self, segment: str) -> dict[str, Any]:
        """Arguments of :func:`instrument_inputs` for run ``segment`` (Type-B errors applied)."""
        try:
            p, w = self.runs[self.segments.index(segment)]
        except ValueError:
            raise InputError(f"unknown centrifuge run {segment!r}; the plan has "
                             f"{', '.join(self.segments)}") from None
        errors, tilt = self.errors, type_b_error(self.type_b, "tilt")   # Type-B (0: nominal)
        if tilt:
            base = CentrifugeErrors() if errors is None else errors
            errors = replace(base, parallelism_x_rad=base.parallelism_x_rad + tilt)
        return {"omega": w * (1.0 + type_b_error(self.type_b, "rate")), "position": p,
                "radius_m": self.radius_m + type_b_error(self.type_b, "radius"),
                "gravity_m_s2": self.site.gravity_m_s2, "latitude_rad": self.site.latitude_rad,
                "platform_heading_rad": self.platform_heading_rad, "errors": errors,
                "dgamma": self.dgamma,
                "earth_rotation_in_acceleration": self.earth_rotation_in_acceleration}

    def inputs_of_rows(self, labels: ArrayLike, t: ArrayLike) -> Inputs:
        """Inputs of every data row, by its run label and time [s], shape (n,).

        One evaluation of the kinematics per run, over that run's rows in their order. The
        rows of a run usually come one after another: the labels are compared at the changes
        only, and a run in one stretch of rows is evaluated and written as a slice.
        """
        lab = np.asarray(labels).astype(str, copy=False)
        tt = np.asarray(t, dtype=float)
        if lab.shape != tt.shape or lab.ndim != 1:
            raise InputError(f"labels and times need the same shape (n,), got {lab.shape} and "
                             f"{tt.shape}")
        C, w, f = np.empty((tt.size, 3, 3)), np.empty((tt.size, 3)), np.empty((tt.size, 3))
        starts = run_starts(lab)
        ends = np.append(starts[1:], tt.size)
        uniq, inverse = np.unique(lab[starts], return_inverse=True)
        for k, u in enumerate(uniq):
            stretches = np.flatnonzero(inverse == k)
            rows: slice | NDArray[np.intp] = (
                slice(int(starts[stretches[0]]), int(ends[stretches[0]])) if stretches.size == 1
                else np.concatenate([np.arange(starts[j], ends[j]) for j in stretches]))
            part = self.inputs(str(u), tt[rows])
            C[rows], w[rows], f[rows] = part.C_ni, part.omega_i, part.f_i
        return Inputs(C, w, f)


@dataclass(frozen=True)
class Centrifuge:
    """A dual-axis centrifuge at a site, with its Type-B errors: its runs on demand.

    Attributes
    ----------
    radius_m : float
        Nominal arm radius [m].
    site : Site
    platform_heading_rad : float
        Azimuth of ``x_P`` [rad].
    type_b : mapping of str to float
        Type-B errors [SI] (:data:`TYPE_B`); empty for the nominal machine.
    """

    radius_m: float
    site: Site
    platform_heading_rad: float = 0.0
    type_b: Mapping[str, float] = field(default_factory=dict)

    def runs(self, runs: tuple[tuple[int, float], ...]) -> CentrifugeRuns:
        """The error-free machine (Earth rotation included) running ``(position, omega)`` runs."""
        return CentrifugeRuns(runs, radius_m=self.radius_m, site=self.site,
                              platform_heading_rad=self.platform_heading_rad,
                              type_b=self.type_b)
