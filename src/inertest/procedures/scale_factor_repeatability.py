"""Scale-factor repeatability, asymmetry and linearity over several rate-table runs.

IEEE Std 952-1997 (single-axis FOG) specifies, besides the scale factor of one rate-table test,
its *repeatability*: the test repeated under the same conditions with specified changes between
runs (days, power-ons), the scale factor of each run measured, and the repeatability the
standard deviation (1 sigma) of those scale factors relative to their mean, in ppm (IEEE Std 528
terminology: scale-factor repeatability). Per run (the readings of one ``run`` label) the rate
test of IEEE Std 952 (as ``gyro-rate-table``):

    E = K+ w [w > 0] + K- w [w < 0] (+ c2 w^2) + c,   K = (K+ + K-) / 2,
    asymmetry = (K+ - K-) / K,  B = c / K - W_ie . a,  K2 = c2 / K

``w`` the commanded table rate, by least squares under the plan's noise model with the readings
at one rate as one unit (:func:`inertest.estimation.identify.solve`: ``auto`` and its model
checks), so each run's ``K`` carries its own standard uncertainty. Across the runs:

* ``K`` the mean scale factor, ``asymmetry``, ``B`` (and ``K2``) means over the runs, each by the
  one-way random-effects model of :mod:`inertest.estimation.random_effects` (weights ``1 /
  (tau^2 + v_r)``, Hartung-Knapp std, ``R - 1`` degrees of freedom);
* ``K_repeatability`` [ppm]: the sample standard deviation of the runs' scale factors divided by
  their mean (the standard's number), with std ``s sqrt(1 - c4^2) / c4`` and its chi-squared
  95 % interval; the run-to-run part with the in-run uncertainty removed (REML ``tau``, Q-profile
  interval) and the within-run vs between-run F test are stated beside it, for the scale factor
  and for the bias;
* linearity: the deviation of the mean output at each rate from each run's straight line
  ``E = K w_in + c``, averaged over the runs, in ppm of the full-scale output ``|K| max |w|``, with
  its std from the runs' scatter; the nonlinearity is the largest, next to its noise floor.

One run per power-on makes this the turn-on to turn-on repeatability of the scale factor and
the bias on a rate table. Data columns ``run``, ``rate_deg_s`` (commanded table rate, signed),
``output`` [output unit; count/s for pulse outputs].
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.equipment import rate_table as table
from inertest.errors import DataError, IdentifiabilityError, PlanError
from inertest.estimation.identify import solve
from inertest.estimation.model_checks import model_checks
from inertest.estimation.noise_models import NOISE_MODELS
from inertest.estimation.random_effects import random_effects
from inertest.models import rate_gyro
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure, TypeBErrors
from inertest.procedures.spec import known_sigma, noise_samples, require_columns
from inertest.procedures.static_record import chi2_std_interval, read_axis, std_of_std
from inertest.results import Estimate, Identification, LinearTestResult
from inertest.units import DEG_PER_H_TO_RAD_PER_S, DEG_TO_RAD, RATE_UNITS

KIND = "scale-factor-repeatability"
PPM = 1e-6
#: Names a truth file may give: K [K unit], B [deg/h], asymmetry [ppm], K2 [ppm/(deg/s)], and
#: the run-to-run std of K [ppm] and of B [deg/h].
TRUTH_NAMES = ("K", "B", "asymmetry", "K2", "K_repeatability", "B_repeatability")
MIN_RUNS = 3


@dataclass(frozen=True)
class ScaleFactorRepeatabilitySpec:
    """Parameters of a scale-factor repeatability plan (``[procedure]`` table).

    Attributes
    ----------
    rates_deg_s : tuple of float
        Commanded table rates of every run [deg/s], both signs.
    samples_per_rate : int
        Readings at each rate (simulation).
    table_axis : str or tuple of float
        The table axis (= the gyro's input axis) in ENU.
    fit_k2 : bool
        Fit the second-order scale factor in every run.
    noise_model : str
        Noise model of each run's fit (:data:`~inertest.estimation.noise_models.NOISE_MODELS`).
    alpha : float
        Level of the within-run vs between-run F test.
    runs : int
        Runs (simulation).
    """

    kind: ClassVar[str] = KIND
    rates_deg_s: tuple[float, ...] = (-200.0, -50.0, -10.0, -1.0, 1.0, 10.0, 50.0, 200.0)
    samples_per_rate: int = 5
    table_axis: str | tuple[float, ...] = "U"
    fit_k2: bool = False
    noise_model: str = "auto"
    alpha: float = 0.05
    runs: int = 3

    @property
    def axis_enu(self) -> NDArray[np.float64]:
        """Unit vector of the table axis in ENU."""
        return table.direction_vector(self.table_axis)

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> ScaleFactorRepeatabilitySpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "table_axis"))
        return cls(table_axis=read_axis(params, "table_axis"), **v)


FIELDS = (
    Field("rates_deg_s", "numbers", default=ScaleFactorRepeatabilitySpec.rates_deg_s,
          unit="deg/s", doc="commanded table rates of every run, signed"),
    Field("samples_per_rate", "integer", default=5, positive=True,
          doc="readings at each rate (simulation)"),
    Field("fit_k2", "bool", default=False, doc="fit the second-order scale factor K2"),
    Field("noise_model", "text", default="auto", choices=NOISE_MODELS),
    Field("alpha", default=0.05, minimum=1e-6, maximum=0.5,
          doc="level of the within-run vs between-run F test"),
    Field("runs", "integer", default=3, minimum=MIN_RUNS, doc="runs (simulation)"),
)


@dataclass(frozen=True, kw_only=True)
class ScaleFactorResult(LinearTestResult):
    """Outcome of a scale-factor repeatability test (module docstring for the quantities)."""

    runs: tuple[dict[str, object], ...]
    repeatability: dict[str, object]
    between_runs: dict[str, object]
    linearity: dict[str, object]
    scale_unit: str
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope)."""
        return {"runs": list(self.runs), "repeatability": self.repeatability,
                "between_runs": self.between_runs, "linearity": self.linearity}


@dataclass(frozen=True)
class RateRuns:
    """Rate-table readings per run: labels, rates [deg/s], outputs [raw SI], Earth rate."""

    labels: tuple[str, ...]
    rate_deg_s: tuple[NDArray[np.float64], ...]
    y: tuple[NDArray[np.float64], ...]
    earth_rate_rad_s: float


class ScaleFactorRepeatability(Procedure[ScaleFactorRepeatabilitySpec, RateRuns,
                                         ScaleFactorResult]):
    """Scale factor, asymmetry, bias and linearity per rate-table run; repeatability over runs.

    Data columns ``run``, ``rate_deg_s``, ``output`` (IEEE Std 952 scale-factor tests).
    """

    kind = KIND
    title = "Scale-factor repeatability over rate-table runs"
    spec = ScaleFactorRepeatabilitySpec
    model = "inertest.models.rate_gyro"
    method = ("weighted least squares per run under a noise model; one-way random effects "
              "across runs (REML, Hartung-Knapp, F test)")
    machines = (table,)
    noise_models = NOISE_MODELS

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> table.ConstantRates:
        """The plan's rate table: the gyro's input axis along the table axis."""
        spec: ScaleFactorRepeatabilitySpec = plan.procedure
        return table.ConstantRates(plan.site, spec.axis_enu,
                                   tuple(np.asarray(spec.rates_deg_s) * DEG_TO_RAD),
                                   type_b=dict(type_b or {}))

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: table.ConstantRates
               ) -> RateRuns:
        """The runs (rows of a run together), their rates checked, outputs in raw SI."""
        rate_gyro.check_gyro(plan.instrument, KIND)
        if "run" not in data:
            raise DataError(f"{KIND} data need a run column (the run of each reading: a day or "
                            "a power-on), beside rate_deg_s and output")
        cols = require_columns(data, ("rate_deg_s", "output"), ("run",), procedure=KIND)
        per_si = rate_gyro.raw_rate_per_si(plan.instrument.output_unit)
        lab = cols["run"]
        change = np.ones(lab.size, dtype=bool)
        change[1:] = lab[1:] != lab[:-1]
        starts = np.flatnonzero(change)
        names = [str(x) for x in lab[starts]]
        if len(set(names)) != len(names):
            raise DataError(f"{KIND} data: the rows of each run must be together; sort the rows "
                            "by run")
        if len(names) < MIN_RUNS:
            raise IdentifiabilityError(
                f"{KIND} needs at least {MIN_RUNS} runs for a repeatability with an interval, "
                f"got {len(names)}: {', '.join(names)}; repeat the rate test")
        ends = np.append(starts[1:], lab.size)
        rates, ys = [], []
        for s, e, name in zip(starts, ends, names, strict=True):
            r = cols["rate_deg_s"][s:e]
            pos, neg = np.unique(r[r > 0]), np.unique(r[r < 0])
            if pos.size + neg.size < 3 or pos.size == 0 or neg.size == 0:
                raise IdentifiabilityError(
                    f'{KIND}: run "{name}" needs both directions and at least three non-zero '
                    "rates (scale factor, asymmetry and bias); add rates")
            rates.append(r)
            ys.append(cols["output"][s:e] / per_si)
        w_e = float(motion.inputs_at_rate(0.0).omega_i[0, 0])
        return RateRuns(tuple(names), tuple(rates), tuple(ys), w_e)

    def identify(self, plan: Plan, obs: RateRuns, *, sigma: float | None,
                 noise_model: str | None) -> ScaleFactorResult:
        """Each run's K, asymmetry, B (K2); their means, repeatability and linearity."""
        spec: ScaleFactorRepeatabilitySpec = plan.procedure
        inst = plan.instrument
        per_si = rate_gyro.raw_rate_per_si(inst.output_unit)
        k_unit, k_si = rate_gyro.scale_unit(inst.output_unit)
        sig = None if sigma is None else known_sigma(sigma, 1.0 / per_si)
        motion = self.motion(plan)
        per_run = [_fit_run(r, y, motion, obs.earth_rate_rad_s, spec.fit_k2, sig,
                            str(noise_model or "auto")) for r, y in zip(obs.rate_deg_s, obs.y,
                                                                         strict=True)]
        R = len(per_run)
        names = ["K", "B", "asymmetry", *(["K2"] if spec.fit_k2 else [])]
        unit = {"K": k_unit, "B": "deg/h", "asymmetry": "ppm", "K2": "ppm/(deg/s)"}
        scale = {"K": k_si, "B": DEG_PER_H_TO_RAD_PER_S, "asymmetry": PPM,
                 "K2": PPM / DEG_TO_RAD}
        values = {n: np.array([f.values[n] for f in per_run]) for n in names}
        stds = {n: np.array([f.stds[n] for f in per_run]) for n in names}
        dof = [f.dof for f in per_run]
        coefficients: dict[str, Estimate] = {}
        between: dict[str, object] = {}
        for n in names:
            v2 = np.maximum(stds[n] ** 2, 1e-300)
            nu = float(np.sum(v2) ** 2 / np.sum(v2**2 / np.maximum(dof, 1)))
            re = random_effects(values[n], v2, within_dof=nu)
            coefficients[n] = Estimate(n, re.mu / scale[n], re.mu_std / scale[n], unit[n])
            between[n] = {
                "run_to_run": math.sqrt(re.tau2) / scale[n],
                "interval_95": [math.sqrt(x) / scale[n] for x in re.tau2_interval],
                "f_test": {"statistic": re.F, "dof": [re.dof[0], re.dof[1]],
                           "p_value": re.p_value, "level": spec.alpha,
                           "verdict": "run-to-run variation significant"
                           if re.p_value < spec.alpha else "no variation beyond the in-run "
                           "uncertainty"},
                "unit": unit[n]}
        K = values["K"]
        s = float(np.std(K, ddof=1) / np.mean(K))
        s_std = std_of_std(s, R)
        lo, hi = chi2_std_interval(s, R - 1)
        coefficients["K_repeatability"] = Estimate("K_repeatability", s / PPM, s_std / PPM, "ppm")
        order = ["K", "K_repeatability", *names[1:]]
        coefficients = {n: coefficients[n] for n in order}
        std = np.array([e.std for e in coefficients.values()])
        checks = model_checks(K - coefficients["K"].value * k_si, np.ones((R, 1)),
                              stds["K"] ** 2 + float(between["K"]["run_to_run"]  # type: ignore[index]
                                                     * k_si) ** 2,
                              noise_model="run-to-run offsets + each run's fit", sigma_given=False,
                              labels=obs.labels, unit="run")
        lin = _linearity(per_run, float(abs(np.mean(K))))
        resid = np.concatenate([f.residuals for f in per_run])
        ident = Identification(
            coefficients=coefficients, combinations=(), not_separable=(),
            covariance=np.diag(std**2), names=tuple(order),
            noise_sigma=float(np.sqrt(np.mean([f.white**2 for f in per_run])) * per_si),
            noise_unit=rate_gyro.raw_rate_unit(inst.output_unit),
            sigma_from_residuals=sigma is None, dof=R - 1, rank=1,
            residuals=resid * per_si, noise_model=per_run[0].noise_model, checks=checks)
        messages = [f"run {obs.labels[i]}: {m}" for i, f in enumerate(per_run)
                    for m in f.messages]
        p_k = between["K"]["f_test"]["p_value"]  # type: ignore[index]
        if p_k < spec.alpha:
            messages.append(
                f"the scale factor varies from run to run more than each run's uncertainty "
                f"explains (F test p = {p_k:.2g} < {spec.alpha:g})")
        return ScaleFactorResult(
            site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident, residual_output=resid * per_si,
            output_unit=rate_gyro.raw_rate_unit(inst.output_unit), messages=tuple(messages),
            runs=tuple({"label": obs.labels[i], **{
                n: {"value": float(values[n][i] / scale[n]), "std": float(stds[n][i] / scale[n]),
                    "unit": unit[n]} for n in names}, "noise_model": f.noise_model,
                        "readings": int(f.residuals.size)} for i, f in enumerate(per_run)),
            repeatability={
                "definition": "sample standard deviation (1 sigma) of the runs' scale factors "
                              "divided by their mean (IEEE Std 952-1997; IEEE Std 528 "
                              "scale-factor repeatability)",
                "value": s / PPM, "std": s_std / PPM, "interval_95": [lo / PPM, hi / PPM],
                "dof": R - 1, "unit": "ppm"},
            between_runs=between, linearity=lin, scale_unit=k_unit)

    def truth_quantities(self, truth: Mapping[str, float]) -> dict[str, float]:
        """The truth as given (``K_repeatability`` is the run-to-run std of K [ppm])."""
        return {k: float(v) for k, v in truth.items()}

    def synthesize(self, plan: Plan, motion: table.ConstantRates, truth: Mapping[str, float],
                   *, noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Columns ``run``, ``rate_deg_s``, ``output``: ``runs`` repetitions of the rate test.

        Each run draws its own ``K`` (``K_repeatability`` ppm, 1 sigma) and ``B``
        (``B_repeatability`` deg/h); white noise ``noise`` per reading [output unit].
        """
        rate_gyro.check_gyro(plan.instrument, KIND)
        unknown = sorted(set(truth) - set(TRUTH_NAMES))
        if unknown:
            raise PlanError(f"truth for {KIND} has unknown name(s) {', '.join(unknown)}; "
                            f"known: {', '.join(TRUTH_NAMES)}")
        spec: ScaleFactorRepeatabilitySpec = plan.procedure
        inst = plan.instrument
        k_unit, k_si = rate_gyro.scale_unit(inst.output_unit)
        if "K" not in truth and inst.output_unit not in RATE_UNITS:
            raise PlanError(f"truth needs the scale factor K in {k_unit} for a "
                            f"{inst.output_unit} output")
        gen = np.random.default_rng(rng)
        rates = np.repeat(np.asarray(spec.rates_deg_s, dtype=float), spec.samples_per_rate)
        w_t = rates * DEG_TO_RAD
        distinct, inv = np.unique(w_t, return_inverse=True)
        w_in = np.array([motion.inputs_at_rate(float(r)).omega_i[0, 0] for r in distinct])[inv]
        w_e = float(motion.inputs_at_rate(0.0).omega_i[0, 0])
        w_tab = w_in - w_e
        a = float(truth.get("asymmetry", 0.0)) * PPM
        k2 = float(truth.get("K2", 0.0)) * PPM / DEG_TO_RAD
        per_si = rate_gyro.raw_rate_per_si(inst.output_unit)
        out_run, out_rate, out_y = [], [], []
        for r in range(spec.runs):
            K = float(truth.get("K", 1.0)) * k_si * (
                1.0 + gen.normal(0.0, float(truth.get("K_repeatability", 0.0)) * PPM))
            B = (float(truth.get("B", 0.0)) + gen.normal(
                0.0, float(truth.get("B_repeatability", 0.0)))) * DEG_PER_H_TO_RAD_PER_S
            k_dir = K * (1 + np.sign(w_t) * a / 2)
            y = k_dir * w_tab + K * (w_e + B + k2 * w_tab**2)
            out_y.append(y * per_si + noise_samples(rates.size, noise, gen))
            out_rate.append(rates)
            out_run.append(np.full(rates.size, f"run {r + 1}"))
        return {"run": np.concatenate(out_run), "rate_deg_s": np.concatenate(out_rate),
                "output": np.concatenate(out_y)}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = ScaleFactorRepeatability()


@dataclass(frozen=True)
class _RunFit:
    values: dict[str, float]        # SI: K [raw per rad/s], B [rad/s], asymmetry [1], K2
    stds: dict[str, float]
    dof: int
    white: float
    noise_model: str
    residuals: NDArray[np.float64] = field(repr=False)
    rate_deg_s: NDArray[np.float64] = field(repr=False)
    line_residuals: NDArray[np.float64] = field(repr=False)
    line_std: NDArray[np.float64] = field(repr=False)
    messages: tuple[str, ...] = ()


def _fit_run(rate_deg_s: NDArray[np.float64], y: NDArray[np.float64],
             motion: table.ConstantRates, w_e: float, fit_k2: bool, sigma: float | None,
             noise_model: str) -> _RunFit:
    """One run's asymmetric line (IEEE 952) under the noise model; straight-line residuals."""
    import warnings

    from inertest.errors import InertestWarning

    w_t = rate_deg_s * DEG_TO_RAD
    quad = [w_t**2] if fit_k2 else []
    A = np.column_stack([np.where(w_t > 0, w_t, 0.0), np.where(w_t < 0, w_t, 0.0), *quad,
                         np.ones_like(w_t)])
    groups = np.char.mod("rate %.9g deg/s", rate_deg_s)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InertestWarning)
        fit, noise = solve(A, y, sigma_si=sigma, groups=groups, noise_model=noise_model)
    x, cov = fit.x, fit.covariance
    kp, kn = x[0], x[1]
    K = 0.5 * (kp + kn)
    c = x[-1]
    # engineering quantities and their Jacobian in x
    J = np.zeros((3 + len(quad), x.size))
    vals = [K, c / K - w_e, (kp - kn) / K]
    J[0, 0] = J[0, 1] = 0.5
    J[1, 0] = J[1, 1] = -0.5 * c / K**2
    J[1, -1] = 1.0 / K
    J[2, 0] = 1.0 / K - 0.5 * (kp - kn) / K**2
    J[2, 1] = -1.0 / K - 0.5 * (kp - kn) / K**2
    names = ["K", "B", "asymmetry"]
    if fit_k2:
        vals.append(x[2] / K)
        J[3, 0] = J[3, 1] = -0.5 * x[2] / K**2
        J[3, 2] = 1.0 / K
        names.append("K2")
    C = J @ cov @ J.T
    stds = np.sqrt(np.maximum(np.diag(C), 0.0))
    # straight line E = K w_in + c (IEEE 952): deviations of each rate's mean from it
    distinct, inv = np.unique(rate_deg_s, return_inverse=True)
    w_in = np.array([motion.inputs_at_rate(float(r) * DEG_TO_RAD).omega_i[0, 0]
                     for r in distinct])[inv]
    line_A = np.column_stack([w_in, np.ones_like(w_in)])
    coef = np.linalg.lstsq(line_A, y, rcond=None)[0]
    dev = y - line_A @ coef
    counts = np.bincount(inv)
    mean_dev = np.bincount(inv, dev) / counts
    var_unit = noise.unit_covariance
    var_unit = var_unit if var_unit.ndim == 1 else np.diag(var_unit)
    first = np.array([int(np.flatnonzero(inv == k)[0]) for k in range(distinct.size)])
    line_std = np.sqrt(var_unit[noise.unit_index[first]])
    return _RunFit(values=dict(zip(names, (float(v) for v in vals), strict=True)),
                   stds=dict(zip(names, (float(s) for s in stds), strict=True)),
                   dof=int(fit.dof), white=float(noise.white_sigma), noise_model=noise.model,
                   residuals=fit.residuals, rate_deg_s=distinct, line_residuals=mean_dev,
                   line_std=line_std, messages=tuple(str(w.message) for w in caught))


