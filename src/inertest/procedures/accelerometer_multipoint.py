"""Multipoint test of a single pendulous accelerometer on a dividing head in the 1 g field.

Seed ``000_dad8be616c6569c7.txt``, ch. 3 (accelerometer torque-feedback test: "use a precision
dividing head to separate the static-model coefficients"); IEEE Std 1293-2018 / IEEE Std 530
multipoint tumble test. The head turns the accelerometer in a vertical plane (mountings of
:mod:`inertest.equipment.dividing_head`) through positions equally spaced over 360 deg. Model
(:mod:`inertest.models.pendulous_accelerometer`)::

    E / K1 = K0 + aI + K2 aI^2 + K3 aI^3 + KIP aI aP + KIO aI aO + KPO aP aO
                + KPP aP^2 + KOO aO^2 + dO aP - dP aO

Per mounting, the Fourier terms of the output over head angle give the classical closed forms
(IA-PA, ``gamma = g/g0``)::

    B0 = K1 (K0 + gamma^2 (K2 + KPP)/2)    C1 = K1 (gamma + 3 gamma^3 K3/4)    S1 = K1 gamma dO
    C2 = K1 gamma^2 (K2 - KPP)/2           S2 = K1 gamma^2 KIP/2               C3 = K1 gamma^3 K3/4

so ``K1 = (C1 - 3 C3)/gamma``, ``K3 = 4 C3/(K1 gamma^3)``, ``dO = S1/(K1 gamma)``,
``KIP = 2 S2/(K1 gamma^2)``, and only ``K0 + gamma^2 (K2 + KPP)/2`` and ``K2 - KPP`` of the bias and
square terms (IA-OA: the same with P -> O and ``S1 = -K1 gamma dP``). The general least squares over
all mountings identifies what the union determines; because ``aI^2 + aP^2 + aO^2 = gamma^2`` at
every position, ``K0`` and the three square terms are never all separable in the 1 g field.

Data columns: ``mounting`` (IA-PA, IA-OA or PA-OA), ``angle_deg`` (head angle [deg]), ``output``
(accelerometer output ``E`` [instrument output unit]), one row per reading.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.equipment import dividing_head as head
from inertest.equipment.motion import Fixture, StaticPositions
from inertest.errors import (
    DataError,
    IdentifiabilityError,
    InertestWarning,
    InputError,
    PlanError,
)
from inertest.estimation.identify import identify
from inertest.estimation.least_squares import LinearFit
from inertest.estimation.noise_models import NOISE_MODELS
from inertest.models import pendulous_accelerometer as model
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import noise_samples, require_columns
from inertest.results import Combination, Estimate, Identification, LinearTestResult
from inertest.units import G0

KIND = "accelerometer-multipoint"
NAMES = model.COEFFICIENTS
#: Which mounting excites each coefficient that a mounting may leave out (for messages).
_EXCITED_BY = {
    "KIP": "IA-PA", "KPP": "IA-PA or PA-OA", "dO": "IA-PA or PA-OA", "KIO": "IA-OA",
    "KOO": "IA-OA or PA-OA", "dP": "IA-OA or PA-OA", "KPO": "PA-OA (head axis along IA)",
    "K1": "IA-PA or IA-OA", "K2": "IA-PA or IA-OA", "K3": "IA-PA or IA-OA",
}
MIN_POSITIONS = 8


@dataclass(frozen=True)
class AccelerometerMultipointSpec:
    """Parameters of a dividing-head plan (``[procedure]`` table).

    Attributes
    ----------
    mountings : tuple of str
        Planes turned in the vertical plane: ``"IA-PA"``, ``"IA-OA"``, ``"PA-OA"``.
    positions : int
        Head positions per mounting, equally spaced over 360 deg from 0 (at least 8 so that
        the third harmonic does not alias).
    samples_per_position : int
        Readings per position (for simulation).
    noise_model : str
        Noise model behind the uncertainties: ``auto`` (default), ``white``,
        ``position-offsets`` (the head re-settles between positions), ``random-walk`` or
        ``flicker`` (:func:`inertest.estimation.identify.solve`).
    """

    kind: ClassVar[str] = KIND
    mountings: tuple[str, ...] = ("IA-PA", "IA-OA")
    positions: int = 24
    samples_per_position: int = 1
    noise_model: str = "auto"

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> AccelerometerMultipointSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}", ignore=("kind",))
        try:
            mountings = tuple(head.check_mounting(m) for m in v["mountings"])
        except InputError as exc:
            raise PlanError(str(exc)) from None
        if v["positions"] < MIN_POSITIONS:
            raise PlanError(
                f"positions must be an integer >= {MIN_POSITIONS} (equally spaced over 360 deg, "
                f"so the 3rd harmonic of K3 is not aliased), got {v['positions']!r}")
        return cls(**{**v, "mountings": mountings})


#: Parameters of the ``[procedure]`` table of a dividing-head plan.
FIELDS = (
    Field("mountings", "texts", default=("IA-PA", "IA-OA"),
          doc="planes turned in the vertical plane: IA-PA, IA-OA, PA-OA"),
    Field("positions", "integer", default=24,
          doc=f"head positions per mounting, equally spaced over 360 deg (>= {MIN_POSITIONS})"),
    Field("samples_per_position", "integer", default=1, positive=True,
          doc="readings per position (simulation)"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
)




@dataclass(frozen=True, kw_only=True)
class AccelerometerMultipointResult(LinearTestResult):
    """Outcome of :func:`fit`.

    Attributes
    ----------
    identification : Identification
        ``K1`` [output unit/g], ``K0`` [ug], ``K2`` [ug/g^2], ``K3`` [ug/g^3], cross-coupling
        [ug/g^2], ``dO``, ``dP`` [urad] where identifiable; combinations of the rest.
    fourier : dict
        Per mounting: Fourier terms ``B0, S1, C1, S2, C2, S3, C3`` [output unit] and the closed-form
        coefficients derived from them (equally spaced full-circle data only).
    mounting, angle_deg, output, fitted : ndarray
        Rows and the model fit [output unit].
    specific_force_g : ndarray, shape (n, 3)
        (aI, aP, aO) [g0].
    """

    fourier: dict[str, dict[str, object]]
    mounting: NDArray = field(repr=False)
    angle_deg: NDArray[np.float64] = field(repr=False)
    output: NDArray[np.float64] = field(repr=False)
    fitted: NDArray[np.float64] = field(repr=False)
    specific_force_g: NDArray[np.float64] = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block of the result (``result`` in the JSON envelope)."""
        d: dict[str, object] = {}
        d["fourier"] = self.fourier
        return d


