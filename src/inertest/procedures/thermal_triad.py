"""A triad calibration (K, M, B) as a function of temperature, with heating/cooling hysteresis.

Seed ``003_f374f866dfe7c99f.txt``: the FOG/accelerometer triad model of eq. (1) (scale factor,
misalignment, bias; :mod:`inertest.models.triad`) is calibrated by the multi-position method
(sec. 1.1), and its coefficients drift with temperature (sec. 3, temperature compensation).
Here the multi-position calibration (:func:`inertest.procedures.triad_multiposition.fit`) is
run at each temperature step of a chamber programme, then each coefficient ``q`` (``K_i``,
``M_ij`` [urad], ``B_i`` [mg]) is fitted by weighted least squares (weights: the per-step
standard uncertainties) as a polynomial in temperature, optionally plus a term in its rate::

    q(T, dT/dt) = sum_{k=0..degree} a_k (T - T_ref)^k  [+ r dT/dt]     T [degC], dT/dt [degC/min]

Hysteresis: the heating and cooling steps are fitted separately with the same polynomial; the
difference of the two curves ``D(T) = q_heat(T) - q_cool(T)`` is reported at its largest over the
common temperature range, with its standard uncertainty, and the Wald statistic of the
coefficient differences ``d^T (C_heat + C_cool)^-1 d`` (chi-square with ``degree + 1`` dof)
decides whether it is significant (p below ``alpha / number of coefficients``, Bonferroni over
the twelve coefficients, so the family false-alarm rate is ``alpha``).

The fitted laws are exported as a :class:`TriadThermalModel` (JSON of plain numbers, format
:data:`MODEL_FORMAT_VERSION`) that corrects a recording at each row's temperature, per the triad
model's convention ``raw = K (I + M) (u + B)`` (:mod:`inertest.models.triad`)::

    u = (I + M(T))^-1 K(T)^-1 raw - B(T)          [m/s^2]

Data columns: ``temperature_c`` [degC], ``branch`` (``heating`` or ``cooling``), ``position``,
``output_x``, ``output_y``, ``output_z`` [output unit], optional ``step`` (the temperature step
of each row; default: a new step where the branch changes or the temperature jumps by more
than 1 degC between consecutive rows) and
``temperature_rate_c_per_min`` [degC/min].
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from inertest.errors import DataError, IdentifiabilityError, InputError
from inertest.estimation.least_squares import weighted_least_squares
from inertest.models import triad
from inertest.models.thermal import check_model_header
from inertest.plan import Plan
from inertest.procedures.triad_multiposition import TriadMultiposition
from inertest.results import envelope

KIND = "thermal-triad"
#: ``kind`` and format version of the model file written by ``thermal triad --model-out``.
MODEL_KIND = "thermal-triad-model"
MODEL_FORMAT_VERSION = 1
#: Rows corrected at a time by :meth:`TriadThermalModel.compensate` (bounds the temporaries).
CHUNK_ROWS = 16384
#: The multi-position calibration run at each chamber step (the one composition of procedures).
_MULTIPOSITION = TriadMultiposition()
BRANCHES = ("heating", "cooling")
#: Temperature jump between consecutive rows that starts a new step [degC].
STEP_JUMP_C = 1.0


@dataclass(frozen=True)
class CoefficientLaw:
    """One coefficient's polynomial in temperature (and rate).

    Attributes
    ----------
    name, unit : str
        ``K_x`` .. ``B_z`` and its engineering unit.
    t_ref_c : float
        Reference temperature [degC].
    coefficients, covariance : ndarray
        ``a_0 .. a_degree`` [unit / degC^k] (then ``r`` [unit / (degC/min)] with the rate).
    chi2, dof, p_value : float, int, float
        Weighted residual sum of squares of the per-step values about the law, its degrees of
        freedom and the probability of a larger one if the law and the step uncertainties hold.
    """

    name: str
    unit: str
    t_ref_c: float
    degree: int
    uses_rate: bool
    coefficients: NDArray[np.float64] = field(repr=False)
    covariance: NDArray[np.float64] = field(repr=False)
    chi2: float
    dof: int
    p_value: float

    def predict(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Value [unit] and its standard uncertainty at temperatures [degC] (and rates)."""
        A = _design(np.atleast_1d(np.asarray(temperature_c, dtype=float)) - self.t_ref_c,
                    self.degree, None if not self.uses_rate else rate_c_per_min,
                    self.uses_rate)
        value = A @ self.coefficients
        std = np.sqrt(np.clip(np.einsum("ij,jk,ik->i", A, self.covariance, A), 0.0, None))
        return value, std

    def to_dict(self) -> dict[str, object]:
        """JSON: terms with units, covariance, goodness of fit."""
        std = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        names = [f"a{k}" for k in range(self.degree + 1)] + (["r"] if self.uses_rate else [])
        units = ([self.unit] + [f"{self.unit}/degC" + (f"^{k}" if k > 1 else "")
                                for k in range(1, self.degree + 1)]
                 + ([f"{self.unit}/(degC/min)"] if self.uses_rate else []))
        return {
            "equation": (f"{self.name} [{self.unit}] = sum_k a_k (T - T_ref)^k"
                         + (" + r dT/dt" if self.uses_rate else "")
                         + f"; T [degC], T_ref = {self.t_ref_c:g} degC"),
            "terms": {n: {"value": float(v), "std": float(s), "unit": u}
                      for n, v, s, u in zip(names, self.coefficients, std, units, strict=True)},
            "covariance": self.covariance.tolist(),
            "chi2": self.chi2, "dof": self.dof, "p_value": self.p_value,
        }

    def to_model_dict(self) -> dict[str, object]:
        """:meth:`to_dict` plus what :meth:`from_model_dict` needs to rebuild the law."""
        return {"unit": self.unit, "t_ref_c": self.t_ref_c, "degree": self.degree,
                "uses_rate": self.uses_rate, **self.to_dict()}

    @classmethod
    def from_model_dict(cls, name: str, d: Mapping[str, object]) -> CoefficientLaw:
        """Inverse of :meth:`to_model_dict`; errors name the coefficient and the key."""
        try:
            degree = int(d["degree"])  # type: ignore[call-overload]
            uses_rate = bool(d["uses_rate"])
            names = [f"a{k}" for k in range(degree + 1)] + (["r"] if uses_rate else [])
            terms = d["terms"]
            coef = np.array([float(terms[n]["value"]) for n in names])  # type: ignore[index]
            cov = np.asarray(d["covariance"], dtype=float)
            law = cls(name, str(d["unit"]), float(d["t_ref_c"]), degree,  # type: ignore[arg-type]
                      uses_rate, coef, cov, float(d.get("chi2", np.nan)),  # type: ignore[arg-type]
                      int(d.get("dof", 0)), float(d.get("p_value", np.nan)))  # type: ignore[call-overload, arg-type]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"law {name} of the triad thermal model is malformed ({exc!r}); "
                             "write it again with inertest thermal triad --model-out") from None
        if cov.shape != (coef.size, coef.size) or not (np.all(np.isfinite(coef))
                                                       and np.all(np.isfinite(cov))):
            raise InputError(f"law {name}: covariance must be a finite {coef.size}x{coef.size} "
                             "matrix and the coefficients finite")
        return law


