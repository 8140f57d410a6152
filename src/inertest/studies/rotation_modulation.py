"""System-level rotation modulation: a strapdown IMU on a rotating mount in a static-base INS.

Issue 7 (system part), beyond seed ``001_844b96197456cfeb.txt`` (whose component-level scheme
is :mod:`inertest.studies.stator_modulation`). The IMU's errors are constant (or slowly
varying) in the body frame b; the mount turns the body relative to the navigation frame n
(ENU), so the errors reach the INS error equations of :mod:`inertest.ins.error_model`
modulated by the attitude ``C_b^n(t)`` (maps b to n)::

    dw^b(t) = eps^b(t) + M_g w_ib^b(t),      w_ib^b = C_n^b w_ie^n + w_nb^b      (gyro)
    df^b(t) = b^b + M_a f^b(t),              f^b    = C_n^b [0, 0, g]            (accelerometer)
    u(t)    = [ (C_b^n df^b)_E, (C_b^n df^b)_N, C_b^n dw^b ]  ->  x' = A x + B u(t)

with ``eps^b(t) = eps0 + eps1 t`` (constant drift plus a linear trend), ``b^b`` the
accelerometer bias, ``M_g = diag(gyro scale-factor errors) + gyro misalignment`` (off-diagonal
entries couple one axis's rate into another gyro: non-orthogonality), ``M_a = diag(accel
scale-factor errors)``, ``w_ie^n = W (0, cos L, sin L)`` the Earth rate and ``w_nb^b`` the rate
of the mount. The gyro's error on the mount rate is a drift because the strapdown attitude
computation integrates the gyro outputs, mount rotation included. Only the horizontal
accelerometer errors enter: the vertical channel (height, vertical velocity) is not modelled by
the error equations (it is unstable and, in practice, damped by an external height reference).

Signs: ``dw^b`` and ``df^b`` are sensor *output* errors (output = true + error), as everywhere
in inertest, and they enter through ``B`` of :mod:`inertest.ins.error_model`: the
accelerometer error with ``+`` in ``dV'``, the gyro error (drift, scale factor, misalignment)
with ``-`` in ``phi'``, because the computed attitude ``C_b^n = (I - [phi x]) C_b^n(true)``
integrates the gyro output: ``phi' = -w_in^n x phi + dw_in^n - C_b^n dw^b``. Errors are
computed minus true. Checked against an independent nonlinear strapdown simulation
(``tests/ins/test_strapdown_reference.py``: 24 h static, 3 h at 6 deg/s).

Rotation schemes (all start from body = nav, x east, y north, z up, at ``t = 0``)
--------------------------------------------------------------------------------
``none``
    Static IMU, ``C_b^n = R_z(heading)``: the plain static-base INS.
``single-axis``
    Continuous rotation about the vertical at rate ``W`` (``C_b^n = R_z(W t)``); with
    ``alternate=True`` the direction reverses after every ``revolutions`` whole turns
    (+360, -360, ...), which cancels the scale-factor x rotation-rate term.
``four-position``
    Indexing about the vertical: dwell ``T_d`` at each position, turn between them at rate
    ``W``. One cycle = 8 orders (dwell, then turn), positions are azimuth angles of the body
    x axis from east, counter-clockwise positive:

    =====  =========  =======  ========  =====  =========  =======  ========
    order  dwell at   turn     to        order  dwell at   turn     to
    =====  =========  =======  ========  =====  =========  =======  ========
    1      A   0 deg  +180     B 180     5      A   0 deg  -180     B 180
    2      B 180      +90      C 270     6      B 180      +90      C 270
    3      C 270      -180     D  90     7      C 270      +180     D  90
    4      D  90      -90      A   0     8      D  90      -90      A   0
    =====  =========  =======  ========  =====  =========  =======  ========

    Orders 1-4 are a common A-B-C-D four-position sequence of single-axis indexing INS
    (0, 180, 270, 90 deg; dwells in opposite pairs, net turn 0). Alone, its turns leave a
    transition residual: the arcs swept integrate to ``(-2 + 2i) / W`` (E + iN) per cycle.
    Orders 5-8 repeat the positions with the 180-deg turns reversed, whose arcs integrate to
    ``(+2 - 2i) / W``, so over the 8-order cycle constant horizontal drift and bias cancel
    *including* the turns, and the net turn in each direction is zero (scale factor x rate
    cancels too).
``sixteen-position``
    Dual-axis indexing: the outer (azimuth) axis is the navigation vertical z_n, the inner
    axis is the body x axis (horizontal, carried by the outer gimbal). Every turn is 180 deg
    at rate ``W``; dwell ``T_d`` before each turn. Positions: A = identity, B = R_z(180),
    C = R_z(180) R_x(180), D = R_x(180). The 16 orders below follow the 16-position
    sequence of Yuan, Liao and Han, "Error compensation of an optical gyro INS by multi-axis
    rotation", Meas. Sci. Technol. 23 (2012) 025102 (doi:10.1088/0957-0233/23/2/025102), as
    recalled here; the paper's own table was not available to check against, so *this* table
    is the definition that inertest implements and tests:

    =====  =====  ======  =======  =====  =====  ======  =======
    order  axis   turn    to       order  axis   turn    to
    =====  =====  ======  =======  =====  =====  ======  =======
    1      z      +180    B        9      z      -180    B
    2      x      +180    C        10     x      -180    C
    3      z      -180    D        11     z      +180    D
    4      x      -180    A        12     x      +180    A
    5      x      +180    D        13     x      -180    D
    6      z      +180    C        14     z      -180    C
    7      x      -180    B        15     x      +180    B
    8      z      -180    A        16     z      +180    A
    =====  =====  ======  =======  =====  =====  ======  =======

    Orders 9-16 are 1-8 with every direction reversed. Over the cycle the mean of ``C_b^n``
    (turns included) is zero, so constant drift and bias on *all three* axes cancel, and the
    turn angles about each axis sum to zero both ways.

What rotation cannot cancel (tested)
------------------------------------
* drift / bias along a single rotation axis (vertical, for the single-axis and 4-position
  schemes): ``C_b^n e_z = e_z``, so eU is the static one;
* scale-factor error x rotation rate: ``dK_z W`` along the rotation axis, a constant drift
  unless the direction alternates;
* scale-factor error x Earth rate: ``C M_g C^T w_ie^n`` has the non-zero mean
  ``((dK_x + dK_y) / 2) W cos L`` north and ``dK_z W sin L`` up for vertical rotation. Any
  time average of ``C M_g C^T`` keeps the trace of ``M_g`` (a similarity invariant), so no
  scheme cancels a common scale-factor error on the Earth rate. The sixteen-position dwells
  are 180-deg flips, which leave a diagonal ``M_g`` unchanged (``C M_g C^T = M_g``); only its
  turns mix the axes (a half turn about z averages the x, y entries, about x the y, z ones).
  The four-position turns also leave ``(dK_x - dK_y) / 2 W cos L`` times the integral of
  ``sin 2 theta`` over the arcs swept (a small east drift);
* slowly varying drift: a ramp ``eps1 t`` leaves, at whole periods ``t = k T``, the
  integrated horizontal drift ``k T J eps1 / W`` (``J = [[0, 1], [-1, 0]]``): an equivalent
  constant drift of magnitude ``|eps1| / W`` (the first-order residual, as at component
  level in :func:`inertest.studies.stator_modulation.ramp_residual`).

Exact propagation
-----------------
Each segment of a scheme is a dwell (constant ``C_b^n``) or a turn about a fixed axis at a
constant rate ``w``: ``C(tau) = R(w tau) C0`` (navigation-frame axis) or ``C0 R(w tau)`` (body
axis). By Rodrigues' formula the entries of ``C`` are in span{1, cos w tau, sin w tau}, so
every input above (products of at most two such factors) lies in span{1, cos, sin, cos 2,
sin 2} (times ``tau`` for the ramp). Augmenting the state with these basis functions, which
obey ``z' = Omega z``, makes the system LTI per segment, solved exactly by one matrix
exponential per distinct step (Van Loan 1978, doi:10.1109/TAC.1978.1101743). The
coefficients on the basis are found by sampling the input at 10 points of one period
(an exact discrete Fourier fit; the fit residual is checked).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import Site, earth_rate_enu, specific_force_enu
from inertest.equipment.motion import Inputs
from inertest.errors import InputError
from inertest.ins.error_model import (
    INPUT_UNITS,
    INPUTS,
    SIGN_CONVENTION,
    STATE_UNITS,
    STATES,
    InsSite,
    LinearValidity,
    input_matrix,
    linear_validity,
    system_matrix,
)
from inertest.models import triad
from inertest.results import envelope

__all__ = [
    "SCHEMES",
    "ImuErrors",
    "RotationScheme",
    "SystemRun",
    "compare_schemes",
    "cycle_mean_inputs",
    "make_scheme",
    "mean_attitude",
    "monte_carlo_noise",
    "navigation_inputs",
    "propagate_rotating",
    "run_scheme",
    "static_noise_covariance",
]

#: Scheme names understood by :func:`make_scheme`.
SCHEMES: tuple[str, ...] = ("none", "single-axis", "four-position", "sixteen-position")

_NX = 7
_NAV, _BODY = 0, 1
_EZ = np.array([0.0, 0.0, 1.0])
_EX = np.array([1.0, 0.0, 0.0])

#: Four-position cycle: (turn about the vertical [deg]) for orders 1-8 (module table).
FOUR_POSITION_TURNS_DEG: tuple[float, ...] = (180.0, 90.0, -180.0, -90.0,
                                              -180.0, 90.0, 180.0, -90.0)
#: Sixteen-position cycle: (axis, turn [deg]) for orders 1-16 (module table); "z" is the
#: navigation vertical (outer axis), "x" the body x axis (inner axis).
SIXTEEN_POSITION_ORDERS: tuple[tuple[str, float], ...] = (
    ("z", 180.0), ("x", 180.0), ("z", -180.0), ("x", -180.0),
    ("x", 180.0), ("z", 180.0), ("x", -180.0), ("z", -180.0),
    ("z", -180.0), ("x", -180.0), ("z", 180.0), ("x", 180.0),
    ("x", -180.0), ("z", -180.0), ("x", 180.0), ("z", 180.0),
)


# --------------------------------------------------------------------------------------------
# Schemes: C_b^n(t) and the mount rate
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RotationScheme:
    """A rotation schedule as segments: dwell (rate 0) or a turn about a fixed axis.

    Attributes
    ----------
    name : str
        One of :data:`SCHEMES`.
    start_s, duration_s : ndarray, shape (k,)
        Segment start times and lengths [s]; the segments tile ``[0, span_s]``.
    c0 : ndarray, shape (k, 3, 3)
        ``C_b^n`` at each segment start.
    axis : ndarray, shape (k, 3)
        Unit turn axis: in the navigation frame (``frame == 0``) or the body frame (``1``).
    frame : ndarray of int, shape (k,)
        0: ``C(tau) = R(w tau) C0`` (navigation-frame axis); 1: ``C(tau) = C0 R(w tau)``.
    rate_rad_s : ndarray, shape (k,)
        Signed turn rate w [rad/s]; 0 for a dwell.
    cycle_s : float
        Length of one whole cycle (period) [s]; ``inf`` for ``none``.
    parameters : dict
        The arguments the scheme was built with (SI, names with unit suffixes).
    """

    name: str
    start_s: NDArray[np.float64]
    duration_s: NDArray[np.float64]
    c0: NDArray[np.float64]
    axis: NDArray[np.float64]
    frame: NDArray[np.int64]
    rate_rad_s: NDArray[np.float64]
    cycle_s: float
    parameters: dict = field(default_factory=dict)

    @property
    def label(self) -> str:
        """Name for legends and tables, e.g. ``single-axis (alternating)``."""
        if self.parameters.get("alternate"):
            return f"{self.name} (alternating)"
        return self.name

    @property
    def span_s(self) -> float:
        """End of the last segment [s]."""
        return float(self.start_s[-1] + self.duration_s[-1])

    def _locate(self, t: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        t = np.asarray(t, dtype=float)
        if np.any(t < -1e-9) or np.any(t > self.span_s * (1 + 1e-12) + 1e-9):
            raise InputError(
                f"times must lie within the scheme's span [0, {self.span_s:g}] s; build the "
                "scheme for the whole simulated span"
            )
        idx = np.clip(np.searchsorted(self.start_s, t, side="right") - 1, 0, self.start_s.size - 1)
        return idx, t - self.start_s[idx]

    def attitude(self, t: ArrayLike) -> NDArray[np.float64]:
        """``C_b^n`` at times ``t`` [s], shape (n, 3, 3)."""
        idx, tau = self._locate(np.atleast_1d(np.asarray(t, dtype=float)))
        return _segment_attitude(self, idx, tau)

    def motion(self, site: Site) -> SchemeMotion:
        """The schedule as an equipment motion at ``site`` (segments = dwells and turns)."""
        return SchemeMotion(self, site)

    def mount_rate_body(self, t: ArrayLike) -> NDArray[np.float64]:
        """Mount rate ``w_nb^b`` [rad/s] at times ``t``, shape (n, 3)."""
        idx, tau = self._locate(np.atleast_1d(np.asarray(t, dtype=float)))
        return _segment_mount_rate(self, idx, tau)


@dataclass(frozen=True)
class SchemeMotion:
    """A rotation scheme as an equipment motion (:class:`inertest.equipment.motion.Motion`).

    Segments are the scheme's dwells and turns (``"dwell 0"``, ``"turn 1"``, ...); the
    instrument (IMU body) axes are b, so ``C_ni = C_b^n``, ``omega_i = C_b^n^T W_n + w_nb^b``
    and ``f_i = C_b^n^T (0, 0, g)`` at rest on the rotating mount.
    """

    scheme: RotationScheme
    site: Site

    @property
    def segments(self) -> tuple[str, ...]:
        """``"dwell k"`` or ``"turn k"`` for each segment of the schedule."""
        return tuple(f"{'dwell' if w == 0 else 'turn'} {k}"
                     for k, w in enumerate(self.scheme.rate_rad_s))

    def inputs(self, segment: str, t: ArrayLike) -> Inputs:
        """Inputs at times ``t`` [s] since the start of ``segment``."""
        try:
            k = self.segments.index(segment)
        except ValueError:
            raise InputError(f"unknown segment {segment!r} of the {self.scheme.name} scheme; "
                             f"it has {len(self.segments)} segments") from None
        tau = np.atleast_1d(np.asarray(t, dtype=float))
        if np.any(tau < 0) or np.any(tau > self.scheme.duration_s[k] * (1 + 1e-12)):
            raise InputError(f"times must lie within segment {segment!r} "
                             f"[0, {self.scheme.duration_s[k]:g}] s")
        idx = np.full(tau.shape, k)
        c = _segment_attitude(self.scheme, idx, tau)
        w_b = np.einsum("nji,j->ni", c, earth_rate_enu(self.site.latitude_rad))
        f_b = np.einsum("nji,j->ni", c, specific_force_enu(self.site.gravity_m_s2))
        return Inputs(c, w_b + _segment_mount_rate(self.scheme, idx, tau), f_b)


def _rot(axis: NDArray[np.float64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices about ``axis`` (n, 3) by ``angle`` (n,) [rad], shape (n, 3, 3)."""
    return Rotation.from_rotvec(axis * angle[:, None]).as_matrix()


