"""Systematic calibration of a navigation-grade strapdown IMU (PSINS ``kf/sysclbt.m``, and more).

The unit turns through a sequence of attitudes on a multi-axis table (the 19-position scheme of
Xie Bo, "Multiposition calibration method of laser gyro SINS", JCIT 2011; the 9-position scheme;
continuous turns) and navigates at the fixed site through the whole run; during every dwell it
is at rest, so its navigation-mode velocity error is the observation. One batch least squares
determines every term of :mod:`inertest.models.strapdown_imu` at once: gyro ``K``, ``M`` (all
six), ``B``; accelerometer ``K``, ``M`` (three: the accelerometers define the frame), ``B``;
the second-order coefficients ``K2a``; the accelerometers' inner lever arms; the gyro-
accelerometer time asynchrony ``tGA``; optionally the gyro g-sensitivity and asymmetric scale
factors; and the initial attitude (a nuisance).

Steps (SI inside; :mod:`inertest.estimation.strapdown` for the navigation)
--------------------------------------------------------------------------
1. **Reduce.** The rates (increments / dt, or rate columns) are checked (NaN, gaps,
   saturation against the plan's ranges); the dwells are found from the gyros (the rate
   averaged over ``window_s``, less the first second's, above ``motion_threshold_deg_s`` is a
   turn), shortened by ``settle_s`` at each end, and checked against the plan's ``turns``: the
   number of turns and each turn's rotation (the integrated rates on the body axes) must match
   the plan's axis and angle. The first dwell aligns the unit (level from the accelerometers,
   heading from the gyros) and must last ``min_first_dwell_s``. The white noise of each
   channel comes from the dwells (half the mean square of successive differences).
2. **Navigate.** The record, corrected with the current model, is navigated at the site with
   the position fixed; the pseudo-velocity at ``points_per_dwell`` block ends spread over each
   dwell (blocks of ``block_s``) is the observation (zero for the right model).
3. **Gauss-Newton.** Linear sensitivities of those observations to every state (the error
   equations of PSINS's ``Ft``, solved exactly per block) give the step; iterated until every
   step is below 1e-4 of its standard uncertainty (at most ``max_iterations``); the residuals
   always come from the full nonlinear navigation, so the solution is that of the nonlinear
   equations.
4. **Noise and covariance.** The observations' covariance is propagated from the sensors'
   noise through the same equations: white (from the data, or the plan's ``gyro_arw_deg_rt_h``,
   ``acc_vrw_ug_rt_hz``), and a slow bias process (``noise_model``): ``random-walk`` (rate
   random walk ``gyro_rrw_deg_h_rt_h``, ``acc_rrw_ug_rt_s``) or ``flicker`` (bias instability
   ``gyro_bias_instability_deg_h``, ``acc_bias_instability_ug``), the kernels of
   :mod:`inertest.estimation.noise_models`. Levels not given are fitted by REML to the
   residuals (``auto`` keeps white noise unless a component improves the restricted
   likelihood by the test of :mod:`inertest.estimation.selection`). Generalised least squares
   gives the full covariance ``(J^T V^-1 J)^-1``; the model checks
   (:func:`inertest.estimation.model_checks.model_checks`) test the whitened residuals, and a
   model that does not fit scales the covariance by ``chi^2 / dof`` (said in the messages).
5. **Identifiability.** What the sequence determines is decided from the turns and gravity
   alone (the Jacobian with the Earth rate removed, whose 15 deg/h would otherwise lend a
   weak, meaningless determination to anything): a state in its null space is not estimated;
   the combinations of such states that the sequence does determine are reported with their
   std, and ``not_separable`` says which and why (a sequence without turns about x cannot see
   the gyros' response to rate about x).

Conventions: :mod:`inertest.models.strapdown_imu` (triad model, ``M_ij`` sensor i / axis j,
bias adds to the output; PSINS's ``sysclbt``/``imuclbt`` structs by
:func:`~inertest.models.strapdown_imu.psins_sysclbt`). Data: ``dtheta_x..z`` [rad] and
``dv_x..z`` [m/s] per sample (PSINS increments), or ``gyr_x..z`` [gyr_unit], ``acc_x..z``
[acc_unit]; optional ``t_s`` [s].
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from inertest.earth import earth_rate_enu
from inertest.equipment.turn_sequence import (
    Turn,
    TurnSequence,
    attitude_from_pitch_roll_yaw,
    parse_turn,
)
from inertest.errors import DataError, IdentifiabilityError, PlanError
from inertest.estimation import strapdown as nav
from inertest.estimation.identify import combination_name
from inertest.estimation.least_squares import identifiable_combinations
from inertest.estimation.model_checks import CHECK_ALPHA, model_checks
from inertest.estimation.noise_models import BIAS_TIME_SCALE_DEFAULT
from inertest.models import strapdown_imu as sim
from inertest.models import triad
from inertest.models.imu import CouplingTerms, ImuCalibration
from inertest.models.triad import AXES
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure
from inertest.procedures.spec import check_time_gaps, require_columns
from inertest.results import Combination, Estimate, Identification, LinearTestResult
from inertest.results.triad import TriadEstimates
from inertest.units import (
    ACCEL_UNITS,
    DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S,
    DEG_PER_H_TO_RAD_PER_S,
    DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S,
    DEG_TO_RAD,
    G0,
    MICRO_G_TO_M_PER_S2,
    RATE_UNITS,
)

KIND = "systematic"
INC_COLUMNS = ("dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z")
RATE_COLUMNS = ("gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z")
NOISE_MODELS = ("auto", "white", "random-walk", "flicker")
#: A turn's measured rotation may miss the plan's by this much (and this fraction) [deg].
TURN_TOLERANCE_DEG = 5.0
TURN_TOLERANCE_REL = 0.05
#: A dwell's mean |f| farther than this fraction from the site's gravity is refused.
GRAVITY_TOLERANCE = 0.05
#: Gauss-Newton stops when every step is below this fraction of its std.
STEP_TOLERANCE = 1e-4
#: A direction the data determine with a std above this many typical errors is not determined.
WORST_STD = 1e3
#: Typical error of a state, per unit: the scale of the structural identifiability analysis.
TYPICAL = {"1": 1e-4, "urad": 100.0, "deg/h": 1.0, "mg": 1.0, "ug/g^2": 100.0, "mm": 10.0,
           "ms": 1.0, "deg/h/g": 1.0, "ppm": 100.0}
#: A direction of typical errors whose effect on the navigation errors, the Earth rate left
#: out, is below this fraction of the largest is not determined by the sequence.
STRUCTURAL_RCOND = 1e-5
#: A channel whose white noise is below this fraction of its typical value is noise-free.
NOISE_FLOOR = 1e-7


@dataclass(frozen=True)
class SystematicSpec:
    """``[procedure]`` of a systematic calibration (module docstring; FIELDS for units)."""

    kind: ClassVar[str] = KIND
    sample_rate_hz: float
    turns: tuple[str, ...] = ()
    turn_angle_deg: float = 90.0
    turn_angles_deg: tuple[float, ...] = ()
    gyr_unit: str = "rad/s"
    acc_unit: str = "m/s^2"
    motion_threshold_deg_s: float = 0.5
    window_s: float = 1.0
    settle_s: float = 1.0
    min_dwell_s: float = 5.0
    min_first_dwell_s: float = 10.0
    points_per_dwell: int = 5
    block_s: float = 1.0
    max_iterations: int = 10
    noise_model: str = "auto"
    bias_time_scale: float = BIAS_TIME_SCALE_DEFAULT
    gyro_arw_deg_rt_h: float | None = None
    acc_vrw_ug_rt_hz: float | None = None
    gyro_rrw_deg_h_rt_h: float | None = None
    acc_rrw_ug_rt_s: float | None = None
    gyro_bias_instability_deg_h: float | None = None
    acc_bias_instability_ug: float | None = None
    gyro_range_deg_s: float | None = None
    acc_range_g: float | None = None
    second_order: bool = True
    lever_arms: str = "xy"
    time_asynchrony: bool = True
    g_sensitivity: bool = False
    asymmetric_scale: bool = False
    initial_pitch_roll_yaw_deg: tuple[float, ...] = (0.0, 0.0, 0.0)
    turn_s: float = 9.0
    first_dwell_s: float = 70.0
    dwell_s: float = 40.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> SystematicSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        spec = cls(**read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                                 ignore=("kind",)))
        for t in spec.turns:
            parse_turn(t)
        if spec.turn_angles_deg and len(spec.turn_angles_deg) != len(spec.turns):
            raise PlanError(f"[procedure] of kind {KIND}: turn_angles_deg has "
                            f"{len(spec.turn_angles_deg)} entries for {len(spec.turns)} turns; "
                            "give one angle per turn (or turn_angle_deg for all)")
        if len(spec.initial_pitch_roll_yaw_deg) != 3:
            raise PlanError(f"[procedure] of kind {KIND}: initial_pitch_roll_yaw_deg needs "
                            "three angles [deg]")
        if spec.block_s * spec.sample_rate_hz < 1:
            raise PlanError(f"[procedure] of kind {KIND}: block_s = {spec.block_s:g} s is "
                            "shorter than one sample; raise it")
        return spec

    @property
    def states(self) -> sim.StateSet:
        """The states this plan estimates."""
        return sim.StateSet(second_order=self.second_order, lever_arms=self.lever_arms,
                            time_asynchrony=self.time_asynchrony,
                            g_sensitivity=self.g_sensitivity,
                            asymmetric_scale=self.asymmetric_scale)

    def planned_turns(self) -> list[tuple[int, float]]:
        """(body axis, signed angle [rad]) of each turn of the plan."""
        angles = self.turn_angles_deg or (self.turn_angle_deg,) * len(self.turns)
        out = []
        for t, a in zip(self.turns, angles, strict=True):
            axis, sign = parse_turn(t)
            out.append((axis, sign * a * DEG_TO_RAD))
        return out


FIELDS = (
    Field("sample_rate_hz", positive=True, unit="Hz", doc="sample rate"),
    Field("turns", "texts", default=(), doc='body axis of each turn, "+y", "-x", ...'),
    Field("turn_angle_deg", default=90.0, unit="deg", doc="angle of every turn"),
    Field("turn_angles_deg", "numbers", default=(), unit="deg", doc="angle of each turn"),
    Field("gyr_unit", "text", default="rad/s", choices=tuple(RATE_UNITS)),
    Field("acc_unit", "text", default="m/s^2", choices=tuple(ACCEL_UNITS)),
    Field("motion_threshold_deg_s", default=0.5, positive=True, unit="deg/s",
          doc="rate above which the unit is turning"),
    Field("window_s", default=1.0, positive=True, unit="s", doc="rate averaging window"),
    Field("settle_s", default=1.0, minimum=0.0, unit="s", doc="time left out at dwell ends"),
    Field("min_dwell_s", default=5.0, positive=True, unit="s", doc="shortest dwell"),
    Field("min_first_dwell_s", default=10.0, positive=True, unit="s",
          doc="shortest first dwell (alignment)"),
    Field("points_per_dwell", "integer", default=5, minimum=2, doc="observations per dwell"),
    Field("block_s", default=1.0, positive=True, unit="s", doc="block of the observations"),
    Field("max_iterations", "integer", default=10, minimum=1, doc="Gauss-Newton iterations"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
    Field("bias_time_scale", default=BIAS_TIME_SCALE_DEFAULT, minimum=1.0,
          unit="test durations", doc="time scale of the flicker model"),
    Field("gyro_arw_deg_rt_h", default=None, positive=True, unit="deg/sqrt(h)"),
    Field("acc_vrw_ug_rt_hz", default=None, positive=True, unit="ug/sqrt(Hz)"),
    Field("gyro_rrw_deg_h_rt_h", default=None, minimum=0.0, unit="deg/h/sqrt(h)"),
    Field("acc_rrw_ug_rt_s", default=None, minimum=0.0, unit="ug/sqrt(s)"),
    Field("gyro_bias_instability_deg_h", default=None, minimum=0.0, unit="deg/h"),
    Field("acc_bias_instability_ug", default=None, minimum=0.0, unit="ug"),
    Field("gyro_range_deg_s", default=None, positive=True, unit="deg/s",
          doc="gyro full scale (saturation check)"),
    Field("acc_range_g", default=None, positive=True, unit="g",
          doc="accelerometer full scale (saturation check)"),
    Field("second_order", "bool", default=True),
    Field("lever_arms", "text", default="xy", choices=("xy", "xyz", "none")),
    Field("time_asynchrony", "bool", default=True),
    Field("g_sensitivity", "bool", default=False),
    Field("asymmetric_scale", "bool", default=False),
    Field("initial_pitch_roll_yaw_deg", "numbers", default=(0.0, 0.0, 0.0), unit="deg",
          doc="simulation: attitude of the first dwell (PSINS convention)"),
    Field("turn_s", default=9.0, positive=True, unit="s", doc="simulation: turn time"),
    Field("first_dwell_s", default=70.0, positive=True, unit="s",
          doc="simulation: first dwell"),
    Field("dwell_s", default=40.0, positive=True, unit="s", doc="simulation: dwell after turns"),
)

#: Plan keys of the noise levels and their SI factor: white density, random walk, flicker.
_WHITE_KEYS = (("gyro_arw_deg_rt_h", DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S),
               ("acc_vrw_ug_rt_hz", MICRO_G_TO_M_PER_S2))
_RW_KEYS = (("gyro_rrw_deg_h_rt_h", DEG_PER_H_PER_SQRT_H_TO_RAD_PER_S_PER_SQRT_S),
            ("acc_rrw_ug_rt_s", MICRO_G_TO_M_PER_S2))
_FLICKER_KEYS = (("gyro_bias_instability_deg_h", DEG_PER_H_TO_RAD_PER_S),
                 ("acc_bias_instability_ug", MICRO_G_TO_M_PER_S2))
#: Truth keys of a simulation's noise (same names and units as the plan's).
NOISE_TRUTH_KEYS = tuple(k for k, _ in _WHITE_KEYS + _RW_KEYS + _FLICKER_KEYS)


# --- reduction --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Dwell:
    """One dwell found in the data: ``[start, end)`` samples (after settling) and its blocks."""

    start: int
    end: int
    observed_blocks: tuple[int, ...]


@dataclass(frozen=True)
class TurnCheck:
    """One turn found in the data against the plan.

    ``start_s``, ``end_s`` [s]; ``rotation_deg`` the integrated raw rates on the body axes
    [deg]; ``planned`` the plan's ``(axis, angle_deg)`` or None when the plan gives no turns.
    """

    start_s: float
    end_s: float
    rotation_deg: tuple[float, float, float]
    planned: tuple[str, float] | None


@dataclass(frozen=True)
class SystematicObservations:
    """The record reduced: raw rates, the dwells, the alignment and the noise of each channel."""

    w_raw: NDArray[np.float64] = field(repr=False)
    f_raw: NDArray[np.float64] = field(repr=False)
    dt_s: float
    block: int
    dwells: tuple[Dwell, ...]
    turns: tuple[TurnCheck, ...]
    C_nb0: NDArray[np.float64]
    white_variance: NDArray[np.float64]
    white_measured: NDArray[np.float64]
    white_given: tuple[bool, ...]
    source: str = "increments"

    @property
    def observed_blocks(self) -> NDArray[np.intp]:
        """Block index of every observation, in time order."""
        return np.array([b for d in self.dwells for b in d.observed_blocks], dtype=np.intp)


def _moving_mean(x: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    if k <= 1:
        return x
    c = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x]), axis=0)
    out = np.empty_like(x)
    half = k // 2
    n = x.shape[0]
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) - half + k, 0, n)
    out[:] = (c[hi] - c[lo]) / np.maximum(hi - lo, 1)[:, None]
    return out


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``[start, end)`` of the runs of True."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(),
                    strict=True))


def _read_rates(spec: SystematicSpec, data: Mapping[str, object], source: str
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], float, str]:
    """Raw rates [rad/s] and specific forces [m/s^2], the sample interval, the columns' kind."""
    dt = 1.0 / spec.sample_rate_hz
    if all(c in data for c in INC_COLUMNS):
        cols = require_columns(data, INC_COLUMNS, (), procedure=KIND)
        w = np.column_stack([cols[c] for c in INC_COLUMNS[:3]]) / dt
        f = np.column_stack([cols[c] for c in INC_COLUMNS[3:]]) / dt
        kind = "increments"
    elif any(c in data for c in RATE_COLUMNS):
        cols = require_columns(data, RATE_COLUMNS, (), procedure=KIND)
        w = np.column_stack([cols[c] for c in RATE_COLUMNS[:3]]) * RATE_UNITS[spec.gyr_unit]
        f = np.column_stack([cols[c] for c in RATE_COLUMNS[3:]]) * ACCEL_UNITS[spec.acc_unit]
        kind = "rates"
    else:
        found = ", ".join(map(str, data)) or "none"
        raise DataError(f"{source}: {KIND} data needs the increments {', '.join(INC_COLUMNS)} "
                        f"[rad, m/s] or the rates {', '.join(RATE_COLUMNS)} (found: {found})")
    if "t_s" in data:
        t = np.asarray(data["t_s"], dtype=float)
        check_time_gaps(t, name="t_s", source=source)
    return w, f, dt, kind