@dataclass(frozen=True)
class Hysteresis:
    """Heating minus cooling curve of one coefficient.

    Attributes
    ----------
    max_difference, std : float
        ``D(T)`` at the temperature where ``|D|`` is largest, and its standard uncertainty
        [unit].
    at_temperature_c : float
    statistic, dof, p_value : float, int, float
        Wald chi-square of the coefficient differences.
    significant : bool
        ``p_value`` below the per-coefficient threshold.
    """

    name: str
    unit: str
    max_difference: float
    std: float
    at_temperature_c: float
    statistic: float
    dof: int
    p_value: float
    significant: bool

    def to_dict(self) -> dict[str, object]:
        """JSON with units and the verdict."""
        return {
            "heating_minus_cooling": {"value": self.max_difference, "std": self.std,
                                      "unit": self.unit},
            "at_temperature_c": self.at_temperature_c,
            "wald_chi2": self.statistic, "dof": self.dof, "p_value": self.p_value,
            "verdict": "significant" if self.significant else "not significant",
        }


@dataclass(frozen=True)
class TriadThermalModel:
    """The triad's K(T), M(T), B(T) laws, ready to correct a recording.

    Attributes
    ----------
    laws : dict of CoefficientLaw
        ``K_x..K_z`` [scale unit], ``M_ij`` [urad], ``B_x..B_z`` [mg, input-referred].
    raw_unit : str
        Unit of the raw output (the plan's ``output_unit``).
    scale : ScaleUnit
        How ``K`` is reported (:func:`inertest.models.triad.scale_unit`).
    temperature_range_c : tuple of float
        Step temperatures of the fit [degC] (min, max): the valid range.
    rate_range_c_per_min : tuple of float or None
        Step temperature rates [degC/min] (min, max) when the laws have a rate term.
    serial : str
    sensor : str
        ``"accelerometer"`` (the multi-position procedure calibrates accelerometer triads).
    covariance : ndarray or None
        Joint covariance of the coefficients of all laws (laws in
        :func:`~inertest.models.triad.parameter_names` order, each law's ``a_0..a_degree`` [then
        ``r``]), engineering units; ``None``: the laws' own covariances, taken as independent.

    Notes
    -----
    Correction of a row at temperature ``T`` (triad model of seed 003, eq. (1),
    ``raw = K (I + M) (u + B)``)::

        u = (I + M(T))^-1 K(T)^-1 raw - B(T)            [SI: m/s^2]

    Its standard uncertainty is first order in the law coefficients ``a`` (all twelve laws
    stacked, :func:`~inertest.models.triad.parameter_names` order): ``var u_i = (J_a C_a
    J_a^T)_ii`` with ``J_a = (du/dq) (dq/da)``, where, with ``w = K^-1 raw`` and
    ``v = (I + M)^-1 w``, ``du/dK_j = -(I + M)^-1 e_j w_j / K_j``, ``du/dM_ij = -(I + M)^-1
    e_i v_j``, ``du/dB_i = -e_i`` and ``dq/da`` is each law's design row. ``C_a`` is
    :attr:`covariance`: the laws are fitted from the same per-step triad fits, so their
    coefficients are correlated (``C_a = sum_steps L_q C_step[q, q'] L_q'^T``, ``L_q`` the
    weighted least-squares operator of law ``q``); a tilted or unbalanced position set makes
    ``K_i`` and ``M_ij`` strongly correlated at each step. Without it (a model file that lacks
    ``joint_covariance``) the laws are taken as independent.
    """

    laws: dict[str, CoefficientLaw]
    raw_unit: str
    scale: triad.ScaleUnit
    temperature_range_c: tuple[float, float]
    rate_range_c_per_min: tuple[float, float] | None = None
    serial: str = ""
    sensor: str = "accelerometer"
    covariance: NDArray[np.float64] | None = field(default=None, repr=False)

    kind: ClassVar[str] = MODEL_KIND

    def __post_init__(self) -> None:
        missing = [n for n in triad.parameter_names() if n not in self.laws]
        if missing:
            raise InputError(f"triad thermal model lacks the law(s) {', '.join(missing)}")
        if self.covariance is not None:
            n = sum(self.laws[q].coefficients.size for q in triad.parameter_names())
            c = np.asarray(self.covariance, dtype=float)
            if c.shape != (n, n) or not np.all(np.isfinite(c)):
                raise InputError(f"joint covariance of the triad thermal model must be a finite "
                                 f"{n}x{n} matrix (the coefficients of all laws), got shape "
                                 f"{c.shape}")

    def joint_covariance(self) -> NDArray[np.float64]:
        """:attr:`covariance`, or the laws' covariances as a block diagonal when it is None."""
        if self.covariance is not None:
            return np.asarray(self.covariance, dtype=float)
        blocks = [self.laws[q].covariance for q in triad.parameter_names()]
        n = sum(b.shape[0] for b in blocks)
        out = np.zeros((n, n))
        k = 0
        for b in blocks:
            out[k:k + b.shape[0], k:k + b.shape[0]] = b
            k += b.shape[0]
        return out

    @property
    def uses_rate(self) -> bool:
        """Whether the laws need the temperature rate [degC/min]."""
        return any(law.uses_rate for law in self.laws.values())

    @property
    def unit(self) -> str:
        """SI unit of the corrected output."""
        return triad.INPUT_SI_UNITS[self.sensor]

    def out_of_range(self, temperature_c: ArrayLike, rate_c_per_min: ArrayLike | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Distance of each row outside the valid range: temperature [degC], rate [degC/min].

        Zero inside the range.
        """
        t = np.atleast_1d(np.asarray(temperature_c, dtype=float))
        lo, hi = self.temperature_range_c
        dt = np.maximum(lo - t, 0.0) + np.maximum(t - hi, 0.0)
        dr = None
        if rate_c_per_min is not None and self.rate_range_c_per_min is not None:
            r = np.broadcast_to(np.asarray(rate_c_per_min, dtype=float), t.shape)
            rlo, rhi = self.rate_range_c_per_min
            dr = np.maximum(rlo - r, 0.0) + np.maximum(r - rhi, 0.0)
        return dt, dr

    def compensate(self, raw: ArrayLike, temperature_c: ArrayLike,
                   rate_c_per_min: ArrayLike | None = None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Corrected input and its standard uncertainty at each row's temperature.

        Parameters
        ----------
        raw : array_like, shape (n, 3)
            Raw output [raw_unit].
        temperature_c, rate_c_per_min : array_like, shape (n,)
            Temperature [degC] (and rate [degC/min] when the laws use it) of each row.

        Returns
        -------
        u, std : ndarray, shape (n, 3)
            Corrected input and its standard uncertainty from the laws [SI, :attr:`unit`].
            Rows are processed :data:`CHUNK_ROWS` at a time.
        """
        r = np.asarray(raw, dtype=float)
        if r.ndim != 2 or r.shape[1] != 3:
            raise InputError(f"raw triad output must have shape (n, 3), got {r.shape}")
        t = np.asarray(temperature_c, dtype=float).reshape(-1)
        if t.size != r.shape[0]:
            raise InputError(f"{t.size} temperatures for {r.shape[0]} rows")
        if self.uses_rate and rate_c_per_min is None:
            raise InputError("these laws have a rate term: give the temperature rate "
                             "[degC/min] (CLI: --time-column)")
        rate = (None if rate_c_per_min is None
                else np.broadcast_to(np.asarray(rate_c_per_min, dtype=float), t.shape))
        _, b_si = triad.bias_unit(self.sensor)
        names = triad.parameter_names()
        C = self.joint_covariance()
        u = np.empty_like(r)
        std = np.empty_like(r)
        for a in range(0, t.size, CHUNK_ROWS):
            sl = slice(a, a + CHUNK_ROWS)
            tc, rc = t[sl], None if rate is None else rate[sl]
            # each law's design row (n, p_q) and value (n,) at the rows' temperatures and rates
            rows = {q: _design(tc - self.laws[q].t_ref_c, self.laws[q].degree, rc,
                               self.laws[q].uses_rate) for q in names}
            val = {q: rows[q] @ self.laws[q].coefficients for q in names}
            K = np.column_stack([val[q] for q in triad.SCALE_NAMES])  # scale unit
            IM = np.broadcast_to(np.eye(3), (tc.size, 3, 3)).copy()
            for q, (i, j) in zip(triad.MISALIGNMENT_NAMES, triad.OFF_DIAGONAL, strict=True):
                IM[:, i, j] = val[q] * triad.MICRORAD_TO_RAD
            B = np.column_stack([val[q] for q in triad.BIAS_NAMES]) * b_si
            w = r[sl] * self.scale.raw_si_per_raw / (K * self.scale.si_per_unit)
            P = np.linalg.inv(IM)
            v = np.einsum("nij,nj->ni", P, w)
            u[sl] = v - B
            # du/dq (n, 3, 12) in engineering units of q, then du/da through the design rows
            J = np.empty((tc.size, 3, len(names)))
            J[:, :, :3] = -P * (w / K)[:, None, :]
            for k, (i, j) in enumerate(triad.OFF_DIAGONAL):
                J[:, :, 3 + k] = -P[:, :, i] * (v[:, j] * triad.MICRORAD_TO_RAD)[:, None]
            J[:, :, 9:] = -np.eye(3) * b_si
            Ja = np.concatenate([J[:, :, k, None] * rows[q][:, None, :]
                                 for k, q in enumerate(names)], axis=2)
            std[sl] = np.sqrt(np.clip(np.einsum("nip,nip->ni", Ja @ C, Ja), 0.0, None))
        return u, std

    def to_dict(self) -> dict[str, object]:
        """Versioned JSON document: laws with covariance and units, ranges, serial."""
        return {
            "kind": MODEL_KIND,
            "format_version": MODEL_FORMAT_VERSION,
            "serial": self.serial,
            "sensor": self.sensor,
            "raw_unit": self.raw_unit,
            "output_unit": self.unit,
            "scale_unit": {"unit": self.scale.unit, "si_per_unit": self.scale.si_per_unit,
                           "raw_si_per_raw": self.scale.raw_si_per_raw,
                           "nominal": self.scale.nominal},
            "model": "raw = K (I + M) (u + B); K [scale unit], M [urad], B [mg] each a "
                     "polynomial in (T - T_ref) [degC] (+ r dT/dt [degC/min])",
            "compensation": "u = (I + M(T))^-1 K(T)^-1 (raw * raw_si_per_raw / si_per_unit) "
                            "- B(T) * 9.80665e-3  [m/s^2]",
            "inputs": ["temperature_c"] + (["temperature_rate_c_per_min"] if self.uses_rate
                                           else []),
            "valid_range": {
                "temperature_c": list(self.temperature_range_c),
                "temperature_rate_c_per_min": (None if self.rate_range_c_per_min is None
                                               else list(self.rate_range_c_per_min)),
            },
            "laws": {n: law.to_model_dict() for n, law in self.laws.items()},
            **({} if self.covariance is None else {"joint_covariance": {
                "names": _coefficient_names(self.laws),
                "unit": "each law's term units (laws[name].terms)",
                "matrix": np.asarray(self.covariance).tolist()}}),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> TriadThermalModel:
        """Inverse of :meth:`to_dict`; errors name the key and the fix."""
        check_model_header(d, kind=MODEL_KIND, version=MODEL_FORMAT_VERSION,
                           what="triad thermal model",
                           fix="write one with inertest thermal triad --model-out")
        try:
            su = d["scale_unit"]
            scale = triad.ScaleUnit(str(su["unit"]), float(su["si_per_unit"]),  # type: ignore[index]
                                    float(su["raw_si_per_raw"]),  # type: ignore[index]
                                    None if su.get("nominal") is None  # type: ignore[union-attr]
                                    else float(su["nominal"]))  # type: ignore[index]
            vr = d["valid_range"]
            trange = tuple(float(x) for x in vr["temperature_c"])  # type: ignore[index]
            rr = vr.get("temperature_rate_c_per_min")  # type: ignore[union-attr]
            rrange = None if rr is None else tuple(float(x) for x in rr)
            laws_doc = d["laws"]
            laws = {str(n): CoefficientLaw.from_model_dict(str(n), v)
                    for n, v in laws_doc.items()}  # type: ignore[union-attr]
            jc = d.get("joint_covariance")
            cov: NDArray[np.float64] | None = (
                None if jc is None
                else np.asarray(jc["matrix"], dtype=np.float64))  # type: ignore[index]
            return cls(laws=laws, raw_unit=str(d["raw_unit"]), scale=scale, covariance=cov,
                       temperature_range_c=trange,  # type: ignore[arg-type]
                       rate_range_c_per_min=rrange,  # type: ignore[arg-type]
                       serial=str(d.get("serial", "")),
                       sensor=str(d.get("sensor", "accelerometer")))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise InputError(f"malformed triad thermal model ({exc!r}); write it again with "
                             "inertest thermal triad --model-out") from None


@dataclass(frozen=True)
class ThermalTriadResult:
    """Outcome of :func:`fit_triad_thermal`.

    Attributes
    ----------
    step_temperature_c, step_rate_c_per_min : ndarray, shape (n_steps,)
        Mean temperature [degC] and rate [degC/min] of each step.
    step_branch : ndarray of str
    step_values, step_stds : dict of ndarray
        Each coefficient's multi-position estimate and standard uncertainty per step [unit].
    units : dict of str
    laws : dict of CoefficientLaw
        Fit over all steps.
    hysteresis : dict of Hysteresis
        Empty when either branch has too few steps.
    alpha : float
        Family significance level of the hysteresis verdicts.
    messages : tuple of str
    law_covariance : ndarray or None
        Joint covariance of all laws' coefficients (:attr:`TriadThermalModel.covariance`):
        the laws come from the same per-step triad fits, whose twelve coefficients are
        correlated.
    """

    step_temperature_c: NDArray[np.float64] = field(repr=False)
    step_rate_c_per_min: NDArray[np.float64] = field(repr=False)
    step_branch: NDArray = field(repr=False)
    step_values: dict[str, NDArray[np.float64]] = field(repr=False)
    step_stds: dict[str, NDArray[np.float64]] = field(repr=False)
    units: dict[str, str]
    laws: dict[str, CoefficientLaw]
    hysteresis: dict[str, Hysteresis]
    alpha: float
    serial: str = ""
    messages: tuple[str, ...] = ()
    raw_unit: str = ""
    scale: triad.ScaleUnit | None = None
    law_covariance: NDArray[np.float64] | None = field(default=None, repr=False)

    kind: ClassVar[str] = KIND

    def model(self) -> TriadThermalModel:
        """The laws as a :class:`TriadThermalModel` (valid over the step temperatures)."""
        if self.scale is None:
            raise InputError("this result does not know the triad's units; fit it with "
                             "fit_triad_thermal")
        uses_rate = any(law.uses_rate for law in self.laws.values())
        t, r = self.step_temperature_c, self.step_rate_c_per_min
        return TriadThermalModel(
            laws=dict(self.laws), raw_unit=self.raw_unit, scale=self.scale,
            temperature_range_c=(float(t.min()), float(t.max())),
            rate_range_c_per_min=(float(r.min()), float(r.max())) if uses_rate else None,
            serial=self.serial, covariance=self.law_covariance)

    def coefficients_at(self, temperature_c: float, rate_c_per_min: float = 0.0
                        ) -> dict[str, tuple[float, float]]:
        """Every coefficient's (value, std) [unit] at one temperature [degC] (and rate)."""
        out = {}
        for n, law in self.laws.items():
            v, s = law.predict([temperature_c], [rate_c_per_min])
            out[n] = (float(v[0]), float(s[0]))
        return out

    def to_dict(self) -> dict[str, object]:
        """The result envelope: steps, laws, hysteresis verdicts."""
        flagged = [n for n, h in self.hysteresis.items() if h.significant]
        checks = []
        if self.hysteresis:
            checks.append({
                "name": "hysteresis between heating and cooling",
                "verdict": "significant" if flagged else "not significant",
                "coefficients": flagged, "alpha": self.alpha,
            })
        misfit = [n for n, law in self.laws.items()
                  if law.dof > 0 and law.p_value < self.alpha / max(len(self.laws), 1)]
        checks.append({"name": "polynomial laws fit the steps within their uncertainties",
                       "verdict": "warning" if misfit else "ok", "coefficients": misfit})
        return envelope(self.kind, instrument={"serial": self.serial} if self.serial else None,
                        result={
            "steps": [{"temperature_c": float(t), "rate_c_per_min": float(r), "branch": str(b),
                       "coefficients": {n: {"value": float(self.step_values[n][k]),
                                            "std": float(self.step_stds[n][k]),
                                            "unit": self.units[n]} for n in self.units}}
                      for k, (t, r, b) in enumerate(zip(self.step_temperature_c,
                                                        self.step_rate_c_per_min,
                                                        self.step_branch, strict=True))],
            "laws": {n: law.to_dict() for n, law in self.laws.items()},
            "hysteresis": {n: h.to_dict() for n, h in self.hysteresis.items()},
            **({} if self.law_covariance is None else {"law_covariance": {
                "names": _coefficient_names(self.laws),
                "matrix": self.law_covariance.tolist()}}),
        }, checks=checks, messages=self.messages)


def _coefficient_names(laws: Mapping[str, CoefficientLaw]) -> list[str]:
    """``K_x.a0`` .. ``B_z.r``: the order of the joint covariance of the laws."""
    return [f"{q}.{t}" for q in triad.parameter_names()
            for t in [f"a{k}" for k in range(laws[q].degree + 1)]
            + (["r"] if laws[q].uses_rate else [])]


def _joint_covariance(A: NDArray[np.float64], stds: Mapping[str, NDArray[np.float64]],
                      step_cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """Covariance of all laws' weighted least-squares coefficients.

    Law ``q`` is ``a_q = L_q y_q`` with ``L_q = (A^T W_q A)^-1 A^T W_q``, ``W_q = diag(1 /
    s_q^2)`` over the steps; the steps are independent, so ``cov(a_q, a_q') = L_q diag_k(
    C_k[q, q']) L_q'^T`` with ``C_k`` the covariance of the twelve coefficients of step ``k``
    (shape ``(n_steps, 12, 12)``, :func:`~inertest.models.triad.parameter_names` order).
    """
    L = np.stack([np.linalg.pinv(A / stds[q][:, None]) / stds[q][None, :]
                  for q in triad.parameter_names()])             # (12, p, n_steps)
    C = np.einsum("apk,kab,bqk->apbq", L, step_cov, L)
    n = L.shape[0] * L.shape[1]
    out = C.reshape(n, n)
    return 0.5 * (out + out.T)


def _design(dt: NDArray[np.float64], degree: int, rate: ArrayLike | None, uses_rate: bool
            ) -> NDArray[np.float64]:
    cols = [dt**k for k in range(degree + 1)]
    if uses_rate:
        if rate is None:
            raise InputError("this law has a rate term: give the temperature rate [degC/min]")
        cols.append(np.broadcast_to(np.asarray(rate, dtype=float), dt.shape))
    return np.column_stack(cols)


def _steps(data: Mapping[str, object], temp: NDArray[np.float64], branch: NDArray
           ) -> NDArray[np.int64]:
    """Step index of each row.

    The ``step`` column, or a new step where the branch changes or the temperature jumps by
    more than :data:`STEP_JUMP_C` between consecutive rows.
    """
    if "step" in data:
        _, idx = np.unique(np.asarray(data["step"]), return_inverse=True)
        return np.asarray(idx, dtype=np.int64)
    change = np.r_[True, (branch[1:] != branch[:-1]) | (np.abs(np.diff(temp)) > STEP_JUMP_C)]
    return np.cumsum(change) - 1


def fit_triad_thermal(
    plan: Plan,
    data: Mapping[str, object],
    *,
    degree: int = 2,
    use_rate: bool = False,
    sigma: float | None = None,
    t_ref_c: float | None = None,
    alpha: float = 0.01,
) -> ThermalTriadResult:
    """Multi-position triad calibration at each temperature step, then laws in temperature.

    Parameters
    ----------
    plan : Plan
        A ``triad-multiposition`` plan (site, accelerometer triad, positions).
    data : mapping
        Columns in the module docstring; rows grouped by temperature step.
    degree : int
        Polynomial degree in ``T - T_ref``.
    use_rate : bool
        Add a term linear in the step's temperature rate (needs ``temperature_rate_c_per_min``).
    sigma : float, optional
        Known noise per reading [output unit] for every step; else from each step's residuals.
    t_ref_c : float, optional
        Reference temperature [degC]; default the mean step temperature rounded to 0.1 degC.
    alpha : float
        Family significance level of the hysteresis verdicts.

    Raises
    ------
    DataError
        Missing columns, unknown branch names, non-finite values.
    IdentifiabilityError
        Fewer steps than the polynomial (and rate term) needs, or a constant rate with
        ``use_rate``.
    """
    for c in ("temperature_c", "branch"):
        if c not in data:
            raise DataError(f"thermal triad data lack column {c}; it needs temperature_c, "
                            "branch (heating/cooling), position, output_x, output_y, output_z")
    if degree < 0 or not 0 < alpha < 1:
        raise InputError("degree must be >= 0 and alpha in (0, 1)")
    try:
        temp = np.asarray(data["temperature_c"], dtype=float)
    except (TypeError, ValueError):
        raise DataError("column temperature_c must be numeric [degC]") from None
    if not np.all(np.isfinite(temp)):
        raise DataError("column temperature_c has NaN/inf; repair or remove those rows")
    if temp.size == 0:
        raise DataError("thermal triad data has no rows (only a header); give the chamber steps")
    branch = np.char.lower(np.char.strip(np.asarray(data["branch"]).astype(str)))
    unknown = sorted(set(branch) - set(BRANCHES))
    if unknown:
        raise DataError(f"column branch has {', '.join(map(repr, unknown))}; use heating or "
                        "cooling")
    rate_col = None
    if use_rate:
        if "temperature_rate_c_per_min" not in data:
            raise DataError("use_rate needs the column temperature_rate_c_per_min [degC/min]")
        rate_col = np.asarray(data["temperature_rate_c_per_min"], dtype=float)
    step = _steps(data, temp, branch)
    n_steps = int(step.max()) + 1
    p = degree + 1 + int(use_rate)
    if n_steps < p:
        raise IdentifiabilityError(
            f"{n_steps} temperature step(s) for a law with {p} terms: record at least {p} "
            "steps, or lower the degree")
    cols = {k: np.asarray(v) for k, v in data.items()}
    t_step = np.zeros(n_steps)
    r_step = np.zeros(n_steps)
    b_step = np.empty(n_steps, dtype=object)
    values: dict[str, list[float]] = {}
    stds: dict[str, list[float]] = {}
    units: dict[str, str] = {}
    step_cov = np.zeros((n_steps, 12, 12))
    for k in range(n_steps):
        sel = step == k
        if len(set(branch[sel])) != 1:
            raise DataError(f"temperature step {k + 1} mixes heating and cooling rows; give "
                            "each step one branch")
        t_step[k] = float(np.mean(temp[sel]))
        r_step[k] = 0.0 if rate_col is None else float(np.mean(rate_col[sel]))
        b_step[k] = branch[sel][0]
        try:
            res = _MULTIPOSITION.fit(plan, {c: v[sel] for c, v in cols.items()}, sigma=sigma)
        except (DataError, IdentifiabilityError) as exc:
            raise type(exc)(f"temperature step {k + 1} ({b_step[k]}, {t_step[k]:.1f} degC): "
                            f"{exc}") from None
        for name, est in res.triads[0].all_estimates().items():
            values.setdefault(name, []).append(est.value)
            stds.setdefault(name, []).append(est.std)
            units[name] = est.unit
        step_cov[k] = res.triads[0].covariance[:12, :12]
    if use_rate and np.ptp(r_step) == 0:
        raise IdentifiabilityError("the temperature rate is the same at every step, so its "
                                   "term cannot be found; fit without use_rate")
    t_ref = float(np.round(np.mean(t_step), 1)) if t_ref_c is None else float(t_ref_c)
    vals = {n: np.array(v) for n, v in values.items()}
    sds = {n: np.array(v) for n, v in stds.items()}
    laws = {}
    A = _design(t_step - t_ref, degree, r_step, use_rate)
    for n in vals:
        laws[n] = _law(n, units[n], t_ref, degree, use_rate, A, vals[n], sds[n])
    law_cov = _joint_covariance(A, sds, step_cov)
    hysteresis: dict[str, Hysteresis] = {}
    messages = []
    heat, cool = b_step == "heating", b_step == "cooling"
    if min(heat.sum(), cool.sum()) >= degree + 2:
        lo = max(t_step[heat].min(), t_step[cool].min())
        hi = min(t_step[heat].max(), t_step[cool].max())
        grid = np.linspace(lo, hi, 101)
        G = _design(grid - t_ref, degree, None, False)
        for n in vals:
            fits = []
            for sel in (heat, cool):
                A = _design(t_step[sel] - t_ref, degree, None, False)
                fits.append(weighted_least_squares(A, vals[n][sel], sigma=sds[n][sel]))
            d = fits[0].x - fits[1].x
            C = fits[0].covariance + fits[1].covariance
            stat = float(d @ np.linalg.solve(C, d))
            pval = float(stats.chi2.sf(stat, d.size))
            curve = G @ d
            j = int(np.argmax(np.abs(curve)))
            sd = float(np.sqrt(G[j] @ C @ G[j]))
            hysteresis[n] = Hysteresis(n, units[n], float(curve[j]), sd, float(grid[j]), stat,
                                       d.size, pval, pval < alpha / len(vals))
    else:
        messages.append(f"hysteresis not assessed: each branch needs at least {degree + 2} "
                        "temperature steps (heating and cooling)")
    return ThermalTriadResult(
        step_temperature_c=t_step, step_rate_c_per_min=r_step, step_branch=b_step.astype(str),
        step_values=vals, step_stds=sds, units=units, laws=laws, hysteresis=hysteresis,
        alpha=alpha, serial=plan.instrument.serial or "", messages=tuple(messages),
        raw_unit=plan.instrument.output_unit,
        scale=triad.scale_unit(plan.instrument.output_unit, "accelerometer").with_nominal(
            getattr(plan.procedure, "nominal_scale_factor", None)),
        law_covariance=law_cov)


def _law(name: str, unit: str, t_ref: float, degree: int, use_rate: bool,
         A: NDArray[np.float64], y: NDArray[np.float64], s: NDArray[np.float64]
         ) -> CoefficientLaw:
    lf = weighted_least_squares(A, y, sigma=s)
    chi2 = float(np.sum((lf.residuals / s) ** 2))
    dof = int(y.size - A.shape[1])
    pval = float(stats.chi2.sf(chi2, dof)) if dof > 0 else float("nan")
    return CoefficientLaw(name, unit, t_ref, degree, use_rate, lf.x, lf.covariance, chi2, dof,
                          pval)


def simulate_triad_thermal(
    plan: Plan,
    laws: Mapping[str, Sequence[float]],
    *,
    t_ref_c: float,
    temperatures_c: ArrayLike,
    branches: Sequence[str] = BRANCHES,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> dict[str, NDArray]:
    """Chamber data of a virtual accelerometer triad whose K, M, B follow known laws.

    Parameters
    ----------
    plan : Plan
        A ``triad-multiposition`` plan (positions and samples per position of each step).
    laws : mapping
        ``name: (a_0, a_1, ...)`` of ``a_0 + a_1 (T - t_ref_c) + ...`` in engineering units
        (``K_i`` [scale unit], ``M_ij`` [urad], ``B_i`` [mg]); absent names keep the
        :func:`inertest.procedures.triad_multiposition.simulate` defaults.
    t_ref_c : float
        Reference temperature of the laws [degC].
    temperatures_c : array_like
        Step temperatures of the heating branch [degC]; the cooling branch runs them backwards.
    branches : sequence of {"heating", "cooling"}
    noise : float
        White noise per reading [output unit].
    rng : Generator, int or None

    Returns
    -------
    dict of ndarray
        The columns of :func:`fit_triad_thermal`: ``step``, ``temperature_c``, ``branch``,
        ``position``, ``output_x``, ``output_y``, ``output_z``.
    """
    unknown = sorted(set(branches) - set(BRANCHES))
    if unknown:
        raise InputError(f"branches {', '.join(unknown)}: use heating and/or cooling")
    gen = np.random.default_rng(rng)
    temps = np.atleast_1d(np.asarray(temperatures_c, dtype=float))
    parts: list[dict[str, NDArray]] = []
    for b in branches:
        for T in temps if b == "heating" else temps[::-1]:
            truth = {n: float(np.polyval(np.asarray(c, dtype=float)[::-1], T - t_ref_c))
                     for n, c in laws.items()}
            d = _MULTIPOSITION.simulate(plan, truth, noise=noise, rng=gen)
            n = len(d["position"])
            parts.append({"step": np.full(n, len(parts)), "temperature_c": np.full(n, T),
                          "branch": np.full(n, b), **d})
    if not parts:
        raise InputError("give at least one temperature and one branch")
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