def _linearity(runs: list[_RunFit], K: float) -> dict[str, object]:
    """Per-rate deviation from each run's straight line, averaged over runs [ppm of FS]."""
    rates = runs[0].rate_deg_s
    same = all(r.rate_deg_s.shape == rates.shape and np.all(r.rate_deg_s == rates)
               for r in runs)
    if not same:
        return {"note": "the runs did not use the same rates: no pooled linearity"}
    fs = K * float(np.max(np.abs(rates))) * DEG_TO_RAD
    dev = np.array([r.line_residuals for r in runs]) / fs / PPM
    noise = np.array([r.line_std for r in runs]) / fs / PPM
    R = dev.shape[0]
    mean = dev.mean(axis=0)
    std = np.sqrt(np.mean(noise**2, axis=0) / R)
    worst = int(np.argmax(np.abs(mean)))
    return {"definition": "mean output at each rate minus each run's least-squares straight "
                          "line, averaged over the runs, in ppm of the full-scale output "
                          "(IEEE Std 952-1997 scale-factor nonlinearity)",
            "rate_deg_s": rates.tolist(), "deviation": mean.tolist(), "std": std.tolist(),
            "nonlinearity": float(abs(mean[worst])), "noise_floor": float(std[worst]),
            "unit": "ppm of full scale"}