def _check_saturation(spec: SystematicSpec, w: NDArray[np.float64], f: NDArray[np.float64],
                      source: str) -> None:
    for name, x, rng, unit, to_unit in (
            ("gyro", w, spec.gyro_range_deg_s, "deg/s", 1 / DEG_TO_RAD),
            ("accelerometer", f, spec.acc_range_g, "g", 1 / G0)):
        if rng is None:
            continue
        hit = np.abs(x) * to_unit >= rng * (1 - 1e-3)
        if np.any(hit):
            row, ch = np.argwhere(hit)[0]
            raise DataError(
                f"{source}: the {name} {AXES[ch]} reaches its range {rng:g} {unit} at data row "
                f"{row + 1} ({x[row, ch] * to_unit:.6g} {unit}): a saturated reading loses "
                f"rotation or force; turn slower (turn_s) or use a unit with a larger range")


def _detect(spec: SystematicSpec, w: NDArray[np.float64], dt: float, source: str
            ) -> list[tuple[int, int]]:
    """Dwells ``[start, end)`` in samples (before settling), from the gyros.

    The first must be the rest at the start of the recording, at least ``min_first_dwell_s``
    long (the alignment); later ones at least ``min_dwell_s``.
    """
    n = w.shape[0]
    k = max(1, int(round(spec.window_s / dt)))
    ref = w[:max(1, min(n, int(round(1.0 / dt))))].mean(axis=0)
    rate = np.linalg.norm(_moving_mean(w - ref, k), axis=1)
    still = _runs(rate < spec.motion_threshold_deg_s * DEG_TO_RAD)
    first = still[0] if still and still[0][0] == 0 else (0, 0)
    length = (first[1] - first[0]) * dt
    if length < spec.min_first_dwell_s:
        raise DataError(
            f"{source}: the recording rests {length:.3g} s before the first turn; the "
            f"alignment needs at least min_first_dwell_s = {spec.min_first_dwell_s:g} s at rest "
            "from the start: record a longer first dwell (PSINS's 19-position scheme rests "
            "70 s) or start the recording earlier")
    runs = [first] + [(a, b) for a, b in still[1:] if (b - a) * dt >= spec.min_dwell_s]
    return runs