def _segment_attitude(s: RotationScheme, idx, tau) -> NDArray[np.float64]:
    r = _rot(s.axis[idx], s.rate_rad_s[idx] * tau)
    c0 = s.c0[idx]
    nav = (s.frame[idx] == _NAV)[:, None, None]
    return np.where(nav, r @ c0, c0 @ r)


def _segment_mount_rate(s: RotationScheme, idx, tau) -> NDArray[np.float64]:
    w = s.axis[idx] * s.rate_rad_s[idx][:, None]
    c = _segment_attitude(s, idx, tau)
    w_nav_axis = np.einsum("nji,nj->ni", c, w)  # C^T (w axis_n)
    return np.where((s.frame[idx] == _NAV)[:, None], w_nav_axis, w)


def _snap(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Remove rounding from attitudes that are whole multiples of 90 deg (indexing positions)."""
    r = np.round(c)
    return r if np.allclose(c, r, atol=1e-9) else c


def _build(name: str, moves: list[tuple[float, NDArray, int, float]], span_s: float,
           cycle_s: float, params: dict, c_start: NDArray | None = None) -> RotationScheme:
    """Tile ``[0, span_s]`` with the cycle ``moves`` = [(duration, axis, frame, rate)]."""
    starts, durs, c0s, axes, frames, rates = [], [], [], [], [], []
    c = np.eye(3) if c_start is None else c_start
    t = 0.0
    k = 0
    while t < span_s - 1e-9:
        d, axis, frame, rate = moves[k % len(moves)]
        d = min(d, span_s - t)
        starts.append(t)
        durs.append(d)
        c0s.append(c)
        axes.append(axis)
        frames.append(frame)
        rates.append(rate)
        r = _rot(axis[None, :], np.array([rate * d]))[0]
        c = _snap(r @ c if frame == _NAV else c @ r)
        t += d
        k += 1
    return RotationScheme(name, np.array(starts), np.array(durs), np.array(c0s), np.array(axes),
                          np.array(frames, dtype=np.int64), np.array(rates), float(cycle_s),
                          params)


def _check_span(span_s: float) -> float:
    if not (math.isfinite(span_s) and span_s > 0):
        raise InputError(f"the simulated span must be positive and finite, got {span_s} s")
    return float(span_s)


def _check_rate(rate_rad_s: float, scheme: str) -> float:
    if not math.isfinite(rate_rad_s) or rate_rad_s == 0:
        raise InputError(
            f"scheme {scheme!r} modulates by turning the IMU, but the rotation rate is "
            f"{rate_rad_s} rad/s; give a non-zero rate (e.g. --rate-deg-s 6) or use scheme "
            "'none' for a static IMU"
        )
    return abs(float(rate_rad_s))


def _check_cycle(cycle_s: float, span_s: float, scheme: str) -> None:
    if cycle_s > span_s * (1 + 1e-12):
        raise InputError(
            f"one cycle of scheme {scheme!r} lasts {cycle_s:g} s, longer than the simulated span "
            f"{span_s:g} s: nothing is averaged over a whole period; simulate longer, turn "
            "faster or dwell shorter"
        )


def make_scheme(
    name: str,
    span_s: float,
    *,
    rate_rad_s: float = 0.0,
    dwell_s: float = 0.0,
    heading_rad: float = 0.0,
    alternate: bool = False,
    revolutions: int = 1,
) -> RotationScheme:
    """Build a rotation scheme covering ``[0, span_s]`` (module docstring, tables).

    Parameters
    ----------
    name : {"none", "single-axis", "four-position", "sixteen-position"}
        The scheme.
    span_s : float
        Simulated span [s]; must hold at least one whole cycle of a rotating scheme.
    rate_rad_s : float
        Rotation rate [rad/s]: of the continuous rotation, or of the turns between indexing
        positions. Must be non-zero unless ``name == "none"``; the sign sets the first turn's
        direction of ``single-axis`` (the tables fix the indexing directions).
    dwell_s : float
        Dwell at each indexing position [s] (> 0 for the indexing schemes).
    heading_rad : float
        Fixed azimuth of the static IMU's x axis from east, counter-clockwise [rad] (``none``).
    alternate : bool
        ``single-axis``: reverse the direction after every ``revolutions`` whole turns.
    revolutions : int
        Whole turns per direction when alternating (>= 1).
    """
    span_s = _check_span(span_s)
    params = {"rate_rad_s": float(rate_rad_s), "dwell_s": float(dwell_s)}
    if name == "none":
        c = _snap(_rot(_EZ[None, :], np.array([float(heading_rad)]))[0])
        return _build(name, [(span_s, _EZ, _NAV, 0.0)], span_s, math.inf,
                      {"heading_rad": float(heading_rad)}, c_start=c)
    if name not in SCHEMES:
        raise InputError(f"unknown rotation scheme {name!r}; use one of {', '.join(SCHEMES)}")
    w = _check_rate(rate_rad_s, name)
    if name == "single-axis":
        period = 2 * math.pi / w
        sign = math.copysign(1.0, rate_rad_s)
        params.update(alternate=bool(alternate), revolutions=int(revolutions))
        if alternate:
            if int(revolutions) < 1:
                raise InputError(f"revolutions per direction must be >= 1, got {revolutions}")
            leg = int(revolutions) * period
            cycle = 2 * leg
            _check_cycle(cycle, span_s, name)
            moves = [(leg, _EZ, _NAV, sign * w), (leg, _EZ, _NAV, -sign * w)]
        else:
            cycle = period
            _check_cycle(cycle, span_s, name)
            moves = [(span_s, _EZ, _NAV, sign * w)]
        return _build(name, moves, span_s, cycle, params)
    if not (math.isfinite(dwell_s) and dwell_s > 0):
        raise InputError(f"scheme {name!r} needs a positive dwell time, got {dwell_s} s "
                         "(e.g. --dwell-s 60)")
    if name == "four-position":
        turns = [(math.radians(a), _EZ, _NAV) for a in FOUR_POSITION_TURNS_DEG]
    else:
        turns = [(math.radians(a), _EZ if ax == "z" else _EX, _NAV if ax == "z" else _BODY)
                 for ax, a in SIXTEEN_POSITION_ORDERS]
    moves = []
    for angle, axis, frame in turns:
        moves.append((dwell_s, axis, frame, 0.0))
        moves.append((abs(angle) / w, axis, frame, math.copysign(w, angle)))
    cycle = sum(m[0] for m in moves)
    _check_cycle(cycle, span_s, name)
    return _build(name, moves, span_s, cycle, params)


# --------------------------------------------------------------------------------------------
# IMU errors and the navigation-frame inputs u(t)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImuErrors:
    """IMU errors fixed in the body frame, SI.

    The gyro and accelerometer errors are those of the triad model
    (:class:`inertest.models.triad.TriadErrors`: conventions, index order and units written
    there); build them from the model with :meth:`from_triads`.

    Attributes
    ----------
    gyro_drift : (3,)
        Constant drift ``eps0`` [rad/s] on body x, y, z.
    gyro_drift_rate : (3,)
        Linear drift trend ``eps1`` [rad/s^2]: drift ``eps0 + eps1 t``.
    accel_bias : (3,)
        Accelerometer bias [m/s^2].
    gyro_scale_factor : (3,)
        Gyro scale-factor errors dK [-] (ppm x 1e-6).
    gyro_misalignment : (3, 3)
        Off-diagonal gyro misalignment (non-orthogonality) [rad]: entry (i, j) is ``M_ij`` of
        the triad model, the sensitivity of gyro i to the rate about body axis j; zero diagonal.
    accel_scale_factor : (3,)
        Accelerometer scale-factor errors [-].
    """

    gyro_drift: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    gyro_drift_rate: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    accel_bias: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    gyro_scale_factor: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    gyro_misalignment: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    accel_scale_factor: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        for name, shape in (("gyro_drift", (3,)), ("gyro_drift_rate", (3,)),
                            ("accel_bias", (3,)), ("gyro_scale_factor", (3,)),
                            ("gyro_misalignment", (3, 3)), ("accel_scale_factor", (3,))):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise InputError(f"IMU error {name} must be finite with shape {shape}, got "
                                 f"{np.shape(getattr(self, name))}")
            object.__setattr__(self, name, a.copy())
        triad.check_misalignment(self.gyro_misalignment, "gyro_misalignment")

    @classmethod
    def from_triads(
        cls,
        gyro: triad.TriadErrors | None = None,
        accel: triad.TriadErrors | None = None,
        *,
        gyro_drift_rate: ArrayLike = (0.0, 0.0, 0.0),
    ) -> ImuErrors:
        """From the triad model's errors: gyro (bias = drift), accelerometer, drift trend.

        The accelerometer misalignment is not part of this analysis (only the horizontal bias
        and scale factor enter); a non-zero one is refused rather than dropped.
        """
        g = gyro if gyro is not None else triad.TriadErrors()
        a = accel if accel is not None else triad.TriadErrors()
        if np.any(a.misalignment != 0):
            raise InputError("rotation modulation does not model accelerometer misalignment; "
                             "give the accelerometer triad's scale factors and bias only")
        return cls(gyro_drift=g.bias, gyro_drift_rate=np.asarray(gyro_drift_rate, dtype=float),
                   accel_bias=a.bias, gyro_scale_factor=g.scale_deviation,
                   gyro_misalignment=g.misalignment, accel_scale_factor=a.scale_deviation)

    @property
    def gyro_triad(self) -> triad.TriadErrors:
        """The gyro errors as the triad model's :class:`~inertest.models.triad.TriadErrors`."""
        return triad.TriadErrors(self.gyro_scale_factor, self.gyro_misalignment, self.gyro_drift)

    @property
    def gyro_matrix(self) -> NDArray[np.float64]:
        """``M_g = diag(dK) + misalignment`` [-] (:func:`inertest.models.triad.error_matrix`)."""
        return triad.error_matrix(self.gyro_scale_factor, self.gyro_misalignment)

    def to_dict(self) -> dict[str, object]:
        """Each error with its SI unit (JSON)."""
        return {
            "gyro_drift": {"value": self.gyro_drift.tolist(), "unit": "rad/s"},
            "gyro_drift_rate": {"value": self.gyro_drift_rate.tolist(), "unit": "rad/s^2"},
            "accel_bias": {"value": self.accel_bias.tolist(), "unit": "m/s^2"},
            "gyro_scale_factor": {"value": self.gyro_scale_factor.tolist(), "unit": "1"},
            "accel_scale_factor": {"value": self.accel_scale_factor.tolist(), "unit": "1"},
            "gyro_misalignment": {"value": self.gyro_misalignment.tolist(), "unit": "rad"},
        }


def _inputs(site: InsSite, imu: ImuErrors, c: NDArray, w_nb_b: NDArray,
            eps_b: NDArray) -> NDArray[np.float64]:
    """Navigation-frame inputs (n, 5) for attitudes ``c`` (n, 3, 3), mount rate and drift."""
    lat, w, g = site.latitude_rad, site.earth_rate_rad_s, site.gravity_m_s2
    w_ie_n = np.array([0.0, w * math.cos(lat), w * math.sin(lat)])
    f_n = np.array([0.0, 0.0, g])
    w_ib_b = np.einsum("nji,j->ni", c, w_ie_n) + w_nb_b
    dw_b = eps_b + w_ib_b @ imu.gyro_matrix.T
    df_b = imu.accel_bias + np.einsum("nji,j->ni", c, f_n) * imu.accel_scale_factor
    dw_n = np.einsum("nij,nj->ni", c, dw_b)
    df_n = np.einsum("nij,nj->ni", c, df_b)
    return np.hstack([df_n[:, :2], dw_n])


def navigation_inputs(site: InsSite, scheme: RotationScheme, imu: ImuErrors,
                      t: ArrayLike) -> NDArray[np.float64]:
    """Inputs ``u(t) = [bE, bN, eE, eN, eU]`` [m/s^2, m/s^2, rad/s x 3], shape (n, 5).

    Evaluated directly from ``C_b^n(t)`` (module docstring equations); the vertical
    accelerometer error is dropped (vertical channel not modelled).
    """
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    c = scheme.attitude(tt)
    eps = imu.gyro_drift + np.outer(tt, imu.gyro_drift_rate)
    return _inputs(site, imu, c, scheme.mount_rate_body(tt), eps)


def mean_attitude(scheme: RotationScheme, t0_s: float, t1_s: float) -> NDArray[np.float64]:
    """Exact time average of ``C_b^n`` over ``[t0_s, t1_s]``, shape (3, 3).

    A constant body-frame error ``v`` reaches the navigation frame with the mean
    ``mean_attitude @ v`` over the window; rotation cancels what this maps to zero.
    """
    if not t1_s > t0_s:
        raise InputError(f"the averaging window must have t1 > t0, got [{t0_s}, {t1_s}] s")
    total = np.zeros((3, 3))
    for k in range(scheme.start_s.size):
        a = max(t0_s, scheme.start_s[k])
        b = min(t1_s, scheme.start_s[k] + scheme.duration_s[k])
        if b <= a:
            continue
        ta, tb = a - scheme.start_s[k], b - scheme.start_s[k]
        w = scheme.rate_rad_s[k]
        if w == 0:
            total += scheme.c0[k] * (tb - ta)
            continue
        # R(w tau) = (I + K^2) + sin(w tau) K - cos(w tau) K^2 (Rodrigues), integrated.
        kx = _skew(scheme.axis[k])
        k2 = kx @ kx
        int_r = ((np.eye(3) + k2) * (tb - ta)
                 - (math.cos(w * tb) - math.cos(w * ta)) / w * kx
                 - (math.sin(w * tb) - math.sin(w * ta)) / w * k2)
        total += int_r @ scheme.c0[k] if scheme.frame[k] == _NAV else scheme.c0[k] @ int_r
    return total / (t1_s - t0_s)


def _skew(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


# --------------------------------------------------------------------------------------------
# Exact propagation
# --------------------------------------------------------------------------------------------

_NFIT = 10


def _basis(w: float, tau: NDArray[np.float64]) -> NDArray[np.float64]:
    """[1, cos w tau, sin w tau, cos 2w tau, sin 2w tau], shape (n, 5)."""
    a = w * tau
    return np.column_stack([np.ones_like(tau), np.cos(a), np.sin(a), np.cos(2 * a),
                            np.sin(2 * a)])


def _generator(w: float) -> NDArray[np.float64]:
    """``Omega`` with ``d/dtau basis = Omega basis``."""
    g = np.zeros((5, 5))
    g[1, 2], g[2, 1] = -w, w
    g[3, 4], g[4, 3] = -2 * w, 2 * w
    return g


def _segment_fits(site: InsSite, scheme: RotationScheme, imu: ImuErrors, k: int):
    """Input coefficients of segment k on the basis: ``[G0]`` or ``[G0, G1]`` (ramp), (5, m)."""
    w = float(scheme.rate_rad_s[k])
    t_s = float(scheme.start_s[k])
    if w == 0:
        tau = np.zeros(1)
        bas = np.ones((1, 1))
    else:
        tau = np.arange(_NFIT) * (2 * math.pi / abs(w)) / _NFIT
        bas = _basis(w, tau)
    idx = np.full(tau.size, k)
    c = _segment_attitude(scheme, idx, tau)
    wnb = _segment_mount_rate(scheme, idx, tau)
    u0 = _inputs(site, imu, c, wnb, imu.gyro_drift + t_s * imu.gyro_drift_rate)
    fits = [_fit(bas, u0)]
    if np.any(imu.gyro_drift_rate != 0):
        u1 = np.zeros_like(u0)
        u1[:, 2:] = np.einsum("nij,j->ni", c, imu.gyro_drift_rate)
        fits.append(_fit(bas, u1))
    return fits, bas[0]


def _segment_system(site: InsSite, scheme: RotationScheme, imu: ImuErrors, k: int):
    """Augmented matrix ``[[A, B G0, B G1], [0, Gen]]`` and initial basis state of segment k."""
    w = float(scheme.rate_rad_s[k])
    fits, b0 = _segment_fits(site, scheme, imu, k)
    m = b0.size
    gen = np.zeros((1, 1)) if w == 0 else _generator(w)
    if len(fits) == 2:
        gen = np.block([[gen, np.zeros((m, m))], [np.eye(m), gen]])
    nz = gen.shape[0]
    aug = np.zeros((_NX + nz, _NX + nz))
    aug[:_NX, :_NX] = system_matrix(site)
    aug[:_NX, _NX:] = input_matrix() @ np.hstack(fits)
    aug[_NX:, _NX:] = gen
    z0 = np.zeros(nz)
    z0[:m] = b0
    return aug, z0


def _fit(bas: NDArray, u: NDArray) -> NDArray[np.float64]:
    """Coefficients G (5 inputs x m basis) with ``u = bas @ G.T``; exact for these inputs."""
    if bas.shape[1] == 1:
        return u[:1].T.copy()
    g, *_ = np.linalg.lstsq(bas, u, rcond=None)
    scale = np.max(np.abs(u)) if u.size else 0.0
    if np.max(np.abs(bas @ g - u), initial=0.0) > 1e-9 * scale + 1e-300:
        raise RuntimeError("internal: input not in the harmonic span (report a bug)")
    return g.T


def propagate_rotating(
    site: InsSite,
    scheme: RotationScheme,
    imu: ImuErrors,
    t: ArrayLike,
    *,
    x0: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Exact INS error history (n, 7) of a rotating (or static) IMU at times ``t`` [s].

    Parameters
    ----------
    site : InsSite
        Linearisation point of the error equations.
    scheme : RotationScheme
        From :func:`make_scheme`; must cover ``t``.
    imu : ImuErrors
        Body-frame IMU errors.
    t : array_like, shape (n,)
        Increasing sample times [s] from the initial state at ``t = 0``.
    x0 : array_like, shape (7,), optional
        Initial errors ``[dVE, dVN, dL, dlambda, phiE, phiN, phiU]``, SI; zero when omitted.

    Returns
    -------
    ndarray, shape (n, 7)
        States at ``t``, SI (module docstring: per-segment matrix exponentials, no step error).

    Notes
    -----
    Steps equal to 1e-9 s within segments with the same system share one matrix exponential
    (a periodic scheme on a uniform grid needs a few per segment of one cycle); 24 h at 1 s
    takes well under a second.
    """
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    if tt.ndim != 1 or tt.size == 0 or not np.all(np.isfinite(tt)):
        raise InputError("times must be a non-empty 1-D array of finite seconds")
    if tt[0] < 0 or np.any(np.diff(tt) < 0):
        raise InputError("times must be >= 0 and increasing")
    if tt[-1] > scheme.span_s * (1 + 1e-12) + 1e-9:
        raise InputError(f"the last time {tt[-1]:g} s is beyond the scheme's span "
                         f"{scheme.span_s:g} s; build the scheme for the whole span")
    x = np.zeros(_NX) if x0 is None else np.asarray(x0, dtype=float).copy()
    if x.shape != (_NX,) or not np.all(np.isfinite(x)):
        raise InputError(f"x0 must be 7 finite SI values, got shape {x.shape}")
    # Balanced units (as in ins_errors): velocities over sqrt(g R) keep expm accurate.
    v = math.sqrt(site.gravity_m_s2 * site.radius_m)
    out = np.empty((tt.size, _NX))
    ends = scheme.start_s + scheme.duration_s
    # Output samples of segment k: start <= t < end (the last segment also takes t == end).
    seg_of = np.clip(np.searchsorted(scheme.start_s, tt, side="right") - 1, 0, ends.size - 1)
    bounds = np.searchsorted(seg_of, np.arange(ends.size + 1), side="left")
    cache: dict[tuple[bytes, int], NDArray] = {}
    systems: dict[tuple, tuple[NDArray, NDArray]] = {}
    ramp = bool(np.any(imu.gyro_drift_rate != 0))
    d = np.ones(_NX)
    d[:2] = v
    for k in range(ends.size):
        # Without a drift trend a segment's system depends only on its attitude and motion,
        # which periodic schemes repeat: build each once.
        skey = None if ramp else (scheme.c0[k].tobytes(), scheme.axis[k].tobytes(),
                                  int(scheme.frame[k]), float(scheme.rate_rad_s[k]))
        if skey is not None and skey in systems:
            aug, z = systems[skey]
        else:
            aug, z = _segment_system(site, scheme, imu, k)
            da = np.ones(aug.shape[0])
            da[:_NX] = d
            aug = aug * da[None, :] / da[:, None]
            if skey is not None:
                systems[skey] = (aug, z)
        tag = aug.tobytes()
        y = np.concatenate([x / d, z])
        taus = tt[bounds[k]:bounds[k + 1]] - scheme.start_s[k]
        hs = np.diff(np.r_[0.0, taus, scheme.duration_s[k]])
        # Steps equal to 1e-9 s share one exponential (keys in ns); zero steps are skipped.
        keys = np.rint(hs * 1e9).astype(np.int64).tolist()
        hs = hs.tolist()
        last = len(keys) - 1 if k + 1 < ends.size else len(keys) - 2
        for j in range(last + 1):
            if keys[j] != 0:
                phi = cache.get((tag, keys[j]))
                if phi is None:
                    phi = cache[(tag, keys[j])] = scipy.linalg.expm(aug * hs[j])
                y = phi @ y
            if j < len(keys) - 1:
                out[bounds[k] + j] = y[:_NX]
        x = y[:_NX] * d
    out[:, :2] *= v
    return out


def cycle_mean_inputs(site: InsSite, scheme: RotationScheme,
                      imu: ImuErrors) -> NDArray[np.float64]:
    """Mean navigation-frame inputs over the first whole cycle, ``[bE, bN, eE, eN, eU]`` (5,).

    What the scheme leaves of the IMU's constant errors: an equivalent constant bias [m/s^2]
    and drift [rad/s] that the INS integrates as if the IMU were static (sensor output errors
    resolved in ENU; the drift enters ``phi'`` with a minus sign). Exact (integrals of
    the harmonic fit of each segment). The drift trend ``gyro_drift_rate`` is left out (it is
    not constant; see the module notes for its first-order residual). For ``none`` this is
    the static input itself. Entries below 1e-12 of the IMU's error scale are rounding of a
    cancelled term and are returned as 0.
    """
    const = ImuErrors(gyro_drift=imu.gyro_drift, accel_bias=imu.accel_bias,
                      gyro_scale_factor=imu.gyro_scale_factor,
                      gyro_misalignment=imu.gyro_misalignment,
                      accel_scale_factor=imu.accel_scale_factor)
    cycle = scheme.span_s if math.isinf(scheme.cycle_s) else scheme.cycle_s
    total = np.zeros(5)
    for k in range(scheme.start_s.size):
        t0 = float(scheme.start_s[k])
        if t0 >= cycle - 1e-9:
            break
        d = min(float(scheme.duration_s[k]), cycle - t0)
        g = _segment_fits(site, scheme, const, k)[0][0]
        w = float(scheme.rate_rad_s[k])
        if w == 0:
            integral = np.array([d])
        else:
            integral = np.array([d, math.sin(w * d) / w, (1 - math.cos(w * d)) / w,
                                 math.sin(2 * w * d) / (2 * w),
                                 (1 - math.cos(2 * w * d)) / (2 * w)])
        total += g @ integral
    mean = total / cycle
    # Cancelled terms come out as rounding (~1e-16 of the errors); return them as exact zeros.
    acc = np.max(np.abs(imu.accel_bias)) + np.max(np.abs(imu.accel_scale_factor)) * \
        site.gravity_m_s2
    gyr = np.max(np.abs(imu.gyro_drift)) + np.max(np.abs(imu.gyro_matrix)) * (
        site.earth_rate_rad_s + np.max(np.abs(scheme.rate_rad_s)))
    mean[:2][np.abs(mean[:2]) <= 1e-12 * acc] = 0.0
    mean[2:][np.abs(mean[2:]) <= 1e-12 * gyr] = 0.0
    return mean


# --------------------------------------------------------------------------------------------
# Runs, summaries, comparisons
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SystemRun:
    """INS errors of one scheme. ``x`` (n, 7) in SI at times ``t`` [s]."""

    scheme: RotationScheme
    site: InsSite
    imu: ImuErrors
    t: NDArray[np.float64]
    x: NDArray[np.float64]

    @property
    def cycle_mean_inputs(self) -> NDArray[np.float64]:
        """Equivalent constant errors left by the scheme (:func:`cycle_mean_inputs`), SI."""
        return cycle_mean_inputs(self.site, self.scheme, self.imu)

    @property
    def north_error_m(self) -> NDArray[np.float64]:
        """Latitude error as a north distance ``R dL`` [m]."""
        return self.site.radius_m * self.x[:, 2]

    @property
    def east_error_m(self) -> NDArray[np.float64]:
        """Longitude error as an east distance ``R cos L dlambda`` [m]."""
        return self.site.radius_m * math.cos(self.site.latitude_rad) * self.x[:, 3]

    @property
    def horizontal_error_m(self) -> NDArray[np.float64]:
        """Horizontal position error [m]."""
        return np.hypot(self.north_error_m, self.east_error_m)

    def summary(self) -> dict[str, float]:
        """Max |errors| over the run, SI: position [m], velocity [m/s], attitude [rad]."""
        ax = np.max(np.abs(self.x), axis=0)
        return {
            "max_horizontal_position_m": float(np.max(self.horizontal_error_m)),
            "max_north_position_m": float(np.max(np.abs(self.north_error_m))),
            "max_east_position_m": float(np.max(np.abs(self.east_error_m))),
            "max_dVE_m_s": float(ax[0]),
            "max_dVN_m_s": float(ax[1]),
            "max_phiE_rad": float(ax[4]),
            "max_phiN_rad": float(ax[5]),
            "max_phiU_rad": float(ax[6]),
        }

    @property
    def linear_model(self) -> LinearValidity:
        """How far the linear error model holds on this run (its largest attitude error)."""
        return linear_validity(self.x[:, 4:7])

    def to_dict(self) -> dict:
        """JSON-ready dict, SI with units (like ``ins-errors``)."""
        d: dict = {"scheme": self.scheme.name, "label": self.scheme.label,
                   "parameters": dict(self.scheme.parameters),
                   "cycle_s": (None if math.isinf(self.scheme.cycle_s)
                               else self.scheme.cycle_s),
                   "t": self.t.tolist()}
        for i, s in enumerate(STATES):
            d[s] = self.x[:, i].tolist()
        d["summary"] = self.summary()
        d["linear_model"] = self.linear_model.to_dict()
        d["cycle_mean_inputs"] = dict(zip(INPUTS, self.cycle_mean_inputs.tolist(), strict=True))
        d["sign_convention"] = SIGN_CONVENTION
        d["units"] = {"t": "s", **STATE_UNITS, "cycle_s": "s",
                      "max_horizontal_position_m": "m", "max_north_position_m": "m",
                      "max_east_position_m": "m", "max_dVE_m_s": "m/s", "max_dVN_m_s": "m/s",
                      "max_phiE_rad": "rad", "max_phiN_rad": "rad", "max_phiU_rad": "rad",
                      "cycle_mean_inputs": dict(INPUT_UNITS)}
        return d


def run_scheme(site: InsSite, scheme: RotationScheme, imu: ImuErrors, t: ArrayLike,
               *, x0: ArrayLike | None = None) -> SystemRun:
    """Propagate and wrap in a :class:`SystemRun`."""
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    return SystemRun(scheme, site, imu, tt, propagate_rotating(site, scheme, imu, tt, x0=x0))


def compare_schemes(
    site: InsSite,
    imu: ImuErrors,
    t: ArrayLike,
    *,
    rate_rad_s: float,
    dwell_s: float,
    heading_rad: float = 0.0,
) -> list[SystemRun]:
    """Run every scheme on the same IMU errors and grid ``t`` (from 0 to the span) [s].

    Schemes: none, single-axis (one way and alternating), four-position, sixteen-position,
    with the same rate [rad/s] and dwell [s].
    """
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    span = float(tt[-1])
    schemes = [
        make_scheme("none", span, heading_rad=heading_rad),
        make_scheme("single-axis", span, rate_rad_s=rate_rad_s),
        make_scheme("single-axis", span, rate_rad_s=rate_rad_s, alternate=True),
        make_scheme("four-position", span, rate_rad_s=rate_rad_s, dwell_s=dwell_s),
        make_scheme("sixteen-position", span, rate_rad_s=rate_rad_s, dwell_s=dwell_s),
    ]
    return [run_scheme(site, s, imu, tt) for s in schemes]


# --------------------------------------------------------------------------------------------
# White noise: covariance and Monte Carlo
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SystemStudy:
    """Navigation errors of an INS whose IMU turns on a mount (``modulation system``).

    Attributes
    ----------
    latitude_deg : float
        Site latitude [deg].
    imu : ImuErrors
    runs : tuple of SystemRun
        One run per scheme (several with ``compare``).
    compare : bool
        Every scheme on the same IMU errors (the JSON lists the runs).
    """

    latitude_deg: float
    imu: ImuErrors
    runs: tuple[SystemRun, ...]
    compare: bool = False

    kind = "modulation-system"

    def to_dict(self) -> dict[str, object]:
        """The ``modulation-system`` result envelope (SI, with units)."""
        common = {"latitude_deg": self.latitude_deg, "imu": self.imu.to_dict(),
                  "vertical_channel": "not modelled"}
        result = ({**common, "runs": [r.to_dict() for r in self.runs]} if self.compare
                  else {**common, **self.runs[0].to_dict()})
        return envelope(self.kind, site={"latitude_deg": self.latitude_deg}, result=result,
                        messages=self.messages)

    @property
    def messages(self) -> list[str]:
        """Warnings: each run whose attitude error leaves the linear model's range."""
        return [f"{r.scheme.label}: {r.linear_model.message}" if self.compare
                else str(r.linear_model.message) for r in self.runs if not r.linear_model.valid]


def _discrete(site: InsSite, dt: float) -> tuple[NDArray, NDArray]:
    """``F = e^{A dt}``, ``G = int_0^dt e^{A s} ds B`` (zero-order hold)."""
    aug = np.zeros((_NX + 5, _NX + 5))
    aug[:_NX, :_NX] = system_matrix(site)
    aug[:_NX, _NX:] = input_matrix()
    v = math.sqrt(site.gravity_m_s2 * site.radius_m)
    d = np.ones(_NX + 5)
    d[[0, 1, _NX, _NX + 1]] = v
    phi = scipy.linalg.expm(aug * d[None, :] / d[:, None] * dt) * d[:_NX + 5, None] / d[None, :]
    return phi[:_NX, :_NX], phi[:_NX, _NX:]


def _noise_grid(t: ArrayLike) -> tuple[NDArray, float]:
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    dts = np.diff(tt)
    if tt.size < 2 or tt[0] != 0 or not np.allclose(dts, dts[0], rtol=1e-9) or dts[0] <= 0:
        raise InputError("noise propagation needs a uniform time grid starting at 0 s")
    return tt, float(dts[0])


def static_noise_covariance(site: InsSite, t: ArrayLike, *, gyro_psd: ArrayLike,
                            accel_psd: ArrayLike) -> NDArray[np.float64]:
    """Covariance (n, 7, 7) of the INS errors driven by white noise, static IMU (body = nav).

    ``gyro_psd`` (3,) [rad^2/s] (angle random walk squared) and ``accel_psd`` (3,)
    [(m/s)^2/s] (velocity random walk squared) are the one-sided densities on E, N, U. The
    noise is held constant over each step (zero-order hold, variance ``psd / dt``), the same
    discretisation as :func:`monte_carlo_noise`: ``P+ = F P F^T + G (Q / dt) G^T``.
    """
    tt, dt = _noise_grid(t)
    f, g = _discrete(site, dt)
    q = np.diag(np.concatenate([np.asarray(accel_psd, float)[:2], np.asarray(gyro_psd, float)]))
    qd = g @ (q / dt) @ g.T
    p = np.zeros((tt.size, _NX, _NX))
    for i in range(1, tt.size):
        p[i] = f @ p[i - 1] @ f.T + qd
    return p


#: Realisations per task of :func:`monte_carlo_noise` (fixed, so that a serial run and one on
#: an executor do the same arithmetic on the same shapes: equal bit for bit).
MC_CHUNK = 32
#: Time steps drawn at once per realisation (memory O(MC_CHUNK * MC_STEPS), not O(steps)).
MC_STEPS = 4096


def monte_carlo_noise(site: InsSite, scheme: RotationScheme, t: ArrayLike, *,
                      gyro_psd: ArrayLike, accel_psd: ArrayLike, runs: int,
                      rng: np.random.Generator | int | None = None,
                      executor: Any = None) -> NDArray[np.float64]:
    """Final INS errors (runs, 7) of ``runs`` realisations of body-frame white noise.

    Each step's noise sample (variance ``psd / dt`` per body axis) is rotated by ``C_b^n`` at
    the step start and held over the step. With isotropic noise the navigation-frame noise has
    the same covariance whatever the rotation, so the result matches
    :func:`static_noise_covariance`.

    Realisation ``i`` draws its noise from its own generator, seeded by the ``i``-th child of
    ``rng``'s seed sequence (``SeedSequence.spawn``), and the realisations are computed in
    tasks of :data:`MC_CHUNK`. ``executor``: anything with ``submit(fn, *args)`` returning
    futures with ``result()`` (:class:`concurrent.futures.ProcessPoolExecutor`,
    ``dask.distributed.Client``); None runs here. Serial, pool and Dask results are identical
    bit for bit.
    """
    tt, dt = _noise_grid(t)
    if int(runs) < 1:
        raise InputError(f"Monte Carlo needs at least 1 run, got {runs!r}")
    gen = np.random.default_rng(rng)
    seed_seq = gen.bit_generator.seed_seq
    assert isinstance(seed_seq, np.random.SeedSequence)
    children = seed_seq.spawn(int(runs))
    f, g = _discrete(site, dt)
    sg = np.sqrt(np.asarray(gyro_psd, float) / dt)
    sa = np.sqrt(np.asarray(accel_psd, float) / dt)
    c = scheme.attitude(tt[:-1])
    chunks = [children[a:a + MC_CHUNK] for a in range(0, len(children), MC_CHUNK)]
    if executor is None:
        parts = [_noise_chunk(f, g, sg, sa, c, ch) for ch in chunks]
    else:
        futures = [executor.submit(_noise_chunk, f, g, sg, sa, c, ch) for ch in chunks]
        parts = [fu.result() for fu in futures]
    return np.concatenate(parts)


def _noise_chunk(f: NDArray, g: NDArray, sg: NDArray, sa: NDArray, c: NDArray,
                 seeds: list[np.random.SeedSequence]) -> NDArray[np.float64]:
    """Final errors (len(seeds), 7) of the realisations with these seeds (no BLAS: einsum)."""
    gens = [np.random.default_rng(s) for s in seeds]
    x = np.zeros((len(seeds), _NX))
    steps = c.shape[0]
    for i0 in range(0, steps, MC_STEPS):
        i1 = min(i0 + MC_STEPS, steps)
        # each generator's stream in order: the same numbers whatever MC_STEPS is
        w = np.stack([r.normal(size=(i1 - i0, 6)) for r in gens])
        for i in range(i0, i1):
            wg = w[:, i - i0, :3] * sg
            wa = w[:, i - i0, 3:] * sa
            u = np.hstack([np.einsum("rj,ij->ri", wa, c[i])[:, :2],
                           np.einsum("rj,ij->ri", wg, c[i])])
            x = np.einsum("rj,ij->ri", x, f) + np.einsum("rj,ij->ri", u, g)
    return x
