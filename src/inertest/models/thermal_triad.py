"""The thermal model of a triad: its K, M, B laws in temperature, ready to correct a recording.

Written by ``inertest thermal triad --model-out`` (:mod:`inertest.procedures.thermal_triad`
fits it) and applied by ``inertest apply MODEL DATA --temperature-column T``: each coefficient
of the triad model (:mod:`inertest.models.triad`) is a polynomial in ``T - T_ref`` (and the
temperature rate), with its covariance, the valid range and the hysteresis between heating and
cooling noted by the fit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.errors import InputError
from inertest.models import triad
from inertest.models.thermal import check_model_header

#: ``kind`` and format version of the model file written by ``thermal triad --model-out``.
MODEL_KIND = "thermal-triad-model"
MODEL_FORMAT_VERSION = 1
#: Rows corrected at a time by :meth:`TriadThermalModel.compensate` (bounds the temporaries).
CHUNK_ROWS = 16384


def law_design(dt: NDArray[np.float64], degree: int, rate: ArrayLike | None, uses_rate: bool
               ) -> NDArray[np.float64]:
    """Design of one coefficient's law: ``1, dT, ..., dT^degree`` [and the rate] per row."""
    cols = [dt**k for k in range(degree + 1)]
    if uses_rate:
        if rate is None:
            raise InputError("this law has a rate term: give the temperature rate [degC/min]")
        cols.append(np.broadcast_to(np.asarray(rate, dtype=float), dt.shape))
    return np.column_stack(cols)


def coefficient_names(laws: Mapping[str, CoefficientLaw]) -> list[str]:
    """``K_x.a0`` .. ``B_z.r``: the order of the joint covariance of the laws."""
    return [f"{q}.{t}" for q in triad.parameter_names()
            for t in [f"a{k}" for k in range(laws[q].degree + 1)]
            + (["r"] if laws[q].uses_rate else [])]


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
        A = law_design(np.atleast_1d(np.asarray(temperature_c, dtype=float)) - self.t_ref_c,
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
            rows = {q: law_design(tc - self.laws[q].t_ref_c, self.laws[q].degree, rc,
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
                "names": coefficient_names(self.laws),
                "unit": "each law's term units (laws[name].terms)",
                "matrix": np.asarray(self.covariance).tolist()}}),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TriadThermalModel:
        """Inverse of :meth:`to_dict`; errors name the key and the fix."""
        check_model_header(d, kind=MODEL_KIND, version=MODEL_FORMAT_VERSION,
                           what="triad thermal model",
                           fix="write one with inertest thermal triad --model-out")
        try:
            su = d["scale_unit"]
            scale = triad.ScaleUnit(str(su["unit"]), float(su["si_per_unit"]),
                                    float(su["raw_si_per_raw"]),
                                    None if su.get("nominal") is None
                                    else float(su["nominal"]))
            vr = d["valid_range"]
            trange = tuple(float(x) for x in vr["temperature_c"])
            rr = vr.get("temperature_rate_c_per_min")
            rrange = None if rr is None else tuple(float(x) for x in rr)
            laws_doc = d["laws"]
            laws = {str(n): CoefficientLaw.from_model_dict(str(n), v)
                    for n, v in laws_doc.items()}
            jc = d.get("joint_covariance")
            cov: NDArray[np.float64] | None = (
                None if jc is None
                else np.asarray(jc["matrix"], dtype=np.float64))
            return cls(laws=laws, raw_unit=str(d["raw_unit"]), scale=scale, covariance=cov,
                       temperature_range_c=(trange[0], trange[1]),
                       rate_range_c_per_min=None if rrange is None else (rrange[0], rrange[1]),
                       serial=str(d.get("serial", "")),
                       sensor=str(d.get("sensor", "accelerometer")))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise InputError(f"malformed triad thermal model ({exc!r}); write it again with "
                             "inertest thermal triad --model-out") from None