def _turn_checks(spec: SystematicSpec, runs: list[tuple[int, int]], w: NDArray[np.float64],
                 dt: float, source: str) -> tuple[TurnCheck, ...]:
    planned = spec.planned_turns()
    found = len(runs) - 1
    if planned and found != len(planned):
        starts = ", ".join(f"{b * dt:.1f}" for _, b in runs[:-1][:8])
        raise DataError(
            f"{source}: the data hold {found} turn(s) (starting at t = {starts}"
            f"{' ...' if found > 8 else ''} s), the plan lists {len(planned)}: make the plan's "
            "turns match the recording (or check motion_threshold_deg_s and min_dwell_s)")
    out = []
    for j in range(found):
        a, b = runs[j][1], runs[j + 1][0]
        rot = w[a:b].sum(axis=0) * dt / DEG_TO_RAD
        rot = rot - w[runs[j][0]:runs[j][1]].mean(axis=0) * (b - a) * dt / DEG_TO_RAD
        plan = None
        if planned:
            axis, ang = planned[j]
            want = np.zeros(3)
            want[axis] = ang / DEG_TO_RAD
            tol = max(TURN_TOLERANCE_DEG, TURN_TOLERANCE_REL * abs(want[axis]))
            if np.max(np.abs(rot - want)) > tol:
                raise DataError(
                    f"{source}: turn {j + 1} (t = {a * dt:.1f} to {b * dt:.1f} s) turned "
                    f"({rot[0]:+.1f}, {rot[1]:+.1f}, {rot[2]:+.1f}) deg about the body x, y, z "
                    f"axes; the plan's turn {j + 1} is {want[axis]:+g} deg about "
                    f"{AXES[axis]} ({spec.turns[j]}): fix the plan's turns (or the data's axis "
                    "order and signs); a saturated gyro also loses angle")
            plan = (spec.turns[j], float(want[axis]))
        out.append(TurnCheck(a * dt, b * dt, (float(rot[0]), float(rot[1]), float(rot[2])),
                             plan))
    return tuple(out)


def _observation_blocks(a: int, b: int, m: int, points: int) -> tuple[int, ...]:
    """Up to ``points`` block ends spread over the samples ``[a, b)`` (whole blocks inside)."""
    first = -(-a // m)
    last = b // m - 1
    if last < first:
        return ()
    cand = np.arange(first, last + 1)
    if cand.size <= points:
        return tuple(int(c) for c in cand)
    pick = np.unique(np.round(np.linspace(0, cand.size - 1, points)).astype(int))
    return tuple(int(c) for c in cand[pick])


def coarse_alignment(f: NDArray[np.float64], w: NDArray[np.float64],
                     latitude_rad: float) -> NDArray[np.float64]:
    """``C_nb`` from the mean specific force and rate at rest: up from f, east from w x up.

    Raises DataError when the rate does not resolve a heading (gyros too poor to gyrocompass).
    """
    up = f / np.linalg.norm(f)
    east = np.cross(w, up)
    horizontal = np.linalg.norm(east)
    if not horizontal > 0.2 * np.linalg.norm(earth_rate_enu(latitude_rad)) * np.cos(
            latitude_rad):
        raise DataError("the first dwell's rates do not show the Earth's horizontal rate: the "
                        "gyros cannot find north (too noisy or biased for a systematic "
                        "calibration), or the site latitude is wrong")
    east = east / horizontal
    north = np.cross(up, east)
    return np.vstack([east, north, up])


def _noise_floor() -> NDArray[np.float64]:
    """Per-sample noise below which a channel is noise-free: 1e-7 of the Earth rate, of g0."""
    return NOISE_FLOOR * np.r_[np.full(3, np.linalg.norm(earth_rate_enu(0.0))), np.full(3, G0)]


def _white_noise(spec: SystematicSpec, w: NDArray[np.float64], f: NDArray[np.float64],
                 dwells: Sequence[tuple[int, int]]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], tuple[bool, ...]]:
    """Per-sample variance of each channel: the plan's, else half the mean square difference."""
    x = np.hstack([w, f])
    sq = np.zeros(6)
    count = 0
    for a, b in dwells:
        if b - a >= 2:
            sq += np.sum(np.diff(x[a:b], axis=0) ** 2, axis=0)
            count += b - a - 1
    measured = sq / (2 * max(count, 1))
    var = np.maximum(measured, _noise_floor() ** 2)
    given = [False] * 6
    for k, (key, si) in enumerate(_WHITE_KEYS):
        level = getattr(spec, key)
        if level is not None:
            var[3 * k:3 * k + 3] = (level * si) ** 2 * spec.sample_rate_hz
            given[3 * k:3 * k + 3] = [True] * 3
    return var, measured, tuple(given)


# --- the Jacobian -----------------------------------------------------------------------------

#: A state whose unit vector lies this far into the structural null space is not determined.
NULL_PARTICIPATION = 0.05


def _with_undetermined_directions(null: NDArray[np.float64], Q: NDArray[np.float64],
                                 Je: NDArray[np.float64], Ja: NDArray[np.float64],
                                 L: NDArray[np.float64]) -> NDArray[np.float64]:
    """``null`` with the directions of ``Q`` the data determine worse than the limit.

    States in typical errors; the initial attitude estimated with them; the limit
    :data:`WORST_STD` typical errors: the heading, seen through the Earth rate alone, against
    the horizontal gyro biases in a single attitude; anything the noise buries.
    """
    if Q.shape[1] == 0:
        return null
    D = scipy.linalg.solve_triangular(L, np.hstack([Je @ Q, Ja]), lower=True)
    cn = np.linalg.norm(D, axis=0)
    cn[cn == 0] = 1.0
    _, sv, vt = np.linalg.svd(D / cn, full_matrices=False)
    # the full inverse (no pseudo-inverse: a direction the attitude takes away must show)
    half = (vt.T / np.maximum(sv, 1e-300 * sv[0])) / cn[:, None]
    cov = (half @ half.T)[:Q.shape[1], :Q.shape[1]]
    w, U = np.linalg.eigh(0.5 * (cov + cov.T))
    bad = U[:, w > WORST_STD**2]
    if not bad.size:
        return null
    u, s2, _ = np.linalg.svd(np.hstack([null, Q @ bad]), full_matrices=False)
    return np.asarray(u[:, s2 > 1e-9 * s2[0]])


