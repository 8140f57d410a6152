"""Turn-on to turn-on bias repeatability: several power-on runs of a static test.

IEEE Std 952-1997 (single-axis FOG) and IEEE Std 1293-2018 (linear accelerometer) specify the
bias *repeatability*: the instrument is switched off and on between runs under the same
conditions, the bias of each run is measured, and the repeatability is the standard deviation
(1 sigma) of those biases (IEEE Std 528-2001 terminology: bias repeatability, the coincidence
of bias measurements of the same instrument under the same conditions with specified changes
between them, here power off and on). The test here:

* **bias per run** ``b_r``: the mean output of run ``r`` after ``settle_s`` (the warm-up), with
  the input at rest removed (Earth rate along the gyro's input axis, gravity along the
  accelerometer's), and its standard uncertainty from the run's own noise: the variance of a
  mean over the run under the white + flicker (+ random walk) noise fitted to the runs' pooled
  Allan variance (:mod:`inertest.noise.record_noise`), not the white ``sigma^2 / n``, which
  under flicker is too small by a factor of tens;
* **repeatability** (the standards' number, judged against a limit): the sample standard
  deviation ``s`` of the run biases, with its standard uncertainty ``s sqrt(1 - c4^2) / c4``
  and its chi-squared 95 % interval (``R - 1`` degrees of freedom, ``R`` runs);
* **mean bias** ``B``: the weighted mean of the run biases (weights ``1 / (tau^2 + v_r)``),
  its std by Hartung-Knapp (``t`` with ``R - 1`` degrees of freedom: for equal runs it is
  ``s / sqrt(R)``);
* **turn-on and in-run stated separately**: the scatter of run biases has two parts, the
  in-run part ``v_r`` (what the noise within a run alone makes the run means scatter by) and
  the turn-on part ``tau^2`` (a new bias at each power-on); ``tau`` by restricted maximum
  likelihood of the one-way random-effects model ``b_r = mu + u_r + e_r``, ``u_r ~ N(0,
  tau^2)``, ``e_r ~ N(0, v_r)``, with its 95 % interval by the Q-profile method (Viechtbauer,
  Stat. Med. 26, 2007, doi:10.1002/sim.2514), ``v_r`` taken as known;
* **within-run vs between-run F test** (the CIGTF "operating vs shutdown" comparison: is the
  bias less stable across power-ons than within a run?): ``F = Q / (R - 1)`` with
  ``Q = sum (b_r - b_w)^2 / v_r`` (``b_w`` the ``1/v_r``-weighted mean) against
  ``F(R - 1, nu)``, ``nu`` the effective degrees of freedom of the in-run variance (from the
  Allan fit's covariance, Satterthwaite), at the plan's level ``alpha``.

What counts as in-run: flicker slower than ``1 / (2 s T)`` (``T`` a run's duration, ``s`` the
plan's ``bias_time_scale``, default 2) is a constant over a run and so counts as turn-on
variation; a rate random walk is taken from each power-on. The random walk enters the in-run
variance only when the pooled Allan variance determines it (:data:`inertest.noise.record_noise.
RANDOM_WALK_CHI2`, :data:`~inertest.noise.record_noise.RANDOM_WALK_Z`): one it cannot show but
that dominates a run's mean makes the F test liberal and counts as turn-on variation (the limits
are stated in :mod:`inertest.noise.record_noise`). With white + flicker + a random walk of 3 %
of a run mean's variance the test rejected at 5.3 % at its 5 % level (300 simulated tests,
binomial std 1.3 %; tests/procedures/test_turn_on_repeatability.py).

Data columns: ``run`` (the power-on run of each reading, rows of a run together, runs in time
order), ``output`` [output unit: a rate unit for a gyro, a specific-force unit for an
accelerometer], optional ``time_s`` (checked against ``sample_rate_hz``). A campaign may give
one file per run (:mod:`inertest.app.acceptance` joins them with their labels).

The same test on a rate table (scale factor per power-on) is ``scale-factor-repeatability``
with one run per power-on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from inertest.errors import IdentifiabilityError, PlanError
from inertest.estimation.model_checks import model_checks
from inertest.estimation.random_effects import random_effects
from inertest.noise.record_noise import RecordNoise
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure
from inertest.procedures.spec import noise_samples
from inertest.procedures.static_record import (
    STATIC_FIELDS,
    Runs,
    Sensor,
    chi2_std_interval,
    in_run_noise,
    input_at_rest,
    noise_of,
    noise_term_block,
    read_axis,
    read_static,
    sensor_of,
    std_of_std,
    with_allan_check,
)
from inertest.results import Estimate, Identification, LinearTestResult

KIND = "turn-on-repeatability"
#: Names a truth file may give: bias, turn-on std [bias unit]; ARW [deg/sqrt(h) or
#: m/s/sqrt(h)], bias instability [bias unit], rate random walk [bias unit / sqrt(h)].
TRUTH_NAMES = ("B", "turn_on_sigma", "ARW", "bias_instability", "RRW")
#: Fewest runs: a standard deviation needs two, its interval and the F test three.
MIN_RUNS = 3


@dataclass(frozen=True)
class TurnOnRepeatabilitySpec:
    """Parameters of a turn-on repeatability plan (``[procedure]`` table).

    Attributes
    ----------
    sample_rate_hz : float
        Readings per second.
    settle_s : float
        Seconds left out at the start of every run (the warm-up) [s].
    input_axis : str or tuple of float
        The instrument's input axis in ENU (letter or vector), for the input at rest.
    alpha : float
        Level of the within-run vs between-run F test.
    bias_time_scale : float
        Flicker from ``1 / (2 s T)`` (see the module docstring).
    runs : int
        Power-on runs (simulation).
    run_duration_s : float
        Duration of each run (simulation) [s].
    """

    kind: ClassVar[str] = KIND
    sample_rate_hz: float = 1.0
    settle_s: float = 0.0
    input_axis: str | tuple[float, ...] = "U"
    alpha: float = 0.05
    bias_time_scale: float = 2.0
    runs: int = 6
    run_duration_s: float = 1800.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> TurnOnRepeatabilitySpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "input_axis"))
        return cls(input_axis=read_axis(params), **v)


FIELDS = (
    *STATIC_FIELDS,
    Field("settle_s", default=0.0, minimum=0.0, unit="s",
          doc="seconds left out at the start of each run (warm-up)"),
    Field("alpha", default=0.05, minimum=1e-6, maximum=0.5,
          doc="level of the within-run vs between-run F test"),
    Field("runs", "integer", default=6, minimum=MIN_RUNS, doc="power-on runs (simulation)"),
    Field("run_duration_s", default=1800.0, positive=True, unit="s",
          doc="duration of each run (simulation)"),
)


@dataclass(frozen=True, kw_only=True)
class TurnOnResult(LinearTestResult):
    """Outcome of a turn-on repeatability test.

    Attributes
    ----------
    identification : Identification
        ``B`` (mean bias) and ``turn_on_repeatability`` (1 sigma of the run biases) [bias
        unit], and ``ARW`` [random-walk unit] when the pooled Allan fit resolves it.
    runs : tuple of dict
        Per run: label, bias and its in-run std [bias unit], readings, duration [s].
    repeatability, turn_on, in_run, f_test : dict
        The JSON blocks of the module docstring.
    noise : RecordNoise
        The pooled in-run noise.
    """

    runs: tuple[dict[str, object], ...]
    repeatability: dict[str, object]
    turn_on: dict[str, object]
    in_run: dict[str, object]
    f_test: dict[str, object]
    in_run_noise: dict[str, object]
    at_rest: dict[str, object]
    noise: RecordNoise = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope)."""
        return {"runs": list(self.runs), "repeatability": self.repeatability,
                "turn_on": self.turn_on, "in_run": self.in_run, "f_test": self.f_test,
                "in_run_noise": self.in_run_noise, "input_at_rest": self.at_rest}

    def to_dict(self) -> dict[str, object]:
        """The envelope, with the Allan fit's check beside the run-level model check."""
        return with_allan_check(super().to_dict(), self.noise)