@dataclass(frozen=True)
class HeadObservations:
    """Dividing-head readings with the specific force of each row from the head.

    ``mounting``, ``angle_deg``, ``positions`` (labels), ``output`` (n,) [output unit] and
    ``specific_force_g`` (n, 3) = (aI, aP, aO) [g0].
    """

    mounting: NDArray
    angle_deg: NDArray[np.float64]
    positions: NDArray
    output: NDArray[np.float64]
    specific_force_g: NDArray[np.float64]


class AccelerometerMultipoint(Procedure[AccelerometerMultipointSpec, HeadObservations,
                                        AccelerometerMultipointResult]):
    """Pendulous accelerometer on a dividing head (seed 000, ch. 3; IEEE Std 1293 multipoint).

    Data columns ``mounting``, ``angle_deg`` [deg], ``output`` [output unit], in time order;
    rows with the same mounting and angle are one position (the unit of independence).

    A mounting label swapped between IA-PA and IA-OA, or a head turning the other way, cannot be
    seen in the data (the S1/S2 terms just move between dO/KIP and dP/KIO, or change sign): the
    labels in the data file are trusted.
    """

    kind = KIND
    title = "Pendulous accelerometer, dividing head"
    spec = AccelerometerMultipointSpec
    model = "inertest.models.pendulous_accelerometer"
    method = "weighted least squares under a noise model; Fourier closed forms per mounting"
    machines = (head,)
    noise_models = NOISE_MODELS
    report = "inertest.report.accelerometer:multipoint_sections"

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> Fixture:
        """The dividing head at the plan's site (with its Type-B errors)."""
        return Fixture(head.motion, plan.site, dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Fixture
               ) -> HeadObservations:
        """Each row's mounting, head angle and specific force (aI, aP, aO)."""
        _check_instrument(plan)
        cols = require_columns(data, ("angle_deg", "output"), ("mounting",), procedure=KIND)
        try:
            mounting = np.array([head.check_mounting(m) for m in cols["mounting"]])
        except InputError as exc:
            raise InputError(f"column mounting: {exc}") from None
        positions = head.position_labels(mounting, cols["angle_deg"])
        a = _specific_force(motion.positions(np.unique(mounting), np.unique(cols["angle_deg"])),
                            positions)
        return HeadObservations(mounting, cols["angle_deg"], positions, cols["output"], a)

    def identify(self, plan: Plan, obs: HeadObservations, *, sigma: float | None,
                 noise_model: str | None) -> AccelerometerMultipointResult:
        """The pendulous-accelerometer model by least squares, and the Fourier closed forms.

        Raises
        ------
        IdentifiabilityError
            K1 cannot be found (no mounting with IA in the vertical plane, or too few positions
            to separate K1 from K3).
        DataError
            K1 comes out negative (IA reversed or output sign inverted).
        """
        mounting, a, y = obs.mounting, obs.specific_force_g, obs.output
        gamma = plan.site.gravity_g
        A = model.regressors(a)
        unit = plan.instrument.output_unit
        if sigma is not None and not (np.isfinite(sigma) and sigma > 0):
            raise PlanError(f"noise sigma must be finite and positive, got {sigma}")
        if sigma is None and len(y) <= np.linalg.matrix_rank(A):
            raise IdentifiabilityError(
                f"{len(y)} readings leave no degree of freedom for the noise: record more "
                "positions or readings, or give --sigma")
        lsq, theta_ident = _identify(A, y, sigma, unit,
                                     _explainer(tuple(np.unique(mounting)), gamma),
                                     obs.positions, str(noise_model))
        if not lsq.identifiable[NAMES.index("K1")]:
            raise IdentifiabilityError(_k1_message(mounting, obs.angle_deg))
        if lsq.x[NAMES.index("K1")] <= 0:
            raise DataError(
                f"the output falls as IA turns up (K1 = {lsq.x[NAMES.index('K1')]:.6g} "
                f"{unit}/g): IA is mounted reversed or the output sign is inverted; negate the "
                "output column or check the mounting (head angle 0 must put IA up)")
        ident = _engineering(lsq, theta_ident, unit)
        messages = _spacing_messages(mounting, obs.angle_deg)
        for m in messages:
            warnings.warn(m, InertestWarning, stacklevel=3)
        return AccelerometerMultipointResult(
            site_latitude_deg=plan.site.latitude_deg,
            site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident,
            fourier=fourier_analysis(mounting, obs.angle_deg, y, gamma, unit=unit),
            mounting=mounting,
            angle_deg=obs.angle_deg,
            output=y,
            fitted=y - lsq.residuals,
            specific_force_g=a,
            residual_output=lsq.residuals,
            output_unit=unit,
            messages=tuple(messages),
        )

    def synthesize(self, plan: Plan, motion: Fixture, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Columns ``mounting``, ``angle_deg``, ``output`` of the plan's dividing-head positions.

        ``truth``: ``K1`` [output unit/g], ``K0`` [ug], ``K2`` [ug/g^2], ``K3`` [ug/g^3],
        ``KIP``, ``KIO``, ``KPO``, ``KPP``, ``KOO`` [ug/g^2], ``dO``, ``dP`` [urad]; missing
        names are 0 (``K1`` required). ``noise`` per reading [output unit].
        """
        _check_instrument(plan)
        spec: AccelerometerMultipointSpec = plan.procedure
        angles = head.equally_spaced(spec.positions)
        reps = spec.samples_per_position
        mounting = np.repeat(np.array(spec.mountings), angles.size * reps)
        angle = np.tile(np.repeat(angles, reps), len(spec.mountings))
        a = _specific_force(motion.positions(spec.mountings, angles),
                            head.position_labels(mounting, angle))
        try:
            e = model.output(a, truth)
        except InputError as exc:
            raise PlanError(f"truth: {exc}") from None
        e = e + noise_samples(e.size, noise, rng)
        return {"mounting": mounting, "angle_deg": angle, "output": e}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = AccelerometerMultipoint()


def _identify(
    A: NDArray[np.float64], y: NDArray[np.float64], sigma: float | None, unit: str, explain,
    groups: NDArray, noise_model: str,
) -> tuple[LinearFit, Identification]:
    """:func:`identify` on ``theta`` (also with fewer readings than coefficients)."""
    return identify(
        A, y, sigma_si=sigma, names=NAMES, units={n: unit for n in NAMES},
        si_per_unit={n: 1.0 for n in NAMES}, noise_unit=unit, si_per_noise_unit=1.0,
        pivot_order=("K0", "K2", "KPP", "KOO"), normalize_to="K0", explain=explain,
        groups=groups, noise_model=noise_model)


def _specific_force(motion: StaticPositions, labels: NDArray) -> NDArray[np.float64]:
    """Specific force (aI, aP, aO) [g0] of each row, from the head's motion."""
    return motion.inputs_of_rows(labels).f_i / G0


def _check_instrument(plan: Plan) -> None:
    if plan.instrument.kind != "accelerometer":
        raise PlanError(f'{KIND} tests a single accelerometer: set [instrument] kind = '
                        f'"accelerometer", not "{plan.instrument.kind}"')


def _engineering(lsq: LinearFit, ident: Identification, unit: str) -> Identification:
    """``theta = K1 * c`` -> ``K1`` and ``c`` in micro-units, covariance by the Jacobian."""
    k = NAMES.index("K1")
    theta, C = lsq.x, lsq.covariance
    k1 = theta[k]
    J = np.zeros((len(NAMES), len(NAMES)))
    for i in range(len(NAMES)):
        if i == k:
            J[i, i] = 1.0
        else:
            J[i, i] = 1.0 / (k1 * model.MICRO)
            J[i, k] = -theta[i] / (k1**2 * model.MICRO)
    value = np.where(np.arange(len(NAMES)) == k, theta, theta / (k1 * model.MICRO))
    cov = J @ C @ J.T
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    units = {n: (f"{unit}/g" if n == "K1" else model.ENGINEERING_UNIT[n]) for n in NAMES}
    coefficients = {
        n: Estimate(n, float(value[i]), float(std[i]), units[n])
        for i, n in enumerate(NAMES) if n in ident.coefficients
    }
    combos = []
    for c in ident.combinations:
        w = np.array([c.terms.get(n, 0.0) for n in NAMES])
        jw = w @ J  # gradient of w . c_eng with respect to theta
        combos.append(Combination(
            name=c.name, terms=dict(c.terms), value=float(w @ value),
            std=float(np.sqrt(max(float(jw @ C @ jw), 0.0))),
            unit=units[next(iter(c.terms))]))
    return Identification(
        coefficients=coefficients, combinations=tuple(combos), not_separable=ident.not_separable,
        covariance=cov, names=NAMES, noise_sigma=ident.noise_sigma, noise_unit=unit,
        sigma_from_residuals=ident.sigma_from_residuals, dof=ident.dof, rank=ident.rank,
        residuals=ident.residuals, noise_model=ident.noise_model,
        noise_components=ident.noise_components, checks=ident.checks)


def _explainer(mountings: Sequence[str], gamma: float):
    def explain(fit: LinearFit, A: NDArray[np.float64]) -> list[str]:
        out = []
        zero = [NAMES[i] for i in range(A.shape[1]) if not np.any(np.abs(A[:, i]) > 1e-12)]
        for n in zero:
            out.append(f"{n}: not excited by the mounting(s) {', '.join(mountings)} (its "
                       f"regressor is zero at every position); add a {_EXCITED_BY.get(n, '?')} "
                       "mounting to find it")
        mixed = [NAMES[i] for i in range(A.shape[1])
                 if NAMES[i] not in zero and np.linalg.norm(fit.null_space[i]) > 1e-7]
        squares = {"K0", "K2", "KPP", "KOO"}
        if mixed and set(mixed) <= squares:
            out.append(
                f"{', '.join(mixed)}: aI^2 + aP^2 + aO^2 = {gamma:.6f}^2 g^2 at every position "
                "of a 1 g test, so the bias and the square terms are found only in the "
                "combinations listed")
        elif mixed:
            out.append(f"{', '.join(mixed)}: not separable by these positions; only the "
                       "combinations listed are determined")
        return out

    return explain


def _k1_message(mounting: NDArray, angle_deg: NDArray) -> str:
    ms = sorted(set(mounting.tolist()))
    if not any(m.startswith("IA") for m in ms):
        return (f"K1 cannot be found: with mounting(s) {', '.join(ms)} the input axis IA never "
                "feels gravity; add an IA-PA or IA-OA mounting")
    n = {m: np.unique(np.round(angle_deg[mounting == m], 9) % 360).size for m in ms}
    return (f"K1 cannot be separated from K3 (or the other terms): distinct positions per "
            f"mounting {n}; use at least {MIN_POSITIONS} positions equally spaced over 360 deg in "
            "an IA-PA or IA-OA mounting")


def _spacing_messages(mounting: NDArray, angle_deg: NDArray) -> list[str]:
    out = []
    for m in np.unique(mounting):
        t = np.unique(np.round(np.asarray(angle_deg)[mounting == m] % 360.0, 9))
        if t.size < MIN_POSITIONS or not _equally_spaced(t):
            out.append(f"mounting {m}: the {t.size} head angles are not {MIN_POSITIONS}+ "
                       "positions equally spaced over 360 deg; the Fourier closed forms are "
                       "skipped for it (the least-squares solution still holds)")
    return out


def _equally_spaced(t: NDArray[np.float64]) -> bool:
    d = np.diff(np.append(np.sort(t), np.sort(t)[0] + 360.0))
    return bool(np.allclose(d, 360.0 / t.size, atol=1e-6))


def fourier_analysis(
    mounting: NDArray, angle_deg: NDArray[np.float64], output: NDArray[np.float64], gamma: float,
    *, unit: str = "output",
) -> dict[str, dict[str, object]]:
    """Fourier terms per mounting and the closed-form coefficients (IEEE Std 1293 multipoint).

    Only for mountings whose angles are >= 8 equally spaced positions over 360 deg (each
    position's readings averaged first). ``Ck = (2/N) sum E cos(k theta)``,
    ``Sk = (2/N) sum E sin(k theta)``, ``B0 = mean E``.

    Returns
    -------
    dict
        ``{mounting: {"harmonics": {name: value [output unit]}, "coefficients": {name:
        {"value", "unit"}}, "combinations": {name: {"value", "unit"}}}}``.
    """
    out: dict[str, dict[str, object]] = {}
    for m in np.unique(mounting):
        sel = mounting == m
        tdeg = np.round(np.asarray(angle_deg)[sel] % 360.0, 9)
        t_u, inv = np.unique(tdeg, return_inverse=True)
        if t_u.size < MIN_POSITIONS or not _equally_spaced(t_u):
            continue
        e = np.bincount(inv, weights=output[sel]) / np.bincount(inv)
        t = np.radians(t_u)
        n = t.size
        h = {"B0": float(e.mean())}
        for k in (1, 2, 3):
            h[f"S{k}"] = float(2.0 / n * np.sum(e * np.sin(k * t)))
            h[f"C{k}"] = float(2.0 / n * np.sum(e * np.cos(k * t)))
        out[str(m)] = {"harmonics": h, **_closed_form(str(m), h, gamma, unit)}
    return out


def _closed_form(m: str, h: Mapping[str, float], g: float, unit: str) -> dict[str, object]:
    u = model.MICRO
    if m == "PA-OA":  # IA horizontal: K1 is not found, only K1 times the coefficients
        return {"coefficients": {}, "combinations": {}}
    k1 = (h["C1"] - 3 * h["C3"]) / g
    other, d_name, d_sign, cross = (("PP", "dO", 1.0, "KIP") if m == "IA-PA"
                                    else ("OO", "dP", -1.0, "KIO"))
    coeff = {
        "K1": {"value": k1, "unit": f"{unit}/g"},
        "K3": {"value": 4 * h["C3"] / (k1 * g**3) / u, "unit": "ug/g^3"},
        d_name: {"value": d_sign * h["S1"] / (k1 * g) / u, "unit": "urad"},
        cross: {"value": 2 * h["S2"] / (k1 * g**2) / u, "unit": "ug/g^2"},
    }
    combos = {
        f"K0 + {g**2 / 2:.6g}*K2 + {g**2 / 2:.6g}*K{other}": {
            "value": h["B0"] / k1 / u, "unit": "ug"},
        f"K2 - K{other}": {"value": 2 * h["C2"] / (k1 * g**2) / u, "unit": "ug/g^2"},
    }
    return {"coefficients": coeff, "combinations": combos}