def _structural_split(null: NDArray[np.float64], P: int
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Determined directions ``Q``, the null space ``N`` and the determined states.

    The null space of the discrete structural Jacobian carries traces (below
    :data:`NULL_PARTICIPATION`) of states it does not involve in continuous time (a common
    lever arm cancels between dwells only to the order of the sampling): it is restricted to
    the states that take part in it and made orthonormal again.
    """
    if null.shape[1] == 0:
        return np.eye(P), np.zeros((P, 0)), np.ones(P, dtype=bool)
    part = np.linalg.norm(null, axis=1)
    determined = part < NULL_PARTICIPATION
    N = np.where(determined[:, None], 0.0, null)
    u, sv, _ = np.linalg.svd(N, full_matrices=True)
    d = int(np.sum(sv > 1e-6 * sv[0]))
    return u[:, d:], u[:, :d], determined


def _turn_rates(w: NDArray[np.float64], threshold: float, margin: int) -> NDArray[np.float64]:
    """The rates of the turns alone: zero at rest, and zero on the axes a turn does not use.

    A turn is a run of samples whose rate exceeds ``threshold`` [rad/s], widened by ``margin``
    samples at each end (so that it starts and ends near zero); within it, an axis whose peak
    rate is below a tenth of the turn's peak (noise, a gyro's response to another axis) is
    set to zero.
    """
    moving = np.linalg.norm(w, axis=1) > threshold
    out = np.zeros_like(w)
    n = w.shape[0]
    for a, b in _runs(moving):
        a, b = max(0, a - margin), min(n, b + margin)
        peak = np.abs(w[a:b]).max(axis=0)
        keep = peak > 0.1 * peak.max()
        out[a:b, keep] = w[a:b, keep]
    return out


#: One parameter's inputs to a triad: ``(index of a motion series, direction (3,))`` pairs.
_Terms = list[tuple[int, NDArray[np.float64]]]


@dataclass
class _ParameterInputs:
    """How each SI parameter enters the gyro and accelerometer error rates.

    ``gyro_series`` and ``acc_series``: scalar series of the motion, (n,) each; parameter p
    adds ``series[k] * d`` to the rate error of the triad for each ``(k, d)`` of
    ``gyro_terms[p]`` and ``acc_terms[p]``.
    """

    gyro_series: list[NDArray[np.float64]]
    acc_series: list[NDArray[np.float64]]
    gyro_terms: list[_Terms] = field(default_factory=list)
    acc_terms: list[_Terms] = field(default_factory=list)

    def add(self, gyro: _Terms, acc: _Terms) -> None:
        """One parameter, in terms of the series already there."""
        self.gyro_terms.append(gyro)
        self.acc_terms.append(acc)

    def acc_param(self, series: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]]
                  ) -> None:
        """An accelerometer parameter entering through new series ``(series, direction)``."""
        terms = []
        for s, d in series:
            self.acc_series.append(s)
            terms.append((len(self.acc_series) - 1, d))
        self.add([], terms)

    def gyro_param(self, series: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]]
                   ) -> None:
        """A gyro parameter entering through new series ``(series, direction)``."""
        terms = []
        for s, d in series:
            self.gyro_series.append(s)
            terms.append((len(self.gyro_series) - 1, d))
        self.add(terms, [])


def _structural_motion(nv: nav.Navigation, w: NDArray[np.float64], threshold: float
                       ) -> tuple[nav.Navigation, NDArray[np.float64], NDArray[np.float64]]:
    """The navigation, rates and lever matrices of the turns alone (see :func:`_jacobian`)."""
    w = _turn_rates(w - np.einsum("nji,j->ni", nv.C_nb, nv.w_ie), threshold,
                    int(round(1.0 / nv.dt_s)))
    W = sim.lever_matrix(w, sim.angular_acceleration(w, nv.dt_s))
    # the local frame fixed in inertial space: the body's attitude is its local one
    nv = dataclasses.replace(nv, E=np.broadcast_to(np.eye(3), nv.E.shape).copy(),
                             C_ib=nv.C_nb)
    return nv, w, W


def _base_parameters(inputs: _ParameterInputs, model: sim.StrapdownImu) -> None:
    """The gyro scale and misalignment, gyro biases, accelerometer ``S_a`` terms and biases."""
    Sgi = np.asarray(np.linalg.inv(model.S_g), dtype=np.float64)
    Sai = np.asarray(np.linalg.inv(model.S_a), dtype=np.float64)
    for a in range(3):
        for b in range(3):
            inputs.add([(b, -Sgi[:, a])], [])
    for a in range(3):
        inputs.add([(3, -Sgi[:, a])], [])
    for i, j in sim.ACC_FREE:
        inputs.add([], [(j, -Sai[:, i])])
    for a in range(3):
        inputs.add([], [(3, -Sai[:, a])])


def _optional_parameters(inputs: _ParameterInputs, states: sim.StateSet, corr: sim.Corrected,
                         n: int, w: NDArray[np.float64], w1: NDArray[np.float64],
                         W: NDArray[np.float64]) -> None:
    """The states of ``states`` beyond the base ones, in the order of ``states.names()``."""
    v, f1, f = corr.v[:n], corr.f1[:n], corr.force[:n]
    eye = np.eye(3)
    if states.second_order:
        for i in range(3):
            inputs.acc_param([(v[:, i] ** 2, -eye[i])])
    for i in states.lever_rows:
        for c in range(3):
            inputs.acc_param([(W[:, i, c], -eye[i])])
    if states.time_asynchrony:
        wf = np.cross(w1, f1)
        inputs.acc_param([(wf[:, i], -eye[i]) for i in range(3)])
    if states.g_sensitivity:
        for a in range(3):
            for b in range(3):
                inputs.gyro_param([(f[:, b], -eye[a])])
    if states.asymmetric_scale:
        for a in range(3):
            inputs.gyro_param([(np.abs(w[:, a]), -eye[a])])
        for i in range(3):
            inputs.acc_param([(np.abs(v[:, i]), -eye[i])])


def _error_inputs(nv: nav.Navigation, inputs: _ParameterInputs) -> nav.ErrorInputs:
    """Each parameter's block moments of the gyro and accelerometer errors, (blocks, 3, P)."""
    G = np.column_stack(inputs.gyro_series)
    A = np.column_stack(inputs.acc_series)
    Mg = nav.block_moments(nv, G, weighted=False)
    Mgw = nav.block_moments(nv, G, weighted=True)
    Ma = nav.block_moments(nv, A, weighted=False)
    P = len(inputs.gyro_terms)
    nb = nv.n_blocks
    gs = np.zeros((nb, 3, P))
    gw = np.zeros((nb, 3, P))
    ac = np.zeros((nb, 3, P))
    for p in range(P):
        for k, d in inputs.gyro_terms[p]:
            gs[:, :, p] += Mg[:, k] @ d
            gw[:, :, p] += Mgw[:, k] @ d
        for k, d in inputs.acc_terms[p]:
            ac[:, :, p] += Ma[:, k] @ d
    return nav.ErrorInputs(gs, gw, ac)


def _jacobian(nv: nav.Navigation, corr: sim.Corrected, model: sim.StrapdownImu,
              states: sim.StateSet, blocks: NDArray[np.intp], *,
              structural: float | None = None) -> NDArray[np.float64]:
    """d(observations)/d(SI parameters, then the 3 attitude angles): shape (3k, P + 3).

    ``structural`` (a rate threshold [rad/s]): what the turns and gravity alone determine:
    the Earth rate left out (the local frame not turning) and each rate component below the
    threshold (the noise at rest, a gyro's response to another axis's turn) set to zero.
    """
    n = nv.n_blocks * nv.block
    w = corr.w0[:n]
    w1, W = corr.w1[:n], corr.W[:n]
    if structural is not None:
        nv, w, W = _structural_motion(nv, w, structural)
        w1 = w
    v = corr.v[:n]
    one = np.ones(n)
    inputs = _ParameterInputs([w[:, 0], w[:, 1], w[:, 2], one],
                              [v[:, 0], v[:, 1], v[:, 2], one])
    _base_parameters(inputs, model)
    _optional_parameters(inputs, states, corr, n, w, w1, W)
    P = len(inputs.gyro_terms)
    resp = nav.propagate(nv, _error_inputs(nv, inputs))[blocks]  # (k, 3 (axis), P)
    att = nav.attitude_sensitivity(nv)[blocks].transpose(0, 2, 1)  # (k, 3 (axis), 3 (j))
    J = np.concatenate([resp, att], axis=2)
    return np.asarray(J.reshape(3 * blocks.size, P + 3))


# --- noise of the observations ----------------------------------------------------------------

