"""In-run bias stability of a gyro or accelerometer at rest, as the standards define it.

One static record after warm-up (IEEE Std 952-1997 for single-axis FOGs, IEEE Std 1293-2018
for linear accelerometers). Two different numbers are both called "bias stability" on
datasheets, and the test reports both, each with its uncertainty:

* **bias stability over an averaging time** (IEEE Std 952-1997 and 1293-2018 specification
  format; IEEE Std 528 terminology: the random variation of the bias computed over specified
  finite sample time and averaging time intervals): the record is cut into non-overlapping
  windows of ``averaging_time_s`` (100 s by default), the bias of each window is its mean, and
  the stability is the sample standard deviation (1 sigma) of the window biases over the
  record: ``bias_stability``. It depends on the averaging time *and* on the record's length
  (flicker and a random walk keep adding variance), so both are stated with it. Its standard
  uncertainty is that of a sample variance of correlated normal values: with ``C`` the
  covariance of the window means under the record's own noise (white + flicker + random walk,
  fitted to its Allan variance, :mod:`inertest.noise.record_noise`) and ``P`` the centring
  matrix, ``E s^2 = tr(P C) / (M - 1)`` and ``Var s^2 = 2 tr(P C P C) / (M - 1)^2`` (Isserlis'
  theorem for quadratic forms of normal variables), so ``u(s) = sqrt(Var s^2) / (2 sqrt(E
  s^2))`` with effective degrees of freedom ``2 (E s^2)^2 / Var s^2`` (the chi-squared interval
  in the JSON uses them). Under white noise alone this is ``s / sqrt(2 (M - 1))``; neighbouring
  windows of flicker are correlated, and the interval is wider.
* **bias instability** (IEEE Std 952-1997 Annex C): the flicker floor of the Allan deviation,
  ``B`` with ``sigma_A = 0.664 B``, from :func:`inertest.noise.identification.identify_noise`
  (with the angle random walk ``ARW`` and rate random walk ``RRW``): reported with its std when
  the five-term fit resolves it, otherwise not determined, with the fit's upper bound.

The mean bias ``B`` (the input at rest removed: the Earth rate along the gyro's input axis,
gravity along the accelerometer's) carries the std of a mean over the record under the same
noise. The model check: the window means whitened by ``C`` (Ljung-Box over the windows, a
shifted window, outliers): a trend left from the warm-up or a step shows there.

Data columns: ``output`` [output unit: a rate unit for a gyro, a specific-force unit for an
accelerometer], optional ``time_s``.
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
from inertest.noise.record_noise import RecordNoise, windows
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure
from inertest.procedures.spec import noise_samples
from inertest.procedures.static_record import (
    STATIC_FIELDS,
    Sensor,
    chi2_std_interval,
    in_run_noise,
    input_at_rest,
    noise_of,
    noise_term_block,
    read_axis,
    read_static,
    sensor_of,
    with_allan_check,
)
from inertest.results import Estimate, Identification, LinearTestResult

KIND = "in-run-stability"
#: The Allan terms reported as quantities: name in results -> IEEE 952 term.
ALLAN_QUANTITIES = {"ARW": "N", "bias_instability": "B", "RRW": "K"}
#: Names a truth file may give (bias unit, random-walk units; see turn-on-repeatability).
TRUTH_NAMES = ("B", "ARW", "bias_instability", "RRW")
#: Fewest windows for a standard deviation with an interval.
MIN_WINDOWS = 3


@dataclass(frozen=True)
class InRunStabilitySpec:
    """Parameters of an in-run stability plan (``[procedure]`` table).

    Attributes
    ----------
    sample_rate_hz : float
        Readings per second.
    averaging_time_s : float
        Window of the bias stability (IEEE 952: e.g. 100 s) [s].
    settle_s : float
        Seconds left out at the start (warm-up) [s].
    input_axis : str or tuple of float
        Input axis in ENU, for the input at rest.
    bias_time_scale : float
        Flicker from ``1 / (2 s T)``.
    duration_s : float
        Record length (simulation) [s].
    """

    kind: ClassVar[str] = KIND
    sample_rate_hz: float = 1.0
    averaging_time_s: float = 100.0
    settle_s: float = 0.0
    input_axis: str | tuple[float, ...] = "U"
    bias_time_scale: float = 2.0
    duration_s: float = 7200.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> InRunStabilitySpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "input_axis"))
        out = cls(input_axis=read_axis(params), **v)
        if out.averaging_time_s * out.sample_rate_hz < 1.0:
            raise PlanError(f"[procedure] averaging_time_s = {out.averaging_time_s:g} s is "
                            f"shorter than one reading at {out.sample_rate_hz:g} Hz")
        return out


FIELDS = (
    *STATIC_FIELDS,
    Field("averaging_time_s", default=100.0, positive=True, unit="s",
          doc="window of the bias stability (e.g. 100 s)"),
    Field("settle_s", default=0.0, minimum=0.0, unit="s", doc="seconds left out (warm-up)"),
    Field("duration_s", default=7200.0, positive=True, unit="s", doc="record (simulation)"),
)


@dataclass(frozen=True, kw_only=True)
class InRunStabilityResult(LinearTestResult):
    """Outcome of an in-run stability test.

    Attributes
    ----------
    identification : Identification
        ``B`` and ``bias_stability`` [bias unit]; ``ARW``, ``bias_instability``, ``RRW`` when
        the Allan fit resolves them.
    stability : dict
        Averaging time, windows, value, std, dof, interval.
    window_time_s, window_bias : ndarray
        Centre of each window [s from the record's start] and its bias [bias unit].
    noise : RecordNoise
    """

    stability: dict[str, object]
    allan: dict[str, object]
    at_rest: dict[str, object]
    bias_unit: str
    window_time_s: NDArray[np.float64] = field(repr=False)
    window_bias: NDArray[np.float64] = field(repr=False)
    noise: RecordNoise = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope)."""
        return {"bias_stability": self.stability, "allan": self.allan,
                "windows": {"time_s": self.window_time_s.tolist(),
                            "bias": self.window_bias.tolist(), "unit": self.bias_unit},
                "input_at_rest": self.at_rest}

    def to_dict(self) -> dict[str, object]:
        """The envelope, with the Allan fit's check beside the window-level model check."""
        return with_allan_check(super().to_dict(), self.noise)


@dataclass(frozen=True)
class StaticObservations:
    """One static record in SI (input at rest removed) with its sensor and rate."""

    y: NDArray[np.float64]
    sensor: Sensor
    rate_hz: float
    at_rest: float


class InRunStability(Procedure[InRunStabilitySpec, StaticObservations, InRunStabilityResult]):
    """Bias stability over an averaging time and the Allan bias instability (IEEE 952/1293).

    Data column ``output`` [output unit], optional ``time_s``.
    """

    kind = KIND
    title = "In-run bias stability"
    spec = InRunStabilitySpec
    model = "inertest.noise.record_noise"
    method = ("window means; their covariance from the record's Allan fit (quadratic forms); "
              "IEEE 952 Annex C terms")

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Any) -> StaticObservations:
        """The record in SI, input at rest removed, settling readings left out."""
        runs, sensor, at_rest = read_static(plan, data, KIND)
        if len(runs.labels) > 1:
            raise PlanError(f"{KIND} analyses one continuous record; the data name "
                            f"{len(runs.labels)} runs ({', '.join(runs.labels[:4])}): give one "
                            "run per plan, or use turn-on-repeatability for several power-ons")
        return StaticObservations(runs.values[0], sensor, float(plan.procedure.sample_rate_hz),
                                  at_rest)

    def identify(self, plan: Plan, obs: StaticObservations, *, sigma: float | None,
                 noise_model: str | None) -> InRunStabilityResult:
        """Window biases and their scatter, the Allan terms, the mean bias."""
        spec: InRunStabilitySpec = plan.procedure
        sensor, y = obs.sensor, obs.y
        n = y.size
        m = max(int(round(spec.averaging_time_s * obs.rate_hz)), 1)
        M = n // m
        if M < MIN_WINDOWS:
            raise IdentifiabilityError(
                f"{KIND}: the record holds {M} window(s) of {spec.averaging_time_s:g} s "
                f"({n / obs.rate_hz:g} s after settling); at least {MIN_WINDOWS} are needed for "
                "a standard deviation: record longer or shorten averaging_time_s")
        noise = noise_of([y - y.mean()], plan, sensor, sigma)
        u_win = windows(n, np.arange(M + 1) * m)
        means = y[: M * m].reshape(M, m).mean(axis=1)
        kernels = noise.unit_kernels(u_win)                    # (4, M, M)
        P = np.eye(M) - 1.0 / M
        PK = np.einsum("ij,tjk->tik", P, kernels)
        g_e = np.einsum("tii->t", PK) / (M - 1)                # E s^2 = g_e . p
        C = np.einsum("t,tij->ij", noise.p, kernels)
        PC = P @ C
        e_s2 = float(g_e @ noise.p)
        var_s2 = 2.0 * float(np.sum(PC * PC.T)) / (M - 1) ** 2
        s = float(np.std(means, ddof=1))
        nu_s = 2.0 * e_s2**2 / var_s2 if var_s2 > 0 else math.inf
        std_s = math.sqrt(var_s2) / (2.0 * math.sqrt(e_s2)) if e_s2 > 0 else 0.0
        dof_i = max(int(math.floor(nu_s)), 1) if math.isfinite(nu_s) else M - 1
        lo, hi = chi2_std_interval(s, dof_i)

        g_mean = noise.mean_kernel(n)
        mean = float(y.mean())
        std_mean = math.sqrt(max(float(g_mean @ noise.p), 0.0))
        u = sensor.si_per_bias_unit
        unit = sensor.bias_unit
        coefficients = {
            "B": Estimate("B", mean / u, std_mean / u, unit),
            "bias_stability": Estimate("bias_stability", s / u, std_s / u, unit),
        }
        not_sep = []
        for name, term in ALLAN_QUANTITIES.items():
            t = noise.terms.get(term, {})
            if t.get("resolved"):
                coefficients[name] = Estimate(name, float(t["value"]),  # type: ignore[arg-type]
                                              float(t["std"]), str(t["unit"]))  # type: ignore[arg-type]
            else:
                bound = t.get("upper_bound")
                not_sep.append(
                    f"{name}: not resolved by the five-term Allan fit ({t.get('note', '')}); "
                    + (f"upper bound {float(bound):.3g} {t.get('unit')} (95 %)"  # type: ignore[arg-type]
                       if bound is not None else "no bound"))
        names = ("B", "bias_stability", *ALLAN_QUANTITIES)
        cov = np.zeros((len(names), len(names)))
        for i, name in enumerate(names):
            if name in coefficients:
                cov[i, i] = coefficients[name].std ** 2
        checks = model_checks(means - means.mean(), np.ones((M, 1)), C,
                              noise_model="white + flicker (+ random walk) from the Allan fit",
                              sigma_given=False, labels=[f"window {k + 1}" for k in range(M)],
                              unit="window")
        white = math.sqrt(noise.p[1] * noise.rate_hz) / sensor.si_per_output
        ident = Identification(
            coefficients=coefficients, combinations=(), not_separable=tuple(not_sep),
            covariance=cov, names=names, noise_sigma=white, noise_unit=sensor.output_unit,
            sigma_from_residuals=sigma is None,
            dof=max(int(math.floor(nu_s)), 1) if math.isfinite(nu_s) else M - 1, rank=1,
            residuals=(means - means.mean()) / sensor.si_per_output,
            noise_model="white + flicker" + (" + random walk" if noise.p[3] > 0 else "")
                        + " (Allan fit)",
            noise_components={"white": white}, checks=checks)
        return InRunStabilityResult(
            site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident, residual_output=(means - means.mean()) / sensor.si_per_output,
            output_unit=sensor.output_unit,
            stability={
                "definition": "sample standard deviation (1 sigma) of the biases of "
                              "non-overlapping windows of the averaging time over the record "
                              "(IEEE Std 952-1997, IEEE Std 1293-2018; IEEE Std 528 bias "
                              "stability)",
                "averaging_time_s": m / obs.rate_hz, "windows": M,
                "record_s": n / obs.rate_hz, "value": s / u, "std": std_s / u,
                "expected_under_noise_model": math.sqrt(max(e_s2, 0.0)) / u,
                "effective_dof": None if not math.isfinite(nu_s) else nu_s,
                "interval_95": [lo / u, hi / u], "unit": unit},
            allan={"terms": noise_term_block(noise.terms), "verdict": noise.verdict,
                   "random_walk_in_covariance": bool(noise.p[3] > 0),
                   "bias_time_scale": noise.bias_time_scale},
            at_rest={"value": obs.at_rest / u, "unit": unit},
            bias_unit=unit,
            window_time_s=np.asarray((np.arange(M) + 0.5) * m / obs.rate_hz, dtype=np.float64),
            window_bias=means / u,
            noise=noise)

    def truth_quantities(self, truth: Mapping[str, float]) -> dict[str, float]:
        """The truth as given (``bias_stability`` depends on the record: not derived)."""
        return {k: float(v) for k, v in truth.items()}

    def synthesize(self, plan: Plan, motion: Any, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Columns ``time_s`` and ``output``: bias, input at rest, the truth's IEEE 952 noise."""
        spec: InRunStabilitySpec = plan.procedure
        sensor = sensor_of(plan.instrument, KIND)
        allowed = set(TRUTH_NAMES) | {"bias_stability"}
        unknown = sorted(set(truth) - allowed)
        if unknown:
            raise PlanError(f"truth for {KIND} has unknown name(s) {', '.join(unknown)}; "
                            f"known: {', '.join(TRUTH_NAMES)}")
        gen = np.random.default_rng(rng)
        n = max(int(round(spec.duration_s * spec.sample_rate_hz)), 16)
        y = (input_at_rest(plan, sensor, spec.input_axis)
             + float(truth.get("B", 0.0)) * sensor.si_per_bias_unit
             + in_run_noise(truth, sensor, n, spec.sample_rate_hz, gen))
        return {"time_s": np.arange(n) / spec.sample_rate_hz,
                "output": y / sensor.si_per_output + noise_samples(n, noise, gen)}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = InRunStability()
