"""Static multi-position calibration of an accelerometer triad (6, 12, 24 or listed positions).

Seed ``003_f374f866dfe7c99f.txt`` sec. 1.1: the accelerometer triad of the IMU is calibrated by a
twelve-position method; the output model is the triad model of eq. (1)::

    raw = S f + b,     S = K (I + M)                     (per reading, f at rest = C_nb^T (0,0,g))

with ``f`` the specific force on the fixture-defined reference axes [m/s^2] (from the position's
known attitude, :mod:`inertest.equipment.multiposition`), ``S`` a general 3x3 matrix [raw per
m/s^2] and ``b`` the bias [raw]. The model is linear in the 12 unknowns (``S`` row-wise, ``b``),
solved by least squares axis by axis (each output with its own noise level) and decomposed into
3 scale factors ``K_i = S_ii``, 6 misalignments ``M_ij = S_ij / S_ii`` (reference frame = the
fixture's axes, so all six are identifiable; conventions in :mod:`inertest.models.triad`) and
input-referred biases ``B = S^-1 b``. Identifiability: each output needs the specific force to
span all three reference axes *and* to vary along each (up and down), i.e. the design
``[f^T, 1]`` of rank 4; otherwise the error names the scale factor / misalignment that is lost
and the position that would restore it.

Data columns: ``position`` (label as in the plan, e.g. ``UEN`` or ``UEN/z+45``), ``output_x``,
``output_y``, ``output_z`` [instrument output unit], one row per reading.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.equipment import multiposition as mp
from inertest.equipment.motion import Fixture
from inertest.errors import DataError, IdentifiabilityError, InertestWarning, InputError, PlanError
from inertest.estimation.identify import NoiseFit, solve_outputs
from inertest.estimation.least_squares import weighted_least_squares
from inertest.estimation.noise_models import NOISE_MODELS
from inertest.models import triad
from inertest.models.imu import ImuCalibration
from inertest.models.triad import (
    AXES,
    ScaleUnit,
    calibration_from_parameters,
    stack_parameters,
)
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.results import Identification
from inertest.results.triad import TriadResult, triad_identification
from inertest.units import MICRORAD_TO_RAD

KIND = "triad-multiposition"
OUTPUT_COLUMNS = tuple(f"output_{a}" for a in AXES)

@dataclass(frozen=True)
class TriadMultipositionSpec:
    """Parameters of a multi-position plan (``[procedure]`` table).

    Attributes
    ----------
    positions : tuple of str
        Position labels (see :mod:`inertest.equipment.multiposition`); in a plan file either a
        scheme ``positions = "12"`` (``"6"``, ``"12"``, ``"24"``) or a list of labels.
    samples_per_position : int
        Readings per position (for simulation).
    nominal_scale_factor : float or None
        Nominal ``K`` [scale unit] for count outputs, to report ppm deviations (physical outputs
        have nominal 1).
    noise_model : str
        Noise of the readings behind the uncertainties (:data:`~inertest.estimation.identify.
        NOISE_MODELS`): ``white``, ``position-offsets`` (the fixture re-settles: an offset per
        position), ``random-walk``, ``flicker`` or ``auto`` (by AIC, the default). The unit of
        independence is a position visit (consecutive readings with one label).
    """

    kind: ClassVar[str] = KIND
    positions: tuple[str, ...] = mp.TWELVE
    samples_per_position: int = 1
    nominal_scale_factor: float | None = None
    noise_model: str = "auto"

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> TriadMultipositionSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`).

        ``positions`` is a scheme name or a list of labels (two types): read here.
        """
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "positions"))
        raw = params.get("positions", "12")
        if isinstance(raw, (str, int)) and not isinstance(raw, bool):
            positions = mp.scheme_positions(str(raw))
        elif isinstance(raw, list) and raw:
            positions = tuple(str(p) for p in raw)
            for p in positions:
                mp.attitude(p)  # validates each label
        else:
            raise PlanError('positions must be "6", "12", "24" or a list such as ["UEN", "DWN"]')
        return cls(positions=positions, **v)


