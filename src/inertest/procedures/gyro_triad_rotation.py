"""360-degree rotation calibration of a gyro triad on a two-axis turntable (seed 003, sec. 1.2).

Output model of the triad (seed ``003_f374f866dfe7c99f.txt``, eq. (1), written for the raw rate)::

    raw = K (I + M) w + b = A w + b,     bias B = A^-1 b (input-referred) [deg/h]

The model, its names, units and conventions are those of :mod:`inertest.models.triad`:
``K = diag(K_x, K_y, K_z)`` scale factors [count/deg for a pulse output read as count/s],
``M`` the misalignment [urad] (zero diagonal; ``M_ij`` is gyro i's sensitivity to rate about
axis j, the seed's ``DH_ji``), ``w`` the body rate on the
triad's orthogonal reference axes. The seed writes it per pulse count: ``k_x N_gx = w_x + DH_yx
w_y + DH_zx w_z + e_x0``, i.e. ``k_x = 1/K_x`` (rate per pulse), ``DH_yx = M_xy`` and
``e = K^-1 b = (I + M) B`` (equal to ``B`` to first order; ``B`` is the rate input that gives
the output ``b``, the convention of the calibration block).

The test: with the outer axis, set a triad axis ``j`` along the inner (rotation) axis; count each
gyro's pulses over a window containing one whole 360-degree turn about ``j``, in both
directions; add static windows for the bias. The pulses counted over window ``T`` are::

    N = A Theta + b T,      Theta = +-2 pi e_j + int_T C_bn(t) W_ie_n dt

with the Earth-rate angle computed from the start attitude, the table rate and acceleration and
``T`` (:func:`inertest.equipment.rate_table.body_angle`). Each gyro's counts over all windows give
a linear least-squares problem in its row of ``A`` and ``b`` (4 unknowns, all rows share the
design); scale factors, misalignments and biases follow from ``A`` and ``b`` with covariance by
first-order propagation.

Closed form (independent reference used by the tests): for rotations about ``j`` in both
directions over equal windows at constant rate, ``K_j = (N_j(+) - N_j(-)) / (4 pi)`` and
``M_ij = (N_i(+) - N_i(-)) / (4 pi K_i)``.

Identifiability: column ``j`` of ``A`` (``K_j``, ``M_ij``; and, through ``K_j``, ``M_ji``) needs
rotations about ``j``; the biases need either both directions of every rotation or static
windows. Missing ones raise :class:`~inertest.errors.IdentifiabilityError` naming the
coefficients and the rotation or position that would determine them.

Data columns: ``part`` (free label), ``attitude`` (x, y, z directions at the start, e.g. ``ENU``),
``axis`` (``x``, ``y``, ``z`` or ``static``), ``direction`` (+1 right-handed about the axis, -1,
0 for static), ``duration_s`` (counting window [s]), ``counts_x``, ``counts_y``, ``counts_z``
(pulses counted in the window; for a rate output, the output integrated over the window
[output unit x s]); optional ``start_s`` (start of each window [s] from the start of the
session; default: the windows back to back in row order).

Noise (issue 15): the unit of independence is the window -- the table is set anew for each
turn or static position, so repeated windows of one rotation are replicates, and their scatter
is what the noise model is fitted to. Two keys describe the count noise of a window of length
``T``: ``window_noise`` the white part (``constant``: readout/quantisation, the same for every
window [count]; ``sqrt-window``: angle random walk of the rate output, ``sigma sqrt(T)``
[count/sqrt(s)]), and ``noise_model`` the drift of the rate bias (``white``: none;
``position-offsets``: a rate offset per window, count ``d T``; ``random-walk``: a rate random
walk over the session, count ``int_T W(t) dt``; ``flicker``: 1/f rate noise, a sum of
Ornstein-Uhlenbeck processes with log-spaced times; ``auto``: white unless a drift model
passes the likelihood-ratio test over the three gyros, else the smallest AIC, plus the spread
of the close models' estimates, as in
:func:`inertest.estimation.identify.solve_outputs`). The variance
components are estimated per gyro by REML (Patterson & Thompson, Biometrika 58(3), 1971,
doi:10.1093/biomet/58.3.545) and the coefficients by GLS with that covariance.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.equipment import rate_table as table
from inertest.errors import (
    DataError,
    IdentifiabilityError,
    InertestWarning,
    InputError,
    PlanError,
)
from inertest.estimation.least_squares import weighted_least_squares
from inertest.estimation.model_checks import misfit_message, model_checks
from inertest.estimation.noise_models import MODELS, NOISE_MODELS
from inertest.estimation.reml import Reml, components, gls
from inertest.estimation.selection import common_noise_model, selection_spread
from inertest.models import triad
from inertest.models.imu import ImuCalibration
from inertest.models.rate_gyro import (
    check_gyro,
    raw_rate_per_si,
    raw_rate_unit,
    triad_from_truth,
)
from inertest.models.triad import AXES
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import noise_samples, require_columns
from inertest.results import Estimate, Identification, LinearTestResult, ModelChecks
from inertest.units import DEG_TO_RAD

KIND = "gyro-triad-rotation"
#: Coefficient names in result order (those of :mod:`inertest.models.triad`).
NAMES = triad.parameter_names()
#: Attitude with each axis up, used to suggest the missing rotation.
_UP_ATTITUDE = {"x": "UEN", "y": "NUE", "z": "ENU"}
_STATIC = table.STATIC
#: How a window's white count noise depends on its length (GyroTriadRotationSpec.window_noise).
WINDOW_NOISES = ("constant", "sqrt-window")


@dataclass(frozen=True)
class RotationSpec:
    """One rotation of the plan: start attitude and the body axis turned about."""

    attitude: str
    axis: str


@dataclass(frozen=True)
class GyroTriadRotationSpec:
    """Parameters of a 360-degree rotation plan (``[procedure]`` table).

    Attributes
    ----------
    rate_deg_s : float
        Table rate during a rotation [deg/s].
    accel_deg_s2 : float or None
        Table acceleration [deg/s^2]; None: constant rate from start to stop.
    rotations : tuple of RotationSpec
        Start attitudes and axes; in a plan ``rotations = [{attitude = "ENU", axis = "z"}, ...]``.
        Default: the seed's three, each axis vertical (``UEN``/x, ``NUE``/y, ``ENU``/z).
    directions : tuple of int
        Directions each rotation is run in (default both, ``[1, -1]``).
    rotation_window_s : float or None
        Counting window of a rotation [s] (default: the rotation time + 4 s).
    static_attitudes : tuple of str
        Attitudes of the static windows (default: each axis up and down).
    static_window_s : float
        Counting window at rest [s].
    repeats : int
        Times the whole sequence is run (for simulation).
    window_noise : str
        White count noise of a window: ``"constant"``, the same for every window (quantisation,
        readout), given in count; ``"sqrt-window"``, growing as the square root of the window
        (angle random walk of the gyro), given in count/sqrt(s). (Formerly the key ``noise_model``
        with the values ``white`` and ``random-walk``.)
    noise_model : str
        Drift of the rate bias behind the uncertainties (module docstring):
        :data:`~inertest.estimation.identify.NOISE_MODELS`; default ``white`` (none).
    """

    kind: ClassVar[str] = KIND
    rate_deg_s: float = 10.0
    accel_deg_s2: float | None = None
    rotations: tuple[RotationSpec, ...] = (
        RotationSpec("UEN", "x"), RotationSpec("NUE", "y"), RotationSpec("ENU", "z"))
    directions: tuple[int, ...] = (1, -1)
    rotation_window_s: float | None = None
    static_attitudes: tuple[str, ...] = ("UEN", "DWN", "NUE", "SDE", "ENU", "WND")
    static_window_s: float = 60.0
    repeats: int = 1
    window_noise: str = "constant"
    noise_model: str = "white"

    @property
    def profile(self) -> table.RotationProfile:
        """The table's rotation profile (360 deg)."""
        acc = None if self.accel_deg_s2 is None else self.accel_deg_s2 * DEG_TO_RAD
        return table.RotationProfile(self.rate_deg_s * DEG_TO_RAD, acc)

    @property
    def window_s(self) -> float:
        """Counting window of a rotation [s]."""
        if self.rotation_window_s is not None:
            return self.rotation_window_s
        return self.profile.duration_s + 4.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> GyroTriadRotationSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`).

        ``rotations`` (a list of tables), ``directions`` (+1/-1) and ``static_attitudes`` (a
        list that may be empty) are read here.
        """
        kw: dict[str, object] = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                                            ignore=("kind", "rotations", "directions",
                                                    "static_attitudes"))
        if "rotations" in params:
            raw = params["rotations"]
            if not isinstance(raw, list):
                raise PlanError('rotations must be a list like [{attitude = "ENU", axis = "z"}]')
            rots = []
            for r in raw:
                if not isinstance(r, Mapping) or set(r) != {"attitude", "axis"}:
                    raise PlanError(
                        f'each rotation needs exactly attitude and axis, e.g. {{attitude = "ENU", '
                        f'axis = "z"}}; got {r!r}'
                    )
                table.triad_attitude(str(r["attitude"]))
                table.axis_index(str(r["axis"]))
                rots.append(RotationSpec(str(r["attitude"]).upper(), str(r["axis"]).lower()))
            kw["rotations"] = tuple(rots)
        if "directions" in params:
            d = params["directions"]
            if not isinstance(d, list) or not d or any(x not in (1, -1) for x in d):
                raise PlanError(f"directions must be a list of 1 and/or -1, got {d!r}")
            kw["directions"] = tuple(int(x) for x in d)
        if "static_attitudes" in params:  # may be empty (rotations only): not a Field
            s = params["static_attitudes"]
            if not isinstance(s, list):
                raise PlanError('static_attitudes must be a list like ["ENU", "WND"]')
            for a in s:
                table.triad_attitude(str(a))
            kw["static_attitudes"] = tuple(str(a).upper() for a in s)
        spec = cls(**kw)  # type: ignore[arg-type]
        if spec.window_s < spec.profile.duration_s:
            raise PlanError(
                f"rotation_window_s = {spec.window_s:g} s is shorter than one turn "
                f"({spec.profile.duration_s:g} s at this rate and acceleration); lengthen it"
            )
        return spec


FIELDS = (
    Field("rate_deg_s", default=GyroTriadRotationSpec.rate_deg_s, positive=True, unit="deg/s",
          doc="table rate during a rotation"),
    Field("accel_deg_s2", default=None, positive=True, unit="deg/s^2",
          doc="table acceleration (none: constant rate from start to stop)"),
    Field("rotation_window_s", default=None, positive=True, unit="s",
          doc="counting window of a rotation"),
    Field("static_window_s", default=GyroTriadRotationSpec.static_window_s, positive=True,
          unit="s", doc="counting window at rest"),
    Field("repeats", "integer", default=1, positive=True, doc="runs of the whole sequence"),
    Field("window_noise", "text", default="constant", choices=WINDOW_NOISES,
          doc="white count noise of a window: constant, or growing as sqrt(window)"),
    Field("noise_model", "text", default="white", choices=NOISE_MODELS,
          doc="drift of the rate bias behind the uncertainties"),
)


@dataclass(frozen=True, kw_only=True)
class GyroTriadRotationResult(LinearTestResult):
    """Outcome of :func:`fit` for the 360-degree rotation test.

    Attributes
    ----------
    identification : Identification
        ``K_x..K_z`` [K unit], ``M_xy..M_zy`` [urad], ``B_x..B_z`` [deg/h] with covariance.
    calibration : ImuCalibration
        The gyroscope correction ``calibrated = matrix @ (raw - offset)`` (raw rate).
    forward : ndarray, shape (3, 3)
        ``A = K (I + M)`` [raw rate per rad/s].
    offset : ndarray, shape (3,)
        ``b`` [raw rate unit].
    part, axis : ndarray of str
        Row labels.
    direction, duration_s : ndarray
    body_angle_rad : ndarray, shape (n, 3)
        ``Theta`` per row (table + Earth) [rad].
    counts, fitted_counts : ndarray, shape (n, 3)
        Counted and model counts per row.
    closed_form_scale : dict
        ``K_j`` from the +-pairs about each axis [K unit] (constant-rate, equal-window formula).
    """

    calibration: ImuCalibration
    forward: NDArray[np.float64]
    offset: NDArray[np.float64]
    scale_unit: str
    raw_unit: str
    part: NDArray = field(repr=False)
    axis: NDArray = field(repr=False)
    direction: NDArray[np.float64] = field(repr=False)
    duration_s: NDArray[np.float64] = field(repr=False)
    body_angle_rad: NDArray[np.float64] = field(repr=False)
    counts: NDArray[np.float64] = field(repr=False)
    fitted_counts: NDArray[np.float64] = field(repr=False)
    closed_form_scale: dict[str, float]
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d: dict[str, object] = {}
        d["calibration"] = self.calibration.to_dict()
        d["closed_form_scale"] = {
            k: {"value": v, "unit": self.scale_unit} for k, v in self.closed_form_scale.items()
        }
        count = self.output_unit
        d["noise_components"] = {
            k: {"value": v, "unit": self.identification.noise_unit if k == "white" else
                count + next(u for m, u in _COMPONENT_UNITS.items() if MODELS[m].component == k)}
            for k, v in self.identification.noise_components.items()}
        return d


@dataclass(frozen=True)
class _Rows:
    part: NDArray
    axis: NDArray
    direction: NDArray[np.float64]
    attitude: NDArray
    duration: NDArray[np.float64]
    counts: NDArray[np.float64]
    start: NDArray[np.float64]


def _read(data: Mapping[str, object]) -> _Rows:
    cols = require_columns(
        data, ("direction", "duration_s", "counts_x", "counts_y", "counts_z"),
        ("part", "attitude", "axis"), procedure=KIND)
    axis = np.char.lower(np.char.strip(cols["axis"]))
    bad = np.flatnonzero(~np.isin(axis, [*AXES, _STATIC]))
    if bad.size:
        raise DataError(
            f'axis "{cols["axis"][bad[0]]}" at data row {bad[0] + 1} is not x, y, z or static'
        )
    d = cols["direction"]
    rot = axis != _STATIC
    bad = np.flatnonzero((rot & ~np.isin(d, [1.0, -1.0])) | (~rot & (d != 0)))
    if bad.size:
        i = bad[0]
        raise DataError(
            f"direction {d[i]:g} at data row {i + 1} (axis {axis[i]}): use +1 or -1 for a "
            "rotation and 0 for a static window"
        )
    if np.any(cols["duration_s"] <= 0):
        i = int(np.flatnonzero(cols["duration_s"] <= 0)[0])
        raise DataError(f"duration_s at data row {i + 1} must be positive")
    counts = np.column_stack([cols["counts_x"], cols["counts_y"], cols["counts_z"]])
    dur = cols["duration_s"]
    if "start_s" in data:
        start = require_columns(data, ("start_s",), (), procedure=KIND)["start_s"]
        over = np.flatnonzero(start[1:] < start[:-1] + dur[:-1] - 1e-9 * dur[:-1])
        if over.size:
            raise DataError(
                f"start_s at data row {over[0] + 2} is before the end of the window of row "
                f"{over[0] + 1}: the rows must be the windows in time order, not overlapping")
    else:
        start = np.r_[0.0, np.cumsum(dur[:-1])]  # back to back in row order
    return _Rows(cols["part"], axis, d, np.char.upper(np.char.strip(cols["attitude"])),
                 dur, counts, start)


def body_angles(rows_attitude: NDArray, axis: NDArray, direction: NDArray[np.float64],
                duration_s: NDArray[np.float64], turns: table.TurnTable) -> NDArray[np.float64]:
    """``Theta`` [rad], shape (n, 3): the integral of the body rate over each window.

    The table gives it (:meth:`~inertest.equipment.rate_table.TurnTable.window_angle`): a
    whole turn (table angle plus the Earth-rate angle of the profile) or a static window
    (Earth rate times the window); once per distinct window.
    """
    out = np.empty((axis.size, 3))
    cache: dict[tuple[str, str, float, float], NDArray[np.float64]] = {}
    for i in range(axis.size):
        key = (str(rows_attitude[i]), str(axis[i]), float(direction[i]), float(duration_s[i]))
        if key not in cache:
            try:
                cache[key] = turns.window_angle(*key)
            except InputError as exc:
                raise DataError(f"data row {i + 1}: {exc}") from None
        out[i] = cache[key]
    return out


def _check_labels(rows: _Rows) -> None:
    """Each rotation's own gyro counts the turn: catch mislabelled axes and directions."""
    for j, a in enumerate(AXES):
        idx = np.flatnonzero(rows.axis == a)
        for i in idx:
            big = int(np.argmax(np.abs(rows.counts[i])))
            if big != j:
                raise DataError(
                    f'data row {i + 1} (part "{rows.part[i]}") is labelled a rotation about {a}, '
                    f"but gyro {AXES[big]} counted the turn ({rows.counts[i, big]:.6g} against "
                    f"{rows.counts[i, j]:.6g}): fix the axis label or the counts columns"
                )
        if idx.size:
            s = np.sign(rows.counts[idx, j]) * rows.direction[idx]
            if np.any(s != s[0]):
                i = idx[int(np.flatnonzero(s != s[0])[0])]
                raise DataError(
                    f'data row {i + 1} (part "{rows.part[i]}"): direction {rows.direction[i]:+g} '
                    f"but gyro {a} counted the other way from the other rotations about {a}; "
                    "fix the direction column"
                )


def _check_excitation(rows: _Rows) -> None:
    """Name the coefficients a plan cannot find, and the rotation or position that would."""
    static = bool(np.any(rows.axis == _STATIC))
    for a in AXES:
        mine = rows.axis == a
        if not np.any(mine):
            others = [b for b in AXES if b != a]
            raise IdentifiabilityError(
                f"no rotation about {a}: K_{a}, M_{others[0]}{a}, M_{others[1]}{a} ({a} rate "
                f"into the other gyros) and M_{a}{others[0]}, M_{a}{others[1]} (need K_{a}) "
                f"cannot be found, nor the biases; add 360-degree rotations about {a} (e.g. "
                f'attitude "{_UP_ATTITUDE[a]}", {a} up) in both directions'
            )
        dirs = set(rows.direction[mine].tolist())
        if len(dirs) == 1 and not static:
            missing = "-1" if dirs == {1.0} else "+1"
            raise IdentifiabilityError(
                f"rotations about {a} run in one direction only and there is no static window: "
                f"the biases cannot be separated from K_{a} and the {a} misalignments; add "
                f"rotations about {a} with direction {missing}, or static positions"
            )


@dataclass(frozen=True)
class WindowObservations:
    """The counting windows, checked, with the body angle of each from the table [rad]."""

    rows: _Rows
    body_angle_rad: NDArray[np.float64]


class GyroTriadRotation(Procedure[GyroTriadRotationSpec, WindowObservations,
                                  GyroTriadRotationResult]):
    """Gyro triad, 360-degree rotations on a two-axis table (seed 003, sec. 1.2): K, M, B.

    Data: the columns listed in the module docstring, one row per counting window. A known
    ``sigma`` is the white noise of a window's count [output unit (x s)], per sqrt(s) with
    ``window_noise = "sqrt-window"``; from the residuals when omitted (separately for each
    gyro). ``noise_model``: the drift of the rate bias (module docstring).

    Notes
    -----
    Each gyro is fitted on its own: the count covariance of the windows is ``s2 (W + theta K)``
    with ``W`` the white shape (``window_noise``) and ``K`` the kernel of the bias drift in
    session time (:func:`window_kernel`); ``theta`` (and ``s2`` unless ``sigma`` is given) by
    REML, the coefficients by GLS. ``white`` is ordinary weighted least squares. With ``auto``
    the three gyros share one model, white unless a drift model beats it by the
    likelihood-ratio test pooled over them, else the drift model of smallest summed AIC, and
    each adds the weighted spread of its estimates under the models within 2 per gyro of it
    (the rule of :func:`inertest.estimation.identify.solve_outputs`).

    Raises
    ------
    IdentifiabilityError
        An axis never rotated about, one direction only without static windows, too few rows.
    DataError
        Missing or bad columns, mislabelled axis or direction.
    """

    kind = KIND
    title = "Gyro triad, 360-degree rotations"
    spec = GyroTriadRotationSpec
    model = "inertest.models.triad"
    method = "generalised least squares per gyro, drift component by REML"
    noise_models = NOISE_MODELS
    report = "inertest.report.gyro_triad:rotation_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> table.TurnTable:
        """The two-axis table with the plan's rotation profile, at the plan's site."""
        spec: GyroTriadRotationSpec = plan.procedure
        return table.TurnTable(plan.site, spec.profile)

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: table.TurnTable
               ) -> WindowObservations:
        """The windows read and checked, and the body angle of each."""
        check_gyro(plan.instrument, KIND)
        rows = _read(data)
        _check_labels(rows)
        _check_excitation(rows)
        theta = body_angles(rows.attitude, rows.axis, rows.direction, rows.duration, motion)
        return WindowObservations(rows, theta)

    def identify(self, plan: Plan, obs: WindowObservations, *, sigma: float | None,
                 noise_model: str | None) -> GyroTriadRotationResult:
        """Scale factors, misalignment and bias, each gyro by GLS under its noise model."""
        spec: GyroTriadRotationSpec = plan.procedure
        inst = plan.instrument
        model = str(noise_model)
        rows, theta = obs.rows, obs.body_angle_rad
        per_si = raw_rate_per_si(inst.output_unit)
        X = np.column_stack([theta, rows.duration])
        Y = rows.counts / per_si  # raw SI: count, or rad for rate outputs
        n = X.shape[0]
        # The variance shape of the windows' white noise.
        white = rows.duration if spec.window_noise == "sqrt-window" else np.ones(n)
        rel = np.sqrt(white)
        if weighted_least_squares(X / rel[:, None], Y[:, 0] / rel, sigma=1.0).rank < 4:
            raise IdentifiabilityError(
                "the windows do not separate the scale factors, misalignments and biases (the "
                "design is singular); run every axis in both directions and add static positions"
            )
        if sigma is None and n <= 4:
            raise IdentifiabilityError(
                f"{n} windows leave no degree of freedom to estimate the noise (4 unknowns per "
                "gyro); add rotations or static windows, or give the noise level (--sigma)"
            )
        if sigma is not None and (not np.isfinite(sigma) or sigma <= 0):
            raise PlanError(f"noise sigma must be finite and positive, got {sigma}")
        sig_si = None if sigma is None else sigma / per_si
        fits, weights = _fit_gyros(X, Y, white, rows, model, sig_si)
        coef = np.column_stack([f.x for f in fits])  # (4, 3): column i = [A_ix, A_iy, A_iz, b_i]
        resid = Y - X @ coef
        sig = np.array([f.components["white"] for f in fits])
        # Per gyro i the unknowns are A_ix, A_iy, A_iz, b_i (index 4 i + k); the gyros' noises are
        # independent. Reorder to the triad model's p = [A.ravel(), b].
        cov_i = np.zeros((12, 12))
        for i, f in enumerate(fits):
            cov_i[4 * i:4 * i + 4, 4 * i:4 * i + 4] = f.covariance
        order = [4 * i + j for i in range(3) for j in range(3)] + [4 * i + 3 for i in range(3)]
        A = coef[:3].T
        b = coef[3]
        p = triad.stack_parameters(A, b)
        raw_unit = raw_rate_unit(inst.output_unit)
        su = triad.scale_unit(raw_unit, "gyroscope")
        values, cov = triad.propagate(p, cov_i[np.ix_(order, order)], "gyroscope", su)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        units = triad.units_of("gyroscope", su)
        coefficients = {
            nm: Estimate(nm, float(values[i]), float(std[i]), units[nm])
            for i, nm in enumerate(NAMES)
        }
        gyro = triad.calibration_from_parameters(p, sensor="gyroscope", scale=su,
                                                 raw_unit=raw_unit)
        ident = Identification(
            coefficients=coefficients,
            combinations=(),
            not_separable=(),
            covariance=cov,
            names=NAMES,
            noise_sigma=float(np.sqrt(np.mean(sig**2)) * per_si),
            noise_unit=_count_unit(inst.output_unit) + (
                "/sqrt(s)" if spec.window_noise == "sqrt-window" else ""),
            sigma_from_residuals=sigma is None,
            dof=int(n - 4),
            rank=4,
            residuals=resid.reshape(-1) * per_si,
            noise_model=fits[0].model,
            noise_components={k: float(np.sqrt(np.mean([f.components[k] ** 2 for f in fits])))
                              * per_si for k in fits[0].components},
            checks=_checks(X, resid, fits, rows, sigma is not None),
            noise_model_weights=weights,
        )
        return GyroTriadRotationResult(
            site_latitude_deg=plan.site.latitude_deg,
            site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident,
            calibration=ImuCalibration(gyroscope=gyro),
            forward=A * per_si,
            offset=b * per_si,
            scale_unit=su.unit,
            raw_unit=raw_unit,
            part=rows.part,
            axis=rows.axis,
            direction=rows.direction,
            duration_s=rows.duration,
            body_angle_rad=theta,
            counts=rows.counts,
            fitted_counts=(X @ coef) * per_si,
            closed_form_scale=_closed_form_scale(rows, su.si_per_unit * per_si),
            residual_output=resid * per_si,
            output_unit=_count_unit(inst.output_unit),
            messages=(),
        )

    def synthesize(self, plan: Plan, motion: table.TurnTable, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Counts of a virtual gyro triad over the plan's rotations and static windows.

        ``truth``: ``K_x, K_y, K_z`` [count/deg for pulse outputs], ``M_ij`` [urad], ``B_i``
        [deg/h]. ``noise``: white noise of each window's count [count], or [count/sqrt(s)]
        times the square root of the window with ``window_noise = "sqrt-window"``. The windows
        run back to back (column ``start_s``).
        """
        check_gyro(plan.instrument, KIND)
        spec: GyroTriadRotationSpec = plan.procedure
        per_si = raw_rate_per_si(plan.instrument.output_unit)
        A, b = triad_from_truth(truth, plan.instrument.output_unit)
        cols = plan_rows(spec)
        theta = body_angles(cols["attitude"], cols["axis"], cols["direction"],
                            cols["duration_s"], motion)
        counts = (theta @ A.T + np.outer(cols["duration_s"], b)) * per_si
        gen = np.random.default_rng(rng)
        rel = np.sqrt(cols["duration_s"]) if spec.window_noise == "sqrt-window" else 1.0
        counts = counts + noise_samples(counts.size, noise, gen).reshape(
            counts.shape) * np.reshape(rel, (-1, 1))
        for j, a in enumerate(AXES):
            cols[f"counts_{a}"] = counts[:, j]
        cols["start_s"] = np.r_[0.0, np.cumsum(cols["duration_s"][:-1])]
        return cols


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = GyroTriadRotation()


#: Unit of each drift component per count unit of the output (its name: the noise model's).
_COMPONENT_UNITS = {"position-offsets": "/s", "random-walk": "/s/sqrt(s)", "flicker": "/s"}


def window_kernel(model: str, start_s: NDArray[np.float64], duration_s: NDArray[np.float64]
                  ) -> NDArray[np.float64]:
    """Covariance of the window integrals of a unit rate-bias drift, shape (n, n) [s^2 or s^3].

    The noise model's window kernel (:meth:`inertest.estimation.noise_models.NoiseModel.
    window_kernel`): offsets per window, a random walk of unit step variance per second, or
    1/f flicker of unit variance when averaged over the shortest window.
    """
    return MODELS[model].window_kernel(start_s, duration_s)


@dataclass(frozen=True)
class _GyroFit:
    """One gyro's GLS solution under its noise model (raw SI)."""

    x: NDArray[np.float64]
    covariance: NDArray[np.float64]
    model: str
    components: dict[str, float]
    V: NDArray[np.float64]  # covariance of the windows under the noise model


def _candidates(X: NDArray[np.float64], y: NDArray[np.float64], W: NDArray[np.float64],
                kernels: Mapping[str, NDArray[np.float64]], sigma: float | None
                ) -> dict[str, tuple[_GyroFit, float]]:
    """One gyro under ``white`` and each drift model in ``kernels``, with its AIC.

    REML of ``V = s2 (diag(W) + theta K)`` (``s2 = sigma^2`` when known; Patterson & Thompson
    1971) and GLS, as for every procedure (:mod:`inertest.estimation.reml`); AIC of the
    restricted likelihood, one parameter more for a drift.
    """
    known = sigma is not None
    reml = Reml.of(X, y, W * sigma**2 if known else W, scale_known=known)  # type: ignore[operator]
    fitted = components(reml, {m: _constant(K) for m, K in kernels.items()}, with_white=True)
    out = {}
    for m, c in fitted.items():
        s2, V = c.fitted(reml)
        sol = gls(X, y, V)
        comps = {"white": float(sigma) if known else float(np.sqrt(s2))}  # type: ignore[arg-type]
        if c.kernel is not None:
            comps[str(MODELS[m].component)] = c.level(s2)
        out[m] = (_GyroFit(sol.x, sol.covariance, m, comps, V), c.aic)
    return out


def _constant(K: NDArray[np.float64]) -> Callable[[], NDArray[np.float64]]:
    """``K``, built on demand (the kernels of the windows are computed once for all gyros)."""
    return lambda: K


def _checks(X: NDArray[np.float64], resid: NDArray[np.float64], fits: list[_GyroFit],
            rows: _Rows, given: bool) -> ModelChecks:
    """Model checks of the three gyros' windows together (issue 15).

    The windows of gyro x, then y, then z, each gyro's block with its own fitted covariance
    (the gyros' noises are independent, so the covariance is block-diagonal) and design.
    Standardised residuals, Ljung-Box test and Bonferroni outliers as in
    :func:`inertest.estimation.model_checks.model_checks`; the chi-square is a test only with
    the noise level given. With the level fitted, a window's standardised residual cannot
    exceed about ``sqrt(n - 4)`` (n windows): few windows, or two windows wrong together (two
    labels swapped), stay unseen unless the noise level is given. Warns (InertestWarning) on a
    misfit.
    """
    n = X.shape[0]
    design = np.zeros((3 * n, 12))
    V = np.zeros((3 * n, 3 * n))
    for i, f in enumerate(fits):
        design[i * n:(i + 1) * n, 4 * i:4 * i + 4] = X
        V[i * n:(i + 1) * n, i * n:(i + 1) * n] = f.V
    labels = [f"gyro {a}, window {k + 1} ({rows.part[k]})" for a in AXES for k in range(n)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        checks = model_checks(resid.T.reshape(-1), design, V, noise_model=fits[0].model,
                              sigma_given=given, labels=labels, unit="window")
    if not checks.fits:
        checks = replace(checks, message=misfit_message(
            checks, what="the windows", prefix=f"{KIND}: ",
            check="the attitude, axis, direction and part labels and the noise model"))
        warnings.warn(str(checks.message), InertestWarning, stacklevel=3)
    return checks


def _fit_gyros(X: NDArray[np.float64], Y: NDArray[np.float64], W: NDArray[np.float64],
               rows: _Rows, model: str, sigma: float | None
               ) -> tuple[list[_GyroFit], dict[str, float]]:
    """Each gyro's fit under one noise model, and with ``auto`` the Akaike weights.

    ``auto`` is the rule of :func:`inertest.estimation.identify.solve_outputs`: white unless a
    drift model beats it by the likelihood-ratio test pooled over the three gyros, else the
    drift model of smallest summed AIC; each gyro's covariance gains the spread of its
    estimates under the models within 2 per gyro of it, with the weights of that criterion
    (:func:`inertest.estimation.selection.common_noise_model`,
    :func:`~inertest.estimation.selection.selection_spread`).
    """
    names = [m for m in _COMPONENT_UNITS if model in ("auto", m)]
    if names and X.shape[0] - 4 < 4:
        raise IdentifiabilityError(
            f"{X.shape[0]} windows for 4 unknowns per gyro: too few to estimate the "
            f'"{model}" noise; add windows (repeats), or use noise_model = "white"')
    kernels = {m: window_kernel(m, rows.start, rows.duration) for m in names}
    cands = [_candidates(X, Y[:, i], W, kernels, sigma) for i in range(3)]
    if model != "auto":
        return [c[model][0] for c in cands], {}
    common, weights, near = common_noise_model([{m: a for m, (_, a) in c.items()}
                                                for c in cands])
    fits = []
    for c in cands:
        best = c[common][0]
        if len(near) > 1:
            spread = selection_spread(best.x, {m: c[m][0].x for m in near},
                                      {m: weights[m] for m in near})
            best = replace(best, covariance=best.covariance + spread)
        fits.append(best)
    return fits, weights


def _count_unit(output_unit: str) -> str:
    return "count" if output_unit == "count" else f"{output_unit}*s"


def _closed_form_scale(rows: _Rows, k_per_count: float) -> dict[str, float]:
    """``K_j = (mean N_j(+) - mean N_j(-)) / (4 pi)`` where both directions were run."""
    out = {}
    for j, a in enumerate(AXES):
        pos = rows.counts[(rows.axis == a) & (rows.direction > 0), j]
        neg = rows.counts[(rows.axis == a) & (rows.direction < 0), j]
        if pos.size and neg.size:
            out[f"K_{a}"] = float((pos.mean() - neg.mean()) / (4 * np.pi) / k_per_count)
    return out


def plan_rows(spec: GyroTriadRotationSpec) -> dict[str, NDArray]:
    """The label columns of the plan's windows, in the order they are run."""
    part, att, axis, direction, dur = [], [], [], [], []
    for _ in range(spec.repeats):
        for r in spec.rotations:
            for d in spec.directions:
                part.append(f"{r.attitude} {r.axis}{'+' if d > 0 else '-'}")
                att.append(r.attitude)
                axis.append(r.axis)
                direction.append(float(d))
                dur.append(spec.window_s)
        for a in spec.static_attitudes:
            part.append(f"{a} static")
            att.append(a)
            axis.append(_STATIC)
            direction.append(0.0)
            dur.append(spec.static_window_s)
    return {"part": np.array(part), "attitude": np.array(att), "axis": np.array(axis),
            "direction": np.array(direction), "duration_s": np.array(dur)}
