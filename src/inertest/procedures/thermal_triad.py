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
from inertest.models.thermal import observed_range
from inertest.models.thermal_triad import (
    CoefficientLaw,
    TriadThermalModel,
    coefficient_names,
    law_design,
)
from inertest.plan import Plan
from inertest.procedures.triad_multiposition import PROCEDURE as MULTIPOSITION
from inertest.results import envelope

KIND = "thermal-triad"
BRANCHES = ("heating", "cooling")
#: Temperature jump between consecutive rows that starts a new step [degC].
STEP_JUMP_C = 1.0


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
            temperature_range_c=observed_range(t),
            rate_range_c_per_min=observed_range(r) if uses_rate else None,
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
                "names": coefficient_names(self.laws),
                "matrix": self.law_covariance.tolist()}}),
        }, checks=checks, messages=self.messages)


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
    temp, branch, rate_col = _read_columns(data, degree=degree, alpha=alpha,
                                           use_rate=use_rate)
    step = _steps(data, temp, branch)
    n_steps = int(step.max()) + 1
    p = degree + 1 + int(use_rate)
    if n_steps < p:
        raise IdentifiabilityError(
            f"{n_steps} temperature step(s) for a law with {p} terms: record at least {p} "
            "steps, or lower the degree")
    steps = _step_calibrations(plan, data, temp, branch, rate_col, step, n_steps, sigma)
    t_step, r_step, b_step, vals, sds, units, step_cov = steps
    distinct = np.unique(np.round(t_step, 1)).size
    if distinct < degree + 1:
        raise IdentifiabilityError(
            f"{distinct} distinct step temperatures (to 0.1 degC) cannot determine a law of "
            f"degree {degree} ({degree + 1} terms in T): lower --degree to at most "
            f"{distinct - 1}, or add temperatures")
    if use_rate and np.ptp(r_step) == 0:
        raise IdentifiabilityError("the temperature rate is the same at every step, so its "
                                   "term cannot be found; fit without use_rate")
    t_ref = float(np.round(np.mean(t_step), 1)) if t_ref_c is None else float(t_ref_c)
    A = law_design(t_step - t_ref, degree, r_step, use_rate)
    span = max(float(np.max(np.abs(t_step - t_ref))), 1e-9)  # the rank of the scaled design
    if np.linalg.matrix_rank(law_design((t_step - t_ref) / span, degree, r_step / max(
            float(np.max(np.abs(r_step))), 1e-9), use_rate)) < A.shape[1]:
        raise IdentifiabilityError(
            f"the steps' temperatures{' and rates' if use_rate else ''} do not determine the "
            f"{A.shape[1]} terms of the law; lower --degree or add steps")
    laws = {n: _law(n, units[n], t_ref, degree, use_rate, A, vals[n], sds[n]) for n in vals}
    law_cov = _joint_covariance(A, sds, step_cov)
    messages = []
    heat, cool = b_step == "heating", b_step == "cooling"
    hysteresis: dict[str, Hysteresis] = {}
    if min(heat.sum(), cool.sum()) >= degree + 2:
        hysteresis = _hysteresis(t_step, heat, cool, vals, sds, units, t_ref, degree, alpha)
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


def _read_columns(data: Mapping[str, object], *, degree: int, alpha: float, use_rate: bool
                  ) -> tuple[NDArray[np.float64], NDArray, NDArray[np.float64] | None]:
    """Temperature [degC], branch and (with ``use_rate``) rate [degC/min] of every row."""
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
    return temp, branch, rate_col


def _step_calibrations(
    plan: Plan, data: Mapping[str, object], temp: NDArray[np.float64], branch: NDArray,
    rate_col: NDArray[np.float64] | None, step: NDArray[np.intp], n_steps: int,
    sigma: float | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray, dict[str, NDArray[np.float64]],
           dict[str, NDArray[np.float64]], dict[str, str], NDArray[np.float64]]:
    """The multi-position calibration of every step: temperature, rate, branch, K, M, B."""
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
            res = MULTIPOSITION.fit(plan, {c: v[sel] for c, v in cols.items()}, sigma=sigma)
        except (DataError, IdentifiabilityError) as exc:
            raise type(exc)(f"temperature step {k + 1} ({b_step[k]}, {t_step[k]:.1f} degC): "
                            f"{exc}") from None
        for name, est in res.triads[0].all_estimates().items():
            values.setdefault(name, []).append(est.value)
            stds.setdefault(name, []).append(est.std)
            units[name] = est.unit
        step_cov[k] = res.triads[0].covariance[:12, :12]
    return (t_step, r_step, b_step, {n: np.array(v) for n, v in values.items()},
            {n: np.array(v) for n, v in stds.items()}, units, step_cov)


def _hysteresis(
    t_step: NDArray[np.float64], heat: NDArray[np.bool_], cool: NDArray[np.bool_],
    vals: Mapping[str, NDArray[np.float64]], sds: Mapping[str, NDArray[np.float64]],
    units: Mapping[str, str], t_ref: float, degree: int, alpha: float,
) -> dict[str, Hysteresis]:
    """Heating against cooling, per coefficient: the largest difference of the two laws."""
    lo = max(t_step[heat].min(), t_step[cool].min())
    hi = min(t_step[heat].max(), t_step[cool].max())
    grid = np.linspace(lo, hi, 101)
    G = law_design(grid - t_ref, degree, None, False)
    out = {}
    for n in vals:
        fits = []
        for sel in (heat, cool):
            A = law_design(t_step[sel] - t_ref, degree, None, False)
            fits.append(weighted_least_squares(A, vals[n][sel], sigma=sds[n][sel]))
        d = fits[0].x - fits[1].x
        C = fits[0].covariance + fits[1].covariance
        stat = float(d @ np.linalg.solve(C, d))
        pval = float(stats.chi2.sf(stat, d.size))
        curve = G @ d
        j = int(np.argmax(np.abs(curve)))
        sd = float(np.sqrt(G[j] @ C @ G[j]))
        out[n] = Hysteresis(n, units[n], float(curve[j]), sd, float(grid[j]), stat, d.size,
                            pval, pval < alpha / len(vals))
    return out


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
            d = MULTIPOSITION.simulate(plan, truth, noise=noise, rng=gen)
            n = len(d["position"])
            parts.append({"step": np.full(n, len(parts)), "temperature_c": np.full(n, T),
                          "branch": np.full(n, b), **d})
    if not parts:
        raise InputError("give at least one temperature and one branch")
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