@dataclass(frozen=True)
class TurnOnObservations:
    """The runs in SI with what the fit needs: sensor, rate, input at rest."""

    runs: Runs
    sensor: Sensor
    rate_hz: float
    at_rest: float


class TurnOnRepeatability(Procedure[TurnOnRepeatabilitySpec, TurnOnObservations, TurnOnResult]):
    """Bias repeatability over power-on runs (IEEE Std 952 / 1293), turn-on vs in-run.

    Data columns ``run``, ``output`` [output unit], optional ``time_s``.

    Raises
    ------
    DataError
        Fewer than :data:`MIN_RUNS` runs, a run too short for its Allan variance.
    """

    kind = KIND
    title = "Turn-on to turn-on bias repeatability"
    spec = TurnOnRepeatabilitySpec
    model = "inertest.noise.record_noise"
    method = ("run means; pooled Allan fit for their in-run variance; one-way random effects "
              "(REML, Q-profile) and an F test")

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Any) -> TurnOnObservations:
        """The runs in SI, the input at rest removed and the settling readings left out."""
        runs, sensor, at_rest = read_static(plan, data, KIND, need_run=True)
        if len(runs.labels) < MIN_RUNS:
            raise IdentifiabilityError(
                f"{KIND} needs at least {MIN_RUNS} power-on runs (a standard deviation, its "
                f"interval and the F test), got {len(runs.labels)}: "
                f"{', '.join(runs.labels)}; record more turn-ons")
        return TurnOnObservations(runs, sensor, float(plan.procedure.sample_rate_hz), at_rest)

    def identify(self, plan: Plan, obs: TurnOnObservations, *, sigma: float | None,
                 noise_model: str | None) -> TurnOnResult:
        """Run biases, repeatability, turn-on and in-run parts, F test."""
        spec: TurnOnRepeatabilitySpec = plan.procedure
        sensor, runs = obs.sensor, obs.runs
        R = len(runs.labels)
        b = np.array([v.mean() for v in runs.values])
        noise = noise_of([v - v.mean() for v in runs.values], plan, sensor, sigma)
        g = np.array([noise.mean_kernel(int(n)) for n in runs.lengths])   # (R, 4)
        v = np.maximum(g @ noise.p, 1e-300)
        nu = noise.variance_dof(g.mean(axis=0))

        re = random_effects(b, v, within_dof=nu)
        tau2, mu, std_mu = re.tau2, re.mu, re.mu_std
        lo2, hi2 = re.tau2_interval
        F, p = re.F, re.p_value

        s = float(np.std(b, ddof=1))
        s_std = std_of_std(s, R)
        s_lo, s_hi = chi2_std_interval(s, R - 1)
        significant = p < spec.alpha

        u = sensor.si_per_bias_unit
        unit = sensor.bias_unit
        in_run = math.sqrt(float(v.mean()))
        in_run_std = noise.variance_std(g.mean(axis=0)) / (2.0 * in_run)
        coefficients = {
            "B": Estimate("B", mu / u, std_mu / u, unit),
            "turn_on_repeatability": Estimate("turn_on_repeatability", s / u, s_std / u, unit),
        }
        arw = noise.terms.get("N", {})
        if arw.get("resolved"):
            coefficients["ARW"] = Estimate("ARW", float(arw["value"]),  # type: ignore[arg-type]
                                           float(arw["std"]), str(arw["unit"]))  # type: ignore[arg-type]
        names = tuple(coefficients)
        std = np.array([e.std for e in coefficients.values()])
        checks = model_checks(b - mu, np.ones((R, 1)), tau2 + v, noise_model="turn-on offsets",
                              sigma_given=False, labels=runs.labels, unit="run")
        white = math.sqrt(noise.p[1] * noise.rate_hz) / sensor.si_per_output
        ident = Identification(
            coefficients=coefficients, combinations=(), not_separable=(),
            covariance=np.diag(std**2), names=names, noise_sigma=white,
            noise_unit=sensor.output_unit, sigma_from_residuals=sigma is None,
            dof=R - 1, rank=1, residuals=(b - mu) / sensor.si_per_output,
            noise_model="turn-on offsets + in-run white, flicker"
                        + (", random walk" if noise.p[3] > 0 else "") + " (pooled Allan fit)",
            noise_components={"white": white, "turn-on offset": math.sqrt(tau2)
                              / sensor.si_per_output, "in-run (run mean)": in_run
                              / sensor.si_per_output},
            checks=checks)
        run_rows = tuple(
            {"label": runs.labels[k], "bias": {"value": float(b[k] / u),
                                               "std": float(math.sqrt(v[k]) / u), "unit": unit},
             "readings": int(runs.lengths[k]),
             "duration_s": float(runs.lengths[k] / obs.rate_hz),
             "first_data_row": runs.start[k]} for k in range(R))
        messages = []
        if significant:
            messages.append(
                f"the run biases scatter more than the in-run noise explains (F = {F:.3g}, "
                f"p = {p:.2g} < {spec.alpha:g}): the bias changes at turn-on by about "
                f"{math.sqrt(tau2) / u:.3g} {unit} (1 sigma) beyond its in-run instability")
        return TurnOnResult(
            site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident, residual_output=(b - mu) / sensor.si_per_output,
            output_unit=sensor.output_unit, messages=tuple(messages), runs=run_rows,
            repeatability={
                "definition": "sample standard deviation (1 sigma) of the run biases, one per "
                              "power-on (IEEE Std 952-1997, IEEE Std 1293-2018; IEEE Std 528 "
                              "bias repeatability)",
                "value": s / u, "std": s_std / u, "interval_95": [s_lo / u, s_hi / u],
                "dof": R - 1, "unit": unit},
            turn_on={
                "meaning": "the part of the run-to-run scatter added at each power-on (the "
                           "in-run part removed): one-way random effects, REML",
                "value": math.sqrt(tau2) / u,
                "interval_95": [math.sqrt(lo2) / u, math.sqrt(hi2) / u],
                "interval_method": "Q-profile (Viechtbauer 2007), in-run variances as known",
                "unit": unit},
            in_run={
                "meaning": "std of a run's bias from the noise within the run alone (white, "
                           "flicker from 1/(2 s T), random walk from power-on), root mean "
                           "square over the runs",
                "value": in_run / u, "std": in_run_std / u, "unit": unit,
                "dof": None if not math.isfinite(nu) else nu},
            f_test={
                "name": "within-run vs between-run (operating vs shutdown) F test",
                "statistic": F, "dof": [R - 1, None if not math.isfinite(nu) else nu],
                "p_value": p, "level": spec.alpha,
                "verdict": ("turn-on variation significant" if significant
                            else "no turn-on variation beyond the in-run instability")},
            in_run_noise={"terms": noise_term_block(noise.terms), "allan_fit": noise.verdict,
                          "random_walk_in_variance": bool(noise.p[3] > 0),
                          "bias_time_scale": noise.bias_time_scale,
                          "records_pooled": noise.records},
            at_rest={"value": obs.at_rest / u, "unit": unit,
                     "what": "Earth rate along the input axis" if sensor.kind == "gyro"
                     else "gravity along the input axis"},
            noise=noise)

    def truth_quantities(self, truth: Mapping[str, float]) -> dict[str, float]:
        """Truth with ``turn_on_repeatability = turn_on_sigma`` (the in-run part left out).

        The expected scatter of run biases is ``sqrt(turn_on_sigma^2 + v)`` with ``v`` the
        in-run variance of a run mean, which depends on the plan's run length; for the
        example's runs it is below 1 % of ``turn_on_sigma``.
        """
        out = {k: float(x) for k, x in truth.items()}
        if "turn_on_sigma" in out:
            out["turn_on_repeatability"] = out["turn_on_sigma"]
        return out

    def synthesize(self, plan: Plan, motion: Any, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Columns ``run``, ``time_s``, ``output`` of ``runs`` power-on runs.

        Each run: the bias ``B`` plus a turn-on offset ``N(0, turn_on_sigma^2)``, the input at
        rest, white noise ``noise`` per reading [output unit], and the IEEE 952 noise of the
        truth (``ARW``, ``bias_instability``, ``RRW``; :func:`inertest.noise.identification.
        simulate_noise`).
        """
        spec: TurnOnRepeatabilitySpec = plan.procedure
        sensor = sensor_of(plan.instrument, KIND)
        unknown = sorted(set(truth) - set(TRUTH_NAMES) - {"turn_on_repeatability"})
        if unknown:
            raise PlanError(f"truth for {KIND} has unknown name(s) {', '.join(unknown)}; "
                            f"known: {', '.join(TRUTH_NAMES)}")
        gen = np.random.default_rng(rng)
        n = max(int(round(spec.run_duration_s * spec.sample_rate_hz)), 16)
        at_rest = input_at_rest(plan, sensor, spec.input_axis)
        u = sensor.si_per_bias_unit
        offsets = gen.normal(0.0, float(truth.get("turn_on_sigma", 0.0)) * u, spec.runs)
        out_run, out_t, out_y = [], [], []
        for k in range(spec.runs):
            y = at_rest + float(truth.get("B", 0.0)) * u + offsets[k] + in_run_noise(
                truth, sensor, n, spec.sample_rate_hz, gen)
            out_y.append(y / sensor.si_per_output + noise_samples(n, noise, gen))
            out_run.append(np.full(n, f"run {k + 1}"))
            out_t.append(np.arange(n) / spec.sample_rate_hz)
        return {"run": np.concatenate(out_run), "time_s": np.concatenate(out_t),
                "output": np.concatenate(out_y)}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = TurnOnRepeatability()