@dataclass(frozen=True)
class NoiseLevels:
    """Noise of each channel (:data:`inertest.estimation.strapdown.CHANNELS`), SI.

    ``white``: variance per sample [(rad/s)^2, (m/s^2)^2]; ``model``: ``white``,
    ``random-walk`` or ``flicker``; ``slow``: the rate random walk density [unit/sqrt(s)]
    or the bias instability [unit] of each channel; ``slow_source``: ``"given"`` (plan),
    ``"fitted"`` (REML) or ``"none"``; ``weights``: Akaike weights of ``auto``.
    """

    white: NDArray[np.float64]
    model: str = "white"
    slow: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6))
    slow_source: str = "none"
    weights: Mapping[str, float] = field(default_factory=dict)

    def components(self, dt_s: float) -> dict[str, float]:
        """Mean level of each component over the gyros and over the accelerometers.

        Keyed by names that carry their unit (``noise.components`` of the identification).
        """
        dens = np.sqrt(self.white * dt_s)
        out = {"gyro angle random walk [deg/sqrt(h)]":
               float(np.mean(dens[:3]) / DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S),
               "accelerometer velocity random walk [ug/sqrt(Hz)]":
               float(np.mean(dens[3:]) / MICRO_G_TO_M_PER_S2)}
        if self.model == "random-walk":
            out["gyro rate random walk [deg/h/sqrt(h)]"] = float(
                np.mean(self.slow[:3]) / _RW_KEYS[0][1])
            out["accelerometer bias random walk [ug/sqrt(s)]"] = float(
                np.mean(self.slow[3:]) / _RW_KEYS[1][1])
        elif self.model == "flicker":
            out["gyro bias instability [deg/h]"] = float(
                np.mean(self.slow[:3]) / _FLICKER_KEYS[0][1])
            out["accelerometer bias instability [ug]"] = float(
                np.mean(self.slow[3:]) / _FLICKER_KEYS[1][1])
        return out

    def to_dict(self, dt_s: float) -> dict[str, object]:
        """JSON block: white densities and the slow component, per channel, with units."""
        dens = np.sqrt(self.white * dt_s)
        out: dict[str, object] = {
            "model": self.model,
            "white": {"gyro": {"value": (dens[:3] / DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S).tolist(),
                               "unit": "deg/sqrt(h)"},
                      "accelerometer": {"value": (dens[3:] / MICRO_G_TO_M_PER_S2).tolist(),
                                        "unit": "ug/sqrt(Hz)"}},
            "slow_source": self.slow_source,
        }
        if self.model == "random-walk":
            out["random_walk"] = {
                "gyro": {"value": (self.slow[:3] / _RW_KEYS[0][1]).tolist(),
                         "unit": "deg/h/sqrt(h)"},
                "accelerometer": {"value": (self.slow[3:] / _RW_KEYS[1][1]).tolist(),
                                  "unit": "ug/sqrt(s)"}}
        elif self.model == "flicker":
            out["bias_instability"] = {
                "gyro": {"value": (self.slow[:3] / _FLICKER_KEYS[0][1]).tolist(),
                         "unit": "deg/h"},
                "accelerometer": {"value": (self.slow[3:] / _FLICKER_KEYS[1][1]).tolist(),
                                  "unit": "ug"}}
        if self.weights:
            out["selection_weights"] = dict(self.weights)
        return out


def _given_slow(spec: SystematicSpec) -> tuple[str, NDArray[np.float64]] | None:
    """The slow bias process the plan gives levels for, if any (random walk or flicker)."""
    for model, keys in (("random-walk", _RW_KEYS), ("flicker", _FLICKER_KEYS)):
        levels = [getattr(spec, k) for k, _ in keys]
        if any(v is not None for v in levels):
            lv = np.repeat([(v or 0.0) * si for v, (_, si) in zip(levels, keys, strict=True)], 3)
            return model, lv
    return None


def _restricted_nll(r: NDArray[np.float64], X: NDArray[np.float64], V: NDArray[np.float64]
                    ) -> float:
    """Negative restricted log-likelihood of residuals ``r`` of design ``X`` (scale known)."""
    try:
        L = np.linalg.cholesky(V)
    except np.linalg.LinAlgError:
        return float("inf")
    Xw = scipy.linalg.solve_triangular(L, X, lower=True)
    rw = scipy.linalg.solve_triangular(L, r, lower=True)
    q, rr = np.linalg.qr(Xw)
    res = rw - q @ (q.T @ rw)
    d = np.abs(np.diag(rr))
    return float(np.sum(np.log(np.diag(L))) + np.sum(np.log(d[d > 0])) + 0.5 * res @ res)


def _fit_slow(r: NDArray[np.float64], X: NDArray[np.float64], V_white: NDArray[np.float64],
              kernels: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64]]]
              ) -> dict[str, tuple[float, NDArray[np.float64]]]:
    """REML of the gyro and accelerometer levels of each slow model: ``{model: (nll, (g, a))}``.

    ``kernels[model]``: the observations' covariance per unit level squared of the gyros and of
    the accelerometers. White noise (``nll`` at zero levels) under ``"white"``.
    """
    import scipy.optimize

    out = {"white": (_restricted_nll(r, X, V_white), np.zeros(2))}
    scale = float(np.mean(np.diag(V_white)))
    for name, (Kg, Ka) in kernels.items():
        sg = scale / max(float(np.mean(np.diag(Kg))), 1e-300)
        sa = scale / max(float(np.mean(np.diag(Ka))), 1e-300)

        def nll(z: NDArray[np.float64], Kg: NDArray = Kg, Ka: NDArray = Ka, sg: float = sg,
                sa: float = sa) -> float:
            return _restricted_nll(r, X, V_white + sg * np.exp(z[0]) * Kg
                                   + sa * np.exp(z[1]) * Ka)

        best = (out["white"][0], np.array([-30.0, -30.0]))
        for z0 in ((-4.0, -4.0), (0.0, 0.0), (3.0, 3.0), (0.0, -8.0), (-8.0, 0.0)):
            val = nll(np.array(z0))
            if val < best[0]:
                best = (val, np.array(z0))
        opt = scipy.optimize.minimize(nll, best[1], method="Nelder-Mead",
                                      options={"xatol": 1e-3, "fatol": 1e-4, "maxiter": 400})
        z = opt.x if opt.fun < best[0] else best[1]
        levels = np.array([sg * np.exp(z[0]), sa * np.exp(z[1])])
        levels[levels < 1e-12 * np.array([sg, sa])] = 0.0
        out[name] = (float(min(opt.fun, best[0])), np.sqrt(levels))
    return out


# --- the result -------------------------------------------------------------------------------

@dataclass(frozen=True)
class DwellResidual:
    """Residual pseudo-velocity of one dwell's observations after calibration.

    ``start_s``, ``end_s`` [s] (the part used); ``time_s`` (k,) of each observation;
    ``residual_m_s`` (k, 3) ENU [m/s]; ``rms_m_s`` (3,) [m/s].
    """

    start_s: float
    end_s: float
    time_s: NDArray[np.float64]
    residual_m_s: NDArray[np.float64]

    @property
    def rms_m_s(self) -> NDArray[np.float64]:
        """RMS of the residual per axis [m/s]."""
        return np.asarray(np.sqrt(np.mean(self.residual_m_s**2, axis=0)))