FIELDS = (
    Field("samples_per_position", "integer", default=1, positive=True,
          doc="readings per position (simulation)"),
    Field("nominal_scale_factor", "number", default=None, positive=True, unit="scale unit",
          doc="nominal K of a count output, for the ppm deviations"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS,
          doc="noise model behind the uncertainties"),
)


@dataclass(frozen=True, kw_only=True)
class TriadMultipositionResult(TriadResult):
    """Outcome of :func:`fit`.

    Attributes
    ----------
    position : ndarray of str
        Position label of each row.
    specific_force : ndarray, shape (n, 3)
        Specific force on the reference axes [m/s^2].
    output, fitted : ndarray, shape (n, 3)
        Recorded and model output [output unit].
    noise_per_axis : dict
        Noise per reading of each output [output unit] (from residuals unless given).
    six_position : dict
        Closed-form six-position estimates (bias [output unit], S columns [output unit per
        m/s^2]) when the data hold the six axis-up/down positions; else empty.
    """

    position: NDArray = field(repr=False)
    specific_force: NDArray[np.float64] = field(repr=False)
    output: NDArray[np.float64] = field(repr=False)
    fitted: NDArray[np.float64] = field(repr=False)
    noise_per_axis: dict[str, float]
    six_position: dict[str, list[float]]

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d = super().details()
        d["noise_per_axis"] = {k: {"value": v, "unit": self.output_unit}
                               for k, v in self.noise_per_axis.items()}
        if self.six_position:
            d["six_position_closed_form"] = self.six_position
        return d


def _scale(plan: Plan) -> ScaleUnit:
    inst = plan.instrument
    if inst.kind not in ("accelerometer-triad", "imu"):
        raise PlanError(f'{KIND} calibrates an accelerometer triad: set [instrument] kind = '
                        f'"accelerometer-triad" (or "imu"), not "{inst.kind}"')
    su = triad.scale_unit(inst.output_unit, "accelerometer")
    if su.unit != "1" and inst.output_unit != "count":
        raise PlanError(f'output_unit "{inst.output_unit}" is not a specific-force unit; use '
                        'count, m/s^2, g, mg or ug')
    return su.with_nominal(plan.procedure.nominal_scale_factor)


def check_identifiable(f: NDArray[np.float64], labels: NDArray) -> None:
    """Raise :class:`IdentifiabilityError` unless ``[f^T, 1]`` has rank 4, saying what is lost.

    Parameters
    ----------
    f : ndarray, shape (n, 3)
        Specific force on the reference axes [m/s^2].
    labels : ndarray of str
        Position of each row (for the message).
    """
    distinct = np.unique(labels)
    A = np.column_stack([f / np.max(np.abs(f)), np.ones(len(f))])
    design = weighted_least_squares(A, np.zeros(len(f)), sigma=1.0)
    rank = design.rank
    if rank == 4:
        return
    msgs = []
    for v in design.null_space.T:
        d, c = v[:3], v[3]
        if np.linalg.norm(d) < 1e-9:  # pragma: no cover - the ones column is never zero
            continue
        d = d / np.linalg.norm(d)
        j = int(np.argmax(np.abs(d)))
        axis = AXES[j]
        col = ", ".join(f"S_{a}{axis}" for a in AXES)
        lost = f"K_{axis} and the misalignments M_x{axis}/M_y{axis}/M_z{axis} ({col})"
        if abs(c) < 1e-6:
            msgs.append(
                f"{lost} cannot be found: no position puts specific force along {axis} "
                f"(direction {np.round(d, 3).tolist()}); add positions with {axis} up and down "
                f"(e.g. {_axis_positions(j)})")
        else:
            msgs.append(
                f"{lost} cannot be separated from the biases: the specific force along {axis} "
                f"is the same in every position; add the opposite position (e.g. "
                f"{_axis_positions(j)}) so {axis} is both up and down")
    raise IdentifiabilityError(
        f"{len(distinct)} distinct position(s) ({', '.join(distinct[:8])}) do not determine the "
        f"12 triad parameters (rank {rank} of 4 per output): " + "; ".join(msgs))