@dataclass(frozen=True, kw_only=True)
class SystematicResult(LinearTestResult):
    """Result of a systematic calibration.

    Attributes (beyond :class:`~inertest.results.LinearTestResult`)
    ----------------------------------------------------------------
    model : StrapdownImu
        The estimated error model (states not determined at their nominal values).
    states : StateSet
    calibration : ImuCalibration
        What ``inertest apply`` corrects a recording with.
    triads : tuple of TriadEstimates
        The gyro and accelerometer triads in the triad model's layout (when fully determined).
    dwells : tuple of DwellResidual
    turns : tuple of TurnCheck
    velocity_time_s, velocity_m_s : ndarray
        Pseudo-velocity of the calibrated navigation at every block end [s], [m/s] (ENU).
    initial_attitude_deg : tuple of float
        Pitch, roll, yaw of the first dwell found (PSINS convention) [deg].
    iterations : int
        Gauss-Newton iterations.
    noise : NoiseLevels
    dt_s : float
    """

    model: sim.StrapdownImu = field(repr=False)
    states: sim.StateSet
    calibration: ImuCalibration
    triads: tuple[TriadEstimates, ...]
    dwells: tuple[DwellResidual, ...] = field(repr=False)
    turns: tuple[TurnCheck, ...] = field(repr=False)
    velocity_time_s: NDArray[np.float64] = field(repr=False)
    velocity_m_s: NDArray[np.float64] = field(repr=False)
    initial_attitude_deg: tuple[float, float, float]
    iterations: int
    noise: NoiseLevels = field(repr=False)
    dt_s: float
    procedure: str = KIND

    def psins(self) -> dict[str, dict[str, object]]:
        """The estimate as PSINS's structs (``sysclbt`` correction, ``imuclbt`` generator)."""
        def block(d: Mapping[str, object]) -> dict[str, object]:
            return {k: (np.asarray(v).tolist() if not isinstance(v, float) else v)
                    for k, v in d.items()}

        units = {"Kg": "1", "Ka": "1", "eb": "deg/h", "db": "ug (PSINS: 1e-6 x 9.7803267714 "
                 "m/s^2)", "Ka2": "ug/g^2 (PSINS g = 9.7803267714 m/s^2)", "rx": "m", "ry": "m",
                 "rz": "m", "tGA": "s"}
        return {"sysclbt": {**block(sim.psins_sysclbt(self.model)), "units": units},
                "imuclbt": {**block(sim.psins_imuclbt(self.model)), "units": units}}

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` of the envelope)."""
        d: dict[str, object] = {"calibration": self.calibration.to_dict()}
        if self.triads:
            d["triads"] = {t.sensor: t.to_dict() for t in self.triads}
        d["states"] = list(self.states.names())
        d["psins"] = self.psins()
        d["initial_attitude"] = {"pitch_roll_yaw": list(self.initial_attitude_deg),
                                 "unit": "deg", "convention": "PSINS: C_nb = Rz(yaw) Rx(pitch) "
                                 "Ry(roll), ENU"}
        d["sequence"] = [
            {"start": {"value": t.start_s, "unit": "s"}, "end": {"value": t.end_s, "unit": "s"},
             "rotation": {"value": list(t.rotation_deg), "unit": "deg", "axes": "body x, y, z"},
             "planned": None if t.planned is None else {"turn": t.planned[0],
                                                        "angle": t.planned[1], "unit": "deg"}}
            for t in self.turns]
        d["dwells"] = [
            {"start": {"value": w.start_s, "unit": "s"}, "end": {"value": w.end_s, "unit": "s"},
             "observations": int(w.time_s.size),
             "residual_rms": {"value": w.rms_m_s.tolist(), "unit": "m/s", "axes": "E, N, U"}}
            for w in self.dwells]
        d["iterations"] = self.iterations
        d["noise"] = self.noise.to_dict(self.dt_s)
        return d


# --- the procedure ----------------------------------------------------------------------------

def _si_of_engineering(x: NDArray[np.float64], names: tuple[str, ...],
                       states: sim.StateSet) -> NDArray[np.float64]:
    return sim.to_parameters(sim.from_engineering(dict(zip(names, x, strict=True)), states),
                             states)


def _explain(names: Sequence[str], missing: Sequence[str], turned: set[int],
             states: sim.StateSet) -> list[str]:
    """Plain-language statements of what the sequence cannot determine."""
    out = []
    left = list(missing)
    for j, ax in enumerate(AXES):
        group = [f"Kg_{ax}"] + [f"Mg_{a}{ax}" for a in AXES if a != ax]
        hit = [g for g in group if g in left]
        if hit and j not in turned:
            out.append(f"{', '.join(hit)} (the gyros' response to rate about body {ax}): the "
                       f"sequence has no turn about {ax}, so only the Earth rate (at most "
                       f"15 deg/h) acts about {ax}; add turns about {ax} (the 19-position "
                       "scheme has them)")
            left = [n for n in left if n not in hit]
    common_g = [f"Gg_{a}{a}" for a in AXES]
    if all(n in left for n in common_g):
        out.append(f"{', '.join(common_g)}: a g-sensitivity common to the three gyros is a rate "
                   "error along the specific force, about the vertical at every dwell, which "
                   "only the Earth rate would show; only their differences are determined")
        left = [n for n in left if n not in common_g]
    levers = [n for n in left if n[0] == "r"]
    if levers and states.lever_arms == "xyz":
        out.append(f"{', '.join(levers)}: only the differences between the accelerometers' "
                   "positions are determined (a common offset of all three moves the reference "
                   "point, whose velocity is zero at every dwell); rz is the reference in "
                   'PSINS (lever_arms = "xy")')
        left = [n for n in left if n not in levers]
    if left:
        out.append(f"{', '.join(left)}: not determined by this sequence of turns (their effects "
                   "on the navigation errors cancel or coincide); only the combinations listed "
                   "are; add turns about other axes or in other attitudes")
    return out


class Systematic(Procedure[SystematicSpec, SystematicObservations, SystematicResult]):
    """Strapdown IMU, systematic calibration in navigation mode (PSINS sysclbt).

    Data: PSINS increments ``dtheta_*`` [rad], ``dv_*`` [m/s] per sample, or rates ``gyr_*``,
    ``acc_*``; the plan's ``turns`` (checked against the data). Noise of every channel from
    the dwells (or the plan); no ``sigma``.
    """

    kind = KIND
    title = "Strapdown IMU, systematic calibration (navigation mode, PSINS sysclbt)"
    spec = SystematicSpec
    model = "inertest.models.strapdown_imu"
    method = ("Gauss-Newton: generalised least squares of the navigation-mode velocity errors "
              "during the dwells, iterated on the nonlinear navigation")
    noise_models = NOISE_MODELS
    sigma_note = ("estimates the white noise of every gyro and accelerometer from the dwells "
                  "(or takes gyro_arw_deg_rt_h, acc_vrw_ug_rt_hz from the plan)")
    report = "inertest.report.systematic:systematic_sections"

    def motion(self, plan: Plan, *, type_b: Mapping[str, float] | None = None
               ) -> TurnSequence | None:
        """The plan's turn sequence at its site (None when the plan lists no turns)."""
        spec: SystematicSpec = plan.procedure
        if not spec.turns:
            return None
        turns = tuple(Turn(axis, ang, spec.turn_s) for axis, ang in spec.planned_turns())
        return TurnSequence(site=plan.site,
                            C_nb0=attitude_from_pitch_roll_yaw(spec.initial_pitch_roll_yaw_deg),
                            turns=turns, first_dwell_s=spec.first_dwell_s, dwell_s=spec.dwell_s)

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: TurnSequence | None
               ) -> SystematicObservations:
        """Rates, dwells checked against the plan's turns, alignment, white noise."""
        spec: SystematicSpec = plan.procedure
        source = f"{KIND} data"
        w, f, dt, kind = _read_rates(spec, data, source)
        _check_saturation(spec, w, f, source)
        runs = _detect(spec, w, dt, source)
        turns = _turn_checks(spec, runs, w, dt, source)
        n = w.shape[0]
        settle = int(round(spec.settle_s / dt))
        m = max(1, int(round(spec.block_s / dt)))
        dwells = []
        used = []
        for k, (a, b) in enumerate(runs):
            a2 = a + (settle if a > 0 else 0)
            b2 = b - (settle if b < n else 0)
            blocks = _observation_blocks(a2, b2, m, spec.points_per_dwell)
            if k == 0:
                blocks = tuple(sorted(set(blocks) | set(_observation_blocks(
                    a2, b2, m, 2 * spec.points_per_dwell))))
            dwells.append(Dwell(a2, b2, blocks))
            used.append((a2, b2))
            g = np.linalg.norm(f[a2:b2].mean(axis=0))
            if abs(g / plan.site.gravity_m_s2 - 1) > GRAVITY_TOLERANCE:
                raise DataError(
                    f"{source}: dwell {k + 1} (t = {a2 * dt:.1f} to {b2 * dt:.1f} s) reads |f| = "
                    f"{g:.4g} m/s^2, the site's gravity is {plan.site.gravity_m_s2:.4g}: a "
                    "saturated or mis-scaled accelerometer, or the wrong acc_unit")
        if sum(len(d.observed_blocks) for d in dwells) < 3:
            raise DataError(f"{source}: the dwells are too short for observations of "
                            f"block_s = {spec.block_s:g} s; lower block_s or dwell longer")
        a, b = used[0]
        C0 = coarse_alignment(f[a:b].mean(axis=0), w[a:b].mean(axis=0),
                              plan.site.latitude_rad)
        var, measured, given = _white_noise(spec, w, f, used)
        return SystematicObservations(w_raw=w, f_raw=f, dt_s=dt, block=m, dwells=tuple(dwells),
                                      turns=turns, C_nb0=C0, white_variance=var,
                                      white_measured=measured, white_given=given, source=kind)

    def identify(self, plan: Plan, obs: SystematicObservations, *, sigma: float | None,
                 noise_model: str | None) -> SystematicResult:
        """Gauss-Newton on the nonlinear navigation, GLS covariance, identifiability, checks."""
        spec: SystematicSpec = plan.procedure
        states = spec.states
        names = states.names()
        P = len(names)
        site = plan.site
        blocks = obs.observed_blocks
        x = sim.engineering(sim.to_parameters(sim.StrapdownImu(), states), states).real
        C0 = obs.C_nb0.copy()
        messages: list[str] = []

        chain: list[NDArray[np.float64]] = []

        def linearise(x: NDArray[np.float64], C0: NDArray[np.float64], structural: bool = False
                      ) -> tuple:
            p = _si_of_engineering(x, names, states)
            model = sim.from_parameters(p, states)
            corr = model.correct(obs.w_raw, obs.f_raw, obs.dt_s)
            nv = nav.navigate(corr.omega, corr.force, obs.dt_s, C0,
                              latitude_rad=site.latitude_rad, gravity_m_s2=site.gravity_m_s2,
                              block=obs.block)
            if not chain:  # d engineering / d SI: at the start (it moves by ppm, not more)
                chain.append(np.asarray(np.linalg.inv(sim.engineering_jacobian(p, states)[1]),
                                        dtype=np.float64))
            Dinv = chain[0]
            J = _jacobian(nv, corr, model, states, blocks)
            Js = (_jacobian(nv, corr, model, states, blocks,
                            structural=spec.motion_threshold_deg_s * DEG_TO_RAD)
                  if structural else None)
            return model, nv, nv.u[blocks].ravel(), J[:, :P] @ Dinv, J[:, P:], (
                None if Js is None else (Js[:, :P] @ Dinv, Js[:, P:]))

        model, nv, r, Je, Ja, struct = linearise(x, C0, structural=True)
        assert struct is not None
        # coordinates in units of a typical error of each state (TYPICAL): the structural
        # spectrum compares the effects of physically comparable errors, not of columns made
        # equal (a column that noise alone makes nonzero would look determined)
        unit_of = sim.units(names)
        scale = np.array([1.0 / TYPICAL[unit_of[n]] for n in names])
        Jse, Jsa = struct
        # the initial attitude's directions (without the Earth rate the heading has none: a
        # basis of what is there, not a QR that would invent a direction for it)
        ua, sa, _ = np.linalg.svd(Jsa, full_matrices=False)
        qa = ua[:, sa > 1e-9 * sa[0]] if sa.size and sa[0] > 0 else ua[:, :0]
        Jp = Jse / scale
        Jp = Jp - qa @ (qa.T @ Jp)
        _, sv, vt = np.linalg.svd(Jp, full_matrices=True)
        rank = int(np.sum(sv > STRUCTURAL_RCOND * sv[0])) if sv.size and sv[0] > 0 else 0
        null = vt[rank:].T
        V_white = nav.white_covariance(nv, blocks, obs.white_variance)
        null = _with_undetermined_directions(null, vt[:rank].T, Je / scale, Ja,
                                             np.asarray(np.linalg.cholesky(V_white),
                                                        dtype=np.float64))
        Q, N, determined = _structural_split(null, P)
        rank = Q.shape[1]
        if rank == 0:
            raise IdentifiabilityError(f"{KIND}: the sequence determines none of the states; "
                                       "the unit must turn about at least two axes")
        levels, V = self._noise(spec, nv, blocks, obs, V_white, r, np.hstack(
            [Je / scale @ Q, Ja]), noise_model or spec.noise_model)
        Lc = np.linalg.cholesky(V)

        iterations = 0
        cov_b = np.eye(rank + 3)
        for it in range(spec.max_iterations):
            iterations = it + 1
            design = np.hstack([Je / scale @ Q, Ja])
            Dw = scipy.linalg.solve_triangular(Lc, design, lower=True)
            rw = scipy.linalg.solve_triangular(Lc, r, lower=True)
            beta, *_ = np.linalg.lstsq(Dw, -rw, rcond=None)
            cov_b = np.linalg.pinv(Dw.T @ Dw)
            x = x + (Q @ beta[:rank]) / scale
            C0 = Rotation.from_rotvec(beta[rank:]).as_matrix() @ C0
            step = np.abs(beta) / np.sqrt(np.clip(np.diag(cov_b), 1e-300, None))
            model, nv, r, Je, Ja, _ = linearise(x, C0)
            if np.max(step) < STEP_TOLERANCE:
                break
        else:
            messages.append(f"Gauss-Newton did not settle in {spec.max_iterations} iterations "
                            f"(last step {np.max(step):.2g} std): raise max_iterations")
        design = np.hstack([Je / scale @ Q, Ja])
        Dw = scipy.linalg.solve_triangular(Lc, design, lower=True)
        cov_b = np.linalg.pinv(Dw.T @ Dw)
        labels = [f"dwell {i + 1} t={(b + 1) * obs.block * obs.dt_s:.0f}s {axis}"
                  for i, d in enumerate(obs.dwells) for b in d.observed_blocks
                  for axis in "ENU"]
        checks = model_checks(r, design, V, noise_model=levels.model,
                              sigma_given=levels.slow_source != "fitted",
                              labels=labels, unit="observation")
        if checks.p_value is not None and checks.p_value < CHECK_ALPHA and checks.dof > 0:
            birge = checks.chi_square / checks.dof
            cov_b = cov_b * birge
            messages.append(
                f"the residuals exceed the noise model (chi-square {checks.chi_square:.4g} for "
                f"{checks.dof} dof): the covariance is scaled by chi-square/dof = {birge:.3g} "
                "so the uncertainties reflect the misfit (noise-free or simulated data with "
                "model approximations, an unmodelled term, or noise beyond the model)")
        cov_x = (Q @ cov_b[:rank, :rank] @ Q.T) / np.outer(scale, scale)
        units = sim.units(names)
        std = np.sqrt(np.clip(np.diag(cov_x), 0.0, None))
        coefficients = {n: Estimate(n, float(x[i]), float(std[i]), units[n])
                        for i, n in enumerate(names) if determined[i]}
        missing = [n for i, n in enumerate(names) if not determined[i]]
        combos: list[Combination] = []
        if missing:
            cand = [i for i in range(P) if not determined[i]]
            rows = identifiable_combinations(N, cand, tol=1e-4)
            for c in rows:
                nz = np.flatnonzero(np.abs(c) > 1e-9)
                lead = nz[0]
                wts = c * scale / (c[lead] * scale[lead])
                # weights within 1e-3 of an integer are that integer (a common lever arm
                # cancels exactly in continuous time; the sampling leaves traces of 1e-4)
                near = np.abs(wts - np.round(wts)) < 1e-3
                wts[near] = np.round(wts[near])
                nz = np.flatnonzero(wts != 0)
                terms = [(names[i], float(wts[i])) for i in nz]
                val = float(wts @ x)
                s = float(np.sqrt(max(wts @ cov_x @ wts, 0.0)))
                combos.append(Combination(combination_name(terms), dict(terms), val, s,
                                          units[names[lead]]))
            turned = {int(np.argmax(np.abs(t.rotation_deg))) for t in obs.turns}
            not_sep = tuple(_explain(names, missing, turned, states))
            messages.append("the calibration keeps the states the sequence does not determine "
                            f"at their nominal values ({', '.join(missing)})")
        else:
            not_sep = ()
        ident = Identification(
            coefficients=coefficients, combinations=tuple(combos), not_separable=not_sep,
            covariance=cov_x, names=names, noise_sigma=float("nan"), noise_unit="",
            # "residuals" (from the data) unless the plan gives every level: the white noise
            # is measured on the dwells, a slow process fitted by REML
            sigma_from_residuals=(not all(obs.white_given) or levels.slow_source == "fitted"),
            dof=int(r.size - rank - 3),
            rank=rank, residuals=r, noise_model=levels.model,
            noise_components=levels.components(obs.dt_s), checks=checks,
            noise_model_weights=dict(levels.weights))
        if not np.all(obs.white_measured >= _noise_floor() ** 2):
            messages.append("the recording is noise-free (simulated?) on some channels: their "
                            "white noise is below the numeric floor, so the uncertainties come "
                            "from the residuals' scatter (the model approximations)")
        triads = self._triads(x, cov_x, names, determined)
        cal = _calibration(model, states)
        t_obs = np.asarray((blocks + 1) * obs.block * obs.dt_s, dtype=np.float64)
        res = r.reshape(-1, 3)
        dres = []
        k0 = 0
        for d in obs.dwells:
            k1 = k0 + len(d.observed_blocks)
            dres.append(DwellResidual(d.start * obs.dt_s, d.end * obs.dt_s, t_obs[k0:k1],
                                      res[k0:k1]))
            k0 = k1
        yaw, pitch, roll = Rotation.from_matrix(C0).as_euler("ZXY", degrees=True)
        return SystematicResult(
            site_latitude_deg=site.latitude_deg, site_gravity_m_s2=site.gravity_m_s2,
            identification=ident, residual_output=r, output_unit="m/s",
            messages=tuple(messages), model=model, states=states, calibration=cal,
            triads=triads, dwells=tuple(dres), turns=obs.turns,
            velocity_time_s=(np.arange(nv.n_blocks) + 1) * obs.block * obs.dt_s,
            velocity_m_s=nv.u, initial_attitude_deg=(float(pitch), float(roll), float(yaw)),
            iterations=iterations, noise=levels, dt_s=obs.dt_s)

    def _noise(self, spec: SystematicSpec, nv: nav.Navigation, blocks: NDArray[np.intp],
               obs: SystematicObservations, V_white: NDArray[np.float64],
               r: NDArray[np.float64], X: NDArray[np.float64], choice: str
               ) -> tuple[NoiseLevels, NDArray[np.float64]]:
        """The noise levels and the observations' covariance under them."""
        white = obs.white_variance
        noise_free = not np.all(obs.white_measured >= _noise_floor() ** 2)
        if choice == "white" or (choice == "auto" and noise_free):
            # noise-free data: every residual would pass for a slow process; keep white
            return NoiseLevels(white), V_white
        block_s = obs.block * obs.dt_s
        given = _given_slow(spec)
        if given is not None and (choice == "auto" or choice == given[0]):
            resp = nav.block_responses(nv, blocks)
            V = V_white + nav.correlated_covariance(resp, given[0], given[1], block_s=block_s,
                                                    bias_time_scale=spec.bias_time_scale)
            return NoiseLevels(white, given[0], given[1], "given"), V
        resp = nav.block_responses(nv, blocks)
        models = ("random-walk", "flicker") if choice == "auto" else (choice,)
        kernels = {}
        for mdl in models:
            Kg = nav.correlated_covariance(resp, mdl, np.r_[1.0, 1.0, 1.0, 0, 0, 0],
                                           block_s=block_s, bias_time_scale=spec.bias_time_scale)
            Ka = nav.correlated_covariance(resp, mdl, np.r_[0, 0, 0, 1.0, 1.0, 1.0],
                                           block_s=block_s, bias_time_scale=spec.bias_time_scale)
            kernels[mdl] = (Kg, Ka)
        fits = _fit_slow(r, X, V_white, kernels)
        if choice == "auto":
            from inertest.estimation.selection import common_noise_model

            aic = [{m: 2 * fits[m][0] + (0 if m == "white" else 2) for m in fits},
                   {m: 0.0 if m == "white" else 2.0 for m in fits}]
            best, weights, _ = common_noise_model(aic)
        else:
            best, weights = choice, {}
        if best == "white":
            return NoiseLevels(white, weights=weights), V_white
        g, a = fits[best][1]
        Kg, Ka = kernels[best]
        lv = np.r_[np.full(3, g), np.full(3, a)]
        return (NoiseLevels(white, best, lv, "fitted", weights),
                V_white + g**2 * Kg + a**2 * Ka)

    @staticmethod
    def _triads(x: NDArray[np.float64], cov: NDArray[np.float64], names: tuple[str, ...],
                determined: NDArray[np.bool_]) -> tuple[TriadEstimates, ...]:
        """The triad-model blocks of the triads every state of which is determined."""
        one = triad.ScaleUnit("1", 1.0, 1.0, 1.0)
        out = []
        for sensor, letter in (("accelerometer", "a"), ("gyroscope", "g")):
            full = [f"{n[0]}{letter}{n[1:]}" for n in triad.parameter_names()]
            idx = [names.index(n) if n in names else -1 for n in full]
            if any(i >= 0 and not determined[i] for i in idx):
                continue
            val = np.array([x[i] if i >= 0 else 0.0 for i in idx])
            C = np.zeros((12, 12))
            for a, i in enumerate(idx):
                for b, j in enumerate(idx):
                    if i >= 0 and j >= 0:
                        C[a, b] = cov[i, j]
            out.append(TriadEstimates.from_engineering(val, C, sensor=sensor, scale=one))
        return tuple(out)

    def synthesize(self, plan: Plan, motion: TurnSequence | None, truth: Mapping[str, float],
                   *, noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """PSINS-style increments of a virtual IMU turned through the plan's sequence.

        ``truth``: the result's names and units (``Kg_x`` [1], ``Mg_xy`` [urad], ``Bg_x``
        [deg/h], ``Ka_x``, ``Ma_yx``, ``Ba_x`` [mg], ``K2a_x`` [ug/g^2], ``rx_y`` [mm],
        ``tGA`` [ms], ``Gg_xy`` [deg/h/g], ``Ag_x``, ``Aa_x`` [ppm]) and the noise levels of
        the plan's keys (``gyro_arw_deg_rt_h``, ``acc_vrw_ug_rt_hz``, ``gyro_rrw_deg_h_rt_h``,
        ``acc_rrw_ug_rt_s``, ``gyro_bias_instability_deg_h``, ``acc_bias_instability_ug``).
        ``noise`` (when the truth gives no white level): white noise per reading, deg/h for
        the gyros and ug for the accelerometers. Increments are integrated exactly (3-point
        Gauss-Legendre per sample). Returns ``t_s``, ``dtheta_*`` [rad], ``dv_*`` [m/s].
        """
        spec: SystematicSpec = plan.procedure
        if motion is None:
            raise PlanError(f"[procedure] of kind {KIND} needs turns to simulate a sequence "
                            '(e.g. turns = ["+y", "+y", "-x"])')
        gen = np.random.default_rng(rng)
        levels = {k: float(truth[k]) for k in NOISE_TRUTH_KEYS if k in truth}
        coeffs = {k: float(v) for k, v in truth.items() if k not in NOISE_TRUTH_KEYS}
        everything = sim.StateSet(lever_arms="xyz", g_sensitivity=True, asymmetric_scale=True)
        model = sim.from_engineering(coeffs, everything)
        dt = 1.0 / spec.sample_rate_hz
        n = int(np.floor(motion.duration_s / dt + 1e-9))
        xg, wg = np.polynomial.legendre.leggauss(3)
        t = (np.arange(n)[:, None] + 0.5 * (xg[None, :] + 1)) * dt
        kin = motion.kinematics(t.ravel())
        w_raw, f_raw = model.raw(kin.omega, kin.domega, kin.force)
        dth = (w_raw.reshape(n, 3, 3) * wg[None, :, None]).sum(axis=1) * dt / 2
        dv = (f_raw.reshape(n, 3, 3) * wg[None, :, None]).sum(axis=1) * dt / 2
        white_g = levels.get("gyro_arw_deg_rt_h")
        white_a = levels.get("acc_vrw_ug_rt_hz")
        sg = (white_g * DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S / np.sqrt(dt) if white_g is not None
              else noise * DEG_PER_H_TO_RAD_PER_S)
        sa = (white_a * MICRO_G_TO_M_PER_S2 / np.sqrt(dt) if white_a is not None
              else noise * MICRO_G_TO_M_PER_S2)
        for x, s in ((dth, sg), (dv, sa)):
            if s > 0:
                x += gen.normal(0.0, s * dt, x.shape)
        for x, key, si in ((dth, *_RW_KEYS[0]), (dv, *_RW_KEYS[1])):
            k = levels.get(key, 0.0) * si
            if k > 0:
                x += np.cumsum(gen.normal(0.0, k * np.sqrt(dt), x.shape), axis=0) * dt
        for x, key, si in ((dth, *_FLICKER_KEYS[0]), (dv, *_FLICKER_KEYS[1])):
            b = levels.get(key, 0.0) * si
            if b > 0:
                x += flicker_noise(n, 3, b, dt, gen) * dt
        out: dict[str, NDArray] = {"t_s": (np.arange(n) + 1) * dt}
        for k in range(3):
            out[INC_COLUMNS[k]] = dth[:, k]
        for k in range(3):
            out[INC_COLUMNS[3 + k]] = dv[:, k]
        return out


def flicker_noise(n: int, channels: int, bias_instability: float, dt_s: float,
                  gen: np.random.Generator) -> NDArray[np.float64]:
    """Flicker (1/f) bias noise, one-sided PSD ``B^2 / (pi f)`` (Allan floor 0.664 B), (n, k).

    Synthesised in the frequency domain over ``2 s`` records, ``s`` the default bias time
    scale of :mod:`inertest.estimation.noise_models` (Kasdin, Proc. IEEE 83(5), 1995,
    doi:10.1109/5.381848): independent complex Gaussian lines at ``f_k = k df``,
    ``df = 1 / (2 s n dt)``, the mean line left out, so the lowest frequency is the flicker
    kernel's.
    """
    m = int(2 * BIAS_TIME_SCALE_DEFAULT * n)
    freqs = np.fft.rfftfreq(m, dt_s)
    psd = np.zeros_like(freqs)
    psd[1:] = bias_instability**2 / (np.pi * freqs[1:])
    amp = np.sqrt(psd * m / (4 * dt_s))
    z = gen.normal(size=(freqs.size, channels)) + 1j * gen.normal(size=(freqs.size, channels))
    x = np.fft.irfft(z * amp[:, None], m, axis=0)
    return np.asarray(x[:n])


def _calibration(model: sim.StrapdownImu, states: sim.StateSet) -> ImuCalibration:
    """The correction of :mod:`inertest.models.imu` (triads + the coupling terms)."""
    acc = triad.TriadCalibration(matrix=np.asarray(np.linalg.inv(model.S_a), dtype=np.float64),
                                 offset=model.b_a,
                                 unit="m/s^2", raw_unit="m/s^2")
    gyr = triad.TriadCalibration(
        matrix=np.asarray(np.linalg.inv(model.S_g), dtype=np.float64), offset=model.b_g,
        unit="rad/s", raw_unit="rad/s",
        g_sensitivity=model.S_g @ model.G if states.g_sensitivity else None)
    coupling = CouplingTerms(second_order=model.k2, lever_arm=model.lever,
                             time_asynchrony_s=model.tga, asymmetric_gyro=model.A_g,
                             asymmetric_acc=model.A_a)
    return ImuCalibration(accelerometer=acc, gyroscope=gyr, coupling=coupling)


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = Systematic()