def _axis_positions(j: int) -> str:
    return {0: "UEN and DWN", 1: "NUE and SDE", 2: "ENU and WND"}[j]


def _check_labels(S: NDArray[np.float64]) -> None:
    """Mislabelled axes: each output must respond mostly to its own axis.

    A negative response (reversed axis, negated output) is a legal negative scale factor of the
    triad model; :func:`fit` reports it in a message.
    """
    for i, a in enumerate(AXES):
        row = np.abs(S[i])
        j = int(np.argmax(row))
        if j != i:
            raise DataError(
                f"output_{a} responds mostly to specific force along {AXES[j]} (|S_{a}{AXES[j]}| "
                f"= {row[j]:.4g} > |S_{a}{a}| = {row[i]:.4g}): the output columns or the position "
                f"labels are mislabelled; swap output_{a} and output_{AXES[j]} or fix the "
                "mounting")


def six_position_closed_form(
    labels: NDArray, output: NDArray[np.float64], gravity_m_s2: float
) -> dict[str, list[float]]:
    """Classical six-position formulas where the data hold ``UEN, DWN, NUE, SDE, ENU, WND``.

    ``b = (f_up + f_down) / 2`` (mean over the three axes' pairs) and column ``j`` of ``S`` is
    ``(f_up - f_down) / (2 g)`` with axis ``j`` up (IEEE Std 1293-2018; Titterton & Weston,
    *Strapdown Inertial Navigation Technology*, 2nd ed., sec. 8.3.2).

    Returns
    -------
    dict
        ``{"bias": [3] (output unit), "S": 3x3 (output unit per m/s^2)}``; empty without the six.
    """
    means = {}
    for p in mp.SIX:
        sel = labels == p
        if not np.any(sel):
            return {}
        means[p] = output[sel].mean(axis=0)
    pairs = [("UEN", "DWN"), ("NUE", "SDE"), ("ENU", "WND")]
    S = np.column_stack([(means[u] - means[d]) / (2 * gravity_m_s2) for u, d in pairs])
    b = np.mean([(means[u] + means[d]) / 2 for u, d in pairs], axis=0)
    return {"bias": b.tolist(), "S": S.tolist()}


def position_visits(labels: ArrayLike) -> NDArray:
    """The unit of independence of each reading: its position visit, shape (n,).

    Consecutive readings with one label are one visit (``"UEN"``); a later return to the same
    position is another (``"UEN (2)"``): the fixture re-settles each time it is set.
    """
    lab = np.asarray(labels).astype(str)
    if lab.size == 0:
        return lab
    start = np.r_[True, lab[1:] != lab[:-1]]
    seen: dict[str, int] = {}
    names = []
    for v in lab[start]:
        seen[v] = seen.get(v, 0) + 1
        names.append(v if seen[v] == 1 else f"{v} ({seen[v]})")
    return np.asarray(names)[np.cumsum(start) - 1]


@dataclass(frozen=True)
class CubeObservations:
    """Triad readings with the specific force of each row from the fixture's positions.

    ``labels`` (n,) position labels, ``f`` (n, 3) specific force on the reference axes
    [m/s^2], ``output`` (n, 3) [output unit].
    """

    labels: NDArray
    f: NDArray[np.float64]
    output: NDArray[np.float64]


class TriadMultiposition(Procedure[TriadMultipositionSpec, CubeObservations,
                                   TriadMultipositionResult]):
    """Accelerometer triad, multi-position (seed 003, sec. 1.1): K, M, B from static positions.

    Data columns ``position``, ``output_x``, ``output_y``, ``output_z`` [output unit], rows in
    time order. A known ``sigma`` is the white noise per reading [output unit], the same for
    each axis; else the noise comes from the residuals (the scatter within positions when
    positions hold several readings).

    Notes
    -----
    Each output is fitted by :func:`inertest.estimation.identify.solve` with the position visit
    as the unit of independence: white noise is ordinary least squares; the correlated models
    estimate their variance component by REML from the position means and fit them by GLS, so
    that the stated uncertainty holds when the fixture re-settles between positions or the
    bias wanders during the test. With ``auto`` the three outputs share one noise model, white
    unless a correlated model beats it by the likelihood-ratio test pooled over them, else the
    one of smallest summed AIC, and each adds the weighted spread of its estimates under the
    models within 2 per output of it (:func:`inertest.estimation.identify.solve_outputs`).

    Raises
    ------
    IdentifiabilityError
        The positions do not excite every axis both ways (message names the lost coefficients
        and the positions to add), or too few readings to estimate the noise.
    DataError
        An output responds mostly to another axis or with negative sign (mislabelled axes).
    """

    kind = KIND
    title = "Accelerometer triad, multi-position"
    spec = TriadMultipositionSpec
    model = "inertest.models.triad"
    method = "weighted least squares per output under a common noise model"
    machines = (mp,)
    noise_models = NOISE_MODELS
    report = "inertest.report.accelerometer:triad_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> Fixture:
        """The multi-position fixture at the plan's site (with its Type-B errors)."""
        return Fixture(mp.motion, plan.site, dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Fixture
               ) -> CubeObservations:
        """The specific force of each row's position, checked to excite every axis both ways."""
        _scale(plan)
        cols = require_columns(data, OUTPUT_COLUMNS, ("position",), procedure=KIND)
        labels = np.char.strip(cols["position"])
        try:
            f = motion.positions(labels).inputs_of_rows(labels).f_i
        except InputError as exc:
            raise DataError(f"column position: {exc}") from None
        check_identifiable(f, labels)
        return CubeObservations(labels, f, np.column_stack([cols[c] for c in OUTPUT_COLUMNS]))

    def identify(self, plan: Plan, obs: CubeObservations, *, sigma: float | None,
                 noise_model: str | None) -> TriadMultipositionResult:
        """Bias, scale factors and misalignment by least squares per output."""
        su = _scale(plan)
        labels, f, out = obs.labels, obs.f, obs.output
        y = out * su.raw_si_per_raw
        sig = known_sigma(sigma, su.raw_si_per_raw)
        if sig is None and len(f) <= 4:
            raise IdentifiabilityError(
                f"{len(f)} readings leave no degree of freedom for the noise of each output (4 "
                "unknowns per output): record more readings or positions, or give --sigma")
        A = np.column_stack([f, np.ones(len(f))])
        S = np.zeros((3, 3))
        b = np.zeros(3)
        cov = np.zeros((12, 12))
        resid = np.zeros_like(y)
        noise = {}
        dofs = []
        fits = solve_outputs(A, y, sigma_si=sig, groups=position_visits(labels),
                             noise_model=str(noise_model))
        for i, (a, (lf, _)) in enumerate(zip(AXES, fits, strict=True)):
            S[i], b[i] = lf.x[:3], lf.x[3]
            idx = [3 * i, 3 * i + 1, 3 * i + 2, 9 + i]
            cov[np.ix_(idx, idx)] = lf.covariance
            resid[:, i] = lf.residuals
            noise[f"output_{a}"] = float((lf.sigma if sig is None else sig) / su.raw_si_per_raw)
            dofs.append(lf.dof)
        _check_labels(S)
        p = stack_parameters(S, b)
        pooled = float(np.sqrt(np.mean(np.square(list(noise.values())))))
        est, ident = triad_identification(
            p, cov, sensor="accelerometer", scale=su,
            noise_sigma=pooled if sig is None else float("nan"),
            noise_unit=plan.instrument.output_unit,
            # Each output is fitted with its own noise (its own residual dof): a coefficient's
            # std has its output's dof, not the three outputs' sum (which the budget's k took)
            sigma_from_residuals=sig is None, dof=int(min(dofs)), rank=12,
            residuals=(resid / su.raw_si_per_raw).ravel())
        ident = _with_noise_model(ident, [nf for _, nf in fits], su.raw_si_per_raw)
        messages = _messages(est.misalignment)
        reversed_msg = triad.reversed_axes_message(p, "accelerometer", "output_{}")
        if reversed_msg is not None:
            messages.append(reversed_msg)
        for m in messages:
            warnings.warn(m, InertestWarning, stacklevel=3)
        calib = calibration_from_parameters(p, sensor="accelerometer", scale=su,
                                            raw_unit=plan.instrument.output_unit)
        return TriadMultipositionResult(
            procedure=KIND,
            site_latitude_deg=plan.site.latitude_deg,
            site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident,
            calibration=ImuCalibration(accelerometer=calib),
            triads=(est,),
            residual_output=(resid / su.raw_si_per_raw).ravel(),
            output_unit=plan.instrument.output_unit,
            messages=tuple(messages),
            position=labels,
            specific_force=f,
            output=out,
            fitted=out - resid / su.raw_si_per_raw,
            noise_per_axis=noise,
            six_position=six_position_closed_form(labels, out, plan.site.gravity_m_s2),
        )

    def synthesize(self, plan: Plan, motion: Fixture, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Columns ``position``, ``output_x``, ``output_y``, ``output_z`` at the plan's positions.

        ``truth``: ``K_i`` [scale unit], ``M_ij`` [urad], ``B_i`` [mg]; ``noise`` per reading
        [output unit].
        """
        su = _scale(plan)
        spec: TriadMultipositionSpec = plan.procedure
        labels = np.array([p for p in spec.positions for _ in range(spec.samples_per_position)])
        f = motion.positions(labels).inputs_of_rows(labels).f_i
        S, b = triad.model_from_truth(truth, "accelerometer", su)
        raw = (f @ S.T + b) / su.raw_si_per_raw
        raw = raw + noise_samples(raw.size, noise, rng).reshape(raw.shape)
        return {"position": labels, **{c: raw[:, i] for i, c in enumerate(OUTPUT_COLUMNS)}}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = TriadMultiposition()


def _with_noise_model(ident: Identification, noises: list[NoiseFit], raw_si_per_raw: float
                      ) -> Identification:
    """The identification with the noise model used and its checks.

    Components: RMS over the outputs [output unit]; checks: those of an output whose model
    does not fit, else of the output with the smallest p-value.
    """
    comps: dict[str, list[float]] = {}
    for nf in noises:
        for k, v in nf.components.items():
            comps.setdefault(k, []).append(v / raw_si_per_raw)
    def smallest_p(nf: NoiseFit) -> float:
        ps = [p for p in (nf.checks.p_value, nf.checks.serial_p_value) if p is not None]
        return min(ps, default=1.0)

    worst = min(noises, key=lambda nf: (nf.checks.fits, smallest_p(nf)))
    return replace(ident, noise_model=noises[0].model, noise_model_weights=noises[0].weights,
                   noise_components={k: float(np.sqrt(np.mean(np.square(v))))
                                     for k, v in comps.items()},
                   checks=worst.checks)


def _messages(misalignment: Mapping[str, object]) -> list[str]:
    big = [k for k, e in misalignment.items() if abs(e.value) > 0.05 / MICRORAD_TO_RAD]  # type: ignore[attr-defined]
    if big:
        return [f"misalignment {', '.join(big)} exceed 50 mrad: the small-angle model K (I + M) "
                "is only approximate; check the mounting and the position labels"]
    return []
