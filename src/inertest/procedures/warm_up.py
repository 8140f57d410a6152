"""Warm-up: the settling of the bias after power-on, and the time it takes.

IEEE Std 952-1997 (single-axis FOG) and IEEE Std 1293-2018 (linear accelerometer) specify a
*warm-up time*: the time from power-on until the instrument meets its specified performance
(IEEE Std 528 terminology). For the bias, from one static record started at power-on:

* the transient ``b(t) = b_inf + a exp(-t / T)`` (one time constant) or ``b_inf + a_1
  exp(-t / T_1) + a_2 exp(-t / T_2)`` (two, where the data ask for it), fitted to the means of
  consecutive bins of the record (each model term averaged exactly over its bin), by
  generalised least squares with the covariance of the bin means under the record's own noise
  (white + flicker + random walk from power-on, fitted to the Allan variance of the record with
  the transient removed, :mod:`inertest.noise.record_noise`), Gauss-Newton from several starts;
  the parameters' covariance is the inverse of the whitened Jacobian's normal matrix;
* the choice between one and two time constants, stated: two when the Bayesian information
  criterion of the whitened residuals (``chi2 + p ln G``, ``G`` bins, ``p`` parameters) is lower
  for two (Schwarz, Ann. Stat. 6, 1978, doi:10.1214/aos/1176344136) and the two time constants
  differ by at least :data:`MIN_TIME_CONSTANT_RATIO`;
* the **warm-up time** ``t_w``: the earliest time after which the fitted transient stays within
  ``tolerance`` of its final value ``b_inf``, ``|b(t) - b_inf| <= tolerance`` for every later
  ``t`` (one time constant: ``t_w = T ln(|a| / tolerance)``, 0 when ``|a| <= tolerance``), with
  its standard uncertainty by the delta method (implicit differentiation of ``|b(t_w) -
  b_inf| = tolerance``); a transient that has not settled by the end of the record is stated
  (the extrapolation is the model's).

Monte Carlo (tests/procedures/test_warm_up.py; a FOG's 3 deg/h settling with T = 300 s in a 1 h
record under white + flicker + rate random walk): reported std / scatter 0.85-1.03 for
``B_final``, the amplitude, ``T`` and the warm-up time (70 and 200 simulated records); with two
time constants 0.82-0.97. The noise is estimated from the residuals of a fit that absorbs some of
its slowest part, so the stds lean low by up to about 10 %.

The model check: the whitened bin residuals (Ljung-Box over the bins, outliers, a shifted bin)
under the fitted noise, and the Allan fit of the residual record. Quantities: ``B_final`` (the
bias after warm-up, ``b_inf``) [bias unit], ``warm_up_amplitude`` and ``time_constant`` [s] (one
time constant) or ``amplitude_1``, ``time_constant_1``, ``amplitude_2``, ``time_constant_2``
(two), and ``warm_up_time`` [s].

Data columns: ``output`` [output unit, rate or specific force], optional ``time_s`` (from power-on;
rows in time order at ``sample_rate_hz``; without it the first reading is at ``0.5 /
sample_rate_hz``, the middle of its interval).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from inertest.errors import DataError, IdentifiabilityError, PlanError
from inertest.estimation.model_checks import model_checks
from inertest.noise.record_noise import RecordNoise, windows
from inertest.plan import Field, Plan, read_fields
from inertest.procedures.base import Procedure
from inertest.procedures.spec import noise_samples
from inertest.procedures.static_record import (
    STATIC_FIELDS,
    Sensor,
    in_run_noise,
    input_at_rest,
    noise_of,
    noise_term_block,
    read_axis,
    read_runs,
    sensor_of,
    with_allan_check,
)
from inertest.results import Estimate, Identification, LinearTestResult

KIND = "warm-up"
#: Most bins the record is cut into (fewer for short records: at least 8 readings each).
MAX_BINS = 240
#: Two time constants are reported only when they differ by at least this factor.
MIN_TIME_CONSTANT_RATIO = 2.0
#: Names a truth file may give.
TRUTH_NAMES = ("B_final", "warm_up_amplitude", "time_constant", "amplitude_2",
               "time_constant_2", "ARW", "bias_instability", "RRW")
ONE = ("B_final", "warm_up_amplitude", "time_constant", "warm_up_time")
TWO = ("B_final", "amplitude_1", "time_constant_1", "amplitude_2", "time_constant_2",
       "warm_up_time")


@dataclass(frozen=True)
class WarmUpSpec:
    """Parameters of a warm-up plan (``[procedure]`` table).

    Attributes
    ----------
    sample_rate_hz : float
        Readings per second.
    tolerance : float
        Band about the final bias that ends the warm-up [bias unit: deg/h or ug].
    time_constants : str
        ``"auto"`` (one or two by the criterion), ``"one"`` or ``"two"``.
    input_axis, bias_time_scale, duration_s
        The input axis in ENU (for the input at rest), the flicker's time scale and the record
        length in simulation [s], as for every static test (:mod:`.static_record`).
    """

    kind: ClassVar[str] = KIND
    sample_rate_hz: float = 1.0
    tolerance: float = 0.1
    time_constants: str = "auto"
    input_axis: str | tuple[float, ...] = "U"
    bias_time_scale: float = 2.0
    duration_s: float = 3600.0

    @classmethod
    def from_mapping(cls, params: Mapping[str, object]) -> WarmUpSpec:
        """Build from the ``[procedure]`` table of a plan file (:data:`FIELDS`)."""
        v = read_fields(params, FIELDS, f"[procedure] of kind {KIND}",
                        ignore=("kind", "input_axis"))
        return cls(input_axis=read_axis(params), **v)


FIELDS = (
    *STATIC_FIELDS,
    Field("tolerance", positive=True, doc="band about the final bias that ends the warm-up, "
          "in the bias unit (deg/h for a gyro, ug for an accelerometer)"),
    Field("time_constants", "text", default="auto", choices=("auto", "one", "two")),
    Field("duration_s", default=3600.0, positive=True, unit="s", doc="record (simulation)"),
)


@dataclass(frozen=True, kw_only=True)
class WarmUpResult(LinearTestResult):
    """Outcome of a warm-up test.

    Attributes
    ----------
    identification : Identification
        ``B_final``, the transient's amplitudes and time constants, ``warm_up_time``.
    model : dict
        Time constants chosen, the criterion and its values, the tolerance, whether the
        transient settled within the record.
    bin_time_s, bin_bias, fitted : ndarray
        Bin centres [s from power-on], bin means and the fitted transient [bias unit].
    noise : RecordNoise
    """

    model_choice: dict[str, object]
    in_run_noise: dict[str, object]
    bias_unit: str
    bin_time_s: NDArray[np.float64] = field(repr=False)
    bin_bias: NDArray[np.float64] = field(repr=False)
    fitted: NDArray[np.float64] = field(repr=False)
    noise: RecordNoise = field(repr=False)
    procedure: str = KIND

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope)."""
        return {"model": self.model_choice, "in_run_noise": self.in_run_noise,
                "bins": {"time_s": self.bin_time_s.tolist(), "bias": self.bin_bias.tolist(),
                         "fitted": self.fitted.tolist(), "unit": self.bias_unit}}

    def to_dict(self) -> dict[str, object]:
        """The envelope, with the Allan fit's check beside the bin-level model check."""
        return with_allan_check(super().to_dict(), self.noise)


@dataclass(frozen=True)
class WarmUpObservations:
    """The record in SI (input at rest removed) and the time of each reading from power-on."""

    y: NDArray[np.float64]
    t_s: NDArray[np.float64]
    sensor: Sensor
    rate_hz: float


class WarmUp(Procedure[WarmUpSpec, WarmUpObservations, WarmUpResult]):
    """Bias settling after power-on and the warm-up time (IEEE Std 952 / 1293).

    Data columns ``output`` [output unit], optional ``time_s`` [s from power-on].
    """

    kind = KIND
    title = "Warm-up (bias settling after power-on)"
    spec = WarmUpSpec
    model = "inertest.noise.record_noise"
    method = ("generalised least squares (Gauss-Newton) of exponential settling on bin means, "
              "noise from the record's Allan variance; BIC for one or two time constants")

    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Any) -> WarmUpObservations:
        """The record in SI and the time from power-on of each reading."""
        spec: WarmUpSpec = plan.procedure
        sensor = sensor_of(plan.instrument, KIND)
        at_rest = input_at_rest(plan, sensor, spec.input_axis)
        runs = read_runs(data, procedure=KIND, sensor=sensor, at_rest=at_rest)
        if len(runs.labels) > 1:
            raise PlanError(f"{KIND} analyses one record from power-on; the data name "
                            f"{len(runs.labels)} runs: give one run per plan")
        y = runs.values[0]
        if "time_s" in data:
            t = np.asarray(data["time_s"], dtype=float)
            if t.shape != y.shape or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
                raise DataError(f"{KIND} data: time_s must be finite and increasing, one per "
                                "reading (seconds from power-on)")
            if t[0] < 0:
                raise DataError(f"{KIND} data: time_s starts at {t[0]:g} s; it counts from "
                                "power-on (>= 0)")
        else:
            t = (np.arange(y.size) + 0.5) / spec.sample_rate_hz
        return WarmUpObservations(y, t, sensor, float(spec.sample_rate_hz))

    def identify(self, plan: Plan, obs: WarmUpObservations, *, sigma: float | None,
                 noise_model: str | None) -> WarmUpResult:
        """The transient by GLS under the record's noise, the model choice, the warm-up time."""
        spec: WarmUpSpec = plan.procedure
        sensor, y, t = obs.sensor, obs.y, obs.t_s
        n = y.size
        G = int(min(MAX_BINS, n // 8))
        if G < 12:
            raise IdentifiabilityError(
                f"{KIND}: {n} readings are too few to follow a transient (at least 96: 12 bins "
                "of 8); record longer")
        edges = np.rint(np.linspace(0, n, G + 1)).astype(np.intp)
        bins = windows(n, edges)
        t_lo = t[edges[:-1]] - 0.5 / obs.rate_hz
        t_hi = t[edges[1:] - 1] + 0.5 / obs.rate_hz
        ybar = np.add.reduceat(y, edges[:-1]) / bins.counts
        u = sensor.si_per_bias_unit
        tol = spec.tolerance * u
        # First pass: white weights; then the noise of the residual record and GLS, the noise
        # estimated again from the chosen model's residuals when that is not the first model.
        fit0 = _best_fit(ybar, t_lo, t_hi, None, 1)
        k, used = 1, 0
        while used != k:
            used = k
            resid = y - _model_rows(fit0.x, t, fit0.x.size // 2)
            noise = noise_of([resid - resid.mean()], plan, sensor, sigma)
            C = noise.unit_covariance(bins)
            L = np.linalg.cholesky(C + np.eye(G) * 1e-12 * float(np.trace(C)) / G)
            fits = {1: _best_fit(ybar, t_lo, t_hi, L, 1, start=fit0.x[:3] if used == 1
                                 else None)}
            if spec.time_constants != "one":
                fits[2] = _best_fit(ybar, t_lo, t_hi, L, 2, start=fits[1].x)
            bic = {j: f.chi2 + (2 * j + 1) * math.log(G) for j, f in fits.items()}
            k = 2 if spec.time_constants == "two" else 1
            if spec.time_constants == "auto" and bic[2] < bic[1]:
                T1, T2 = sorted(np.exp(fits[2].x[2::2]))
                k = 2 if T2 >= MIN_TIME_CONSTANT_RATIO * T1 else 1
            fit0 = fits[k]
        fit = fits[k]
        if not np.all(np.isfinite(fit.cov)):
            raise IdentifiabilityError(
                f"{KIND}: the record does not determine the transient (the settling is flat "
                "or too slow for the record); record from power-on, for several time constants")
        theta, cov = _physical(fit.x, fit.cov, k)         # b_inf, a_i, T_i (SI, s)
        t_end = float(t[-1])
        t_w, t_w_grad, settled = _warm_up_time(theta, k, tol, t_end)
        t_w_std = math.sqrt(max(float(t_w_grad @ cov @ t_w_grad), 0.0))
        names = ONE if k == 1 else TWO
        values = [theta[0] / u]
        stds = [math.sqrt(cov[0, 0]) / u]
        units = [sensor.bias_unit]
        for i in range(k):
            values += [theta[1 + 2 * i] / u, theta[2 + 2 * i]]
            stds += [math.sqrt(cov[1 + 2 * i, 1 + 2 * i]) / u,
                     math.sqrt(cov[2 + 2 * i, 2 + 2 * i])]
            units += [sensor.bias_unit, "s"]
        values.append(t_w)
        stds.append(t_w_std)
        units.append("s")
        coefficients = {nm: Estimate(nm, float(v), float(s), un)
                        for nm, v, s, un in zip(names, values, stds, units, strict=True)}
        all_names = tuple(dict.fromkeys((*ONE, *TWO)))
        full = np.zeros((len(all_names), len(all_names)))
        for nm in names:
            i = all_names.index(nm)
            full[i, i] = coefficients[nm].std ** 2
        fitted = _model_bins(fit.x, t_lo, t_hi, k)
        r = ybar - fitted
        checks = model_checks(r, fit.jac_design, C, noise_model="white + flicker (+ random "
                              "walk) from the Allan fit of the residual record",
                              sigma_given=False, labels=[f"bin {i + 1}" for i in range(G)],
                              unit="bin")
        messages = []
        if not settled:
            messages.append(
                f"the transient is still above the tolerance ({spec.tolerance:g} "
                f"{sensor.bias_unit}) at the end of the record ({t_end:.0f} s): the warm-up "
                "time is the model's extrapolation; record longer")
        other = ("two" if k == 1 else "one")
        not_sep = [f"{nm}: the {other}-time-constant model was not chosen (see result.model)"
                   for nm in all_names if nm not in names]
        white = math.sqrt(noise.p[1] * noise.rate_hz) / sensor.si_per_output
        ident = Identification(
            coefficients=coefficients, combinations=(), not_separable=tuple(not_sep),
            covariance=full, names=all_names, noise_sigma=white, noise_unit=sensor.output_unit,
            sigma_from_residuals=sigma is None, dof=G - (2 * k + 1), rank=2 * k + 1,
            residuals=r / sensor.si_per_output,
            noise_model="white + flicker" + (" + random walk" if noise.p[3] > 0 else "")
                        + " (Allan fit of the residual record)",
            noise_components={"white": white}, checks=checks)
        return WarmUpResult(
            site_latitude_deg=plan.site.latitude_deg, site_gravity_m_s2=plan.site.gravity_m_s2,
            identification=ident, residual_output=r / sensor.si_per_output,
            output_unit=sensor.output_unit, messages=tuple(messages),
            model_choice={
                "time_constants": k, "requested": spec.time_constants,
                "criterion": "Bayesian information criterion of the whitened bin residuals "
                             "(chi2 + p ln G), two time constants only when they differ by "
                             f"at least x{MIN_TIME_CONSTANT_RATIO:g}",
                "bic": {str(j): b for j, b in bic.items()}, "bins": G,
                "tolerance": {"value": spec.tolerance, "unit": sensor.bias_unit},
                "settled_within_record": settled, "record_s": t_end},
            in_run_noise={"terms": noise_term_block(noise.terms), "allan_fit": noise.verdict,
                          "random_walk_in_covariance": bool(noise.p[3] > 0)},
            bias_unit=sensor.bias_unit, bin_time_s=0.5 * (t_lo + t_hi), bin_bias=ybar / u,
            fitted=fitted / u, noise=noise)

    def truth_quantities(self, truth: Mapping[str, float]) -> dict[str, float]:
        """Truth under the result's names for two time constants (``amplitude_1``, ...).

        ``warm_up_time`` depends on the plan's tolerance: :func:`warm_up_time_of`.
        """
        out = {k: float(v) for k, v in truth.items()}
        if "time_constant_2" in out:
            out.setdefault("amplitude_1", out.get("warm_up_amplitude", 0.0))
            out.setdefault("time_constant_1", out.get("time_constant", 0.0))
        return out

    def synthesize(self, plan: Plan, motion: Any, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None
                   ) -> dict[str, NDArray]:
        """Columns ``time_s`` and ``output``: the transient, the input at rest and the noise."""
        spec: WarmUpSpec = plan.procedure
        sensor = sensor_of(plan.instrument, KIND)
        allowed = set(TRUTH_NAMES) | {"warm_up_time", "amplitude_1", "time_constant_1"}
        unknown = sorted(set(truth) - allowed)
        if unknown:
            raise PlanError(f"truth for {KIND} has unknown name(s) {', '.join(unknown)}; "
                            f"known: {', '.join(TRUTH_NAMES)}")
        gen = np.random.default_rng(rng)
        n = max(int(round(spec.duration_s * spec.sample_rate_hz)), 96)
        t = (np.arange(n) + 0.5) / spec.sample_rate_hz
        u = sensor.si_per_bias_unit
        b = float(truth.get("B_final", 0.0)) * u + np.zeros(n)
        for a_key, t_key in (("warm_up_amplitude", "time_constant"),
                             ("amplitude_2", "time_constant_2")):
            a, T = float(truth.get(a_key, 0.0)), float(truth.get(t_key, 0.0))
            if a and T > 0:
                b += a * u * np.exp(-t / T)
        y = input_at_rest(plan, sensor, spec.input_axis) + b + in_run_noise(
            truth, sensor, n, spec.sample_rate_hz, gen)
        return {"time_s": t, "output": y / sensor.si_per_output + noise_samples(n, noise, gen)}


#: The procedure (the registry finds it here by the module's name).
PROCEDURE = WarmUp()


def warm_up_time_of(amplitudes: list[float], time_constants: list[float],
                    tolerance: float) -> float:
    """Warm-up time [s] of ``sum a_i exp(-t / T_i)`` to within ``tolerance`` (same unit as a)."""
    theta = np.array([0.0, *(v for pair in zip(amplitudes, time_constants, strict=True)
                             for v in pair)])
    return _warm_up_time(theta, len(amplitudes), tolerance, math.inf)[0]


@dataclass(frozen=True)
class _Fit:
    x: NDArray[np.float64]        # [b_inf, a_1, log T_1, (a_2, log T_2)]
    cov: NDArray[np.float64]
    chi2: float
    jac_design: NDArray[np.float64]


def _bin_exp(T: float, t_lo: NDArray, t_hi: NDArray) -> tuple[NDArray, NDArray]:
    """Mean of ``exp(-t/T)`` over each bin and its derivative in ``log T``."""
    d = t_hi - t_lo
    e0, e1 = np.exp(-t_lo / T), np.exp(-t_hi / T)
    m = T / d * (e0 - e1)
    dm_dT = (e0 - e1) / d + (t_lo * e0 - t_hi * e1) / (T * d)
    return m, dm_dT * T


def _model_bins(x: NDArray, t_lo: NDArray, t_hi: NDArray, k: int) -> NDArray:
    out = np.full(t_lo.shape, x[0])
    for i in range(k):
        out = out + x[1 + 2 * i] * _bin_exp(float(np.exp(x[2 + 2 * i])), t_lo, t_hi)[0]
    return out


def _model_rows(x: NDArray, t: NDArray, k: int) -> NDArray:
    out = np.full(t.shape, x[0])
    for i in range(k):
        out = out + x[1 + 2 * i] * np.exp(-t / float(np.exp(x[2 + 2 * i])))
    return out


def _jacobian(x: NDArray, t_lo: NDArray, t_hi: NDArray, k: int) -> NDArray:
    J = np.ones((t_lo.size, 1 + 2 * k))
    for i in range(k):
        m, dm = _bin_exp(float(np.exp(x[2 + 2 * i])), t_lo, t_hi)
        J[:, 1 + 2 * i] = m
        J[:, 2 + 2 * i] = x[1 + 2 * i] * dm
    return J


def _best_fit(ybar: NDArray, t_lo: NDArray, t_hi: NDArray, L: NDArray | None, k: int, *,
              start: NDArray | None = None) -> _Fit:
    """Least squares of the ``k``-exponential transient on the bin means (whitened by ``L``)."""
    from scipy.optimize import least_squares

    span = float(t_hi[-1])
    tail = ybar[int(0.75 * ybar.size):].mean()
    a0 = float(ybar[0] - tail)
    starts: list[NDArray] = []
    if start is not None and k == 1:
        starts.append(start)
    elif start is not None:   # split the one time constant into a faster and a slower one,
        b, a, lt = start       # of the same sign or of opposite signs (an overshoot)
        for w1, w2 in ((0.7, 0.3), (0.3, 0.7), (1.3, -0.3), (-0.3, 1.3)):
            starts.append(np.array([b, w1 * a, lt - math.log(3.0), w2 * a, lt + math.log(3.0)]))
    else:
        starts += [np.array([tail, a0, math.log(frac * span)]) for frac in (0.03, 0.2)]

    def white(v: NDArray) -> NDArray:
        return v if L is None else scipy.linalg.solve_triangular(L, v, lower=True)

    def resid(x: NDArray) -> NDArray:
        return white(_model_bins(x, t_lo, t_hi, k) - ybar)

    def jac(x: NDArray) -> NDArray:
        return white(_jacobian(x, t_lo, t_hi, k))

    best = None
    for x0 in starts:
        with np.errstate(over="ignore", invalid="ignore"):
            sol = least_squares(resid, x0, jac=jac, method="lm", x_scale="jac", max_nfev=400)
        if np.all(np.isfinite(sol.x)) and (best is None or sol.cost < best.cost):
            best = sol
    if best is None:
        raise IdentifiabilityError(
            f"{KIND}: the settling of the bias could not be fitted (no start converged); check "
            "that the record starts at power-on")
    assert best is not None
    Jw = jac(best.x)
    with np.errstate(all="ignore"):
        try:
            cov = np.linalg.inv(Jw.T @ Jw)
        except np.linalg.LinAlgError:
            cov = np.full((Jw.shape[1],) * 2, np.nan)
    return _Fit(best.x, cov, float(2.0 * best.cost), _jacobian(best.x, t_lo, t_hi, k))


def _physical(x: NDArray, cov: NDArray, k: int) -> tuple[NDArray, NDArray]:
    """``[b_inf, a_1, T_1, ...]`` (T in s) and its covariance from the fitted ``log T``."""
    theta = x.copy()
    D = np.eye(x.size)
    for i in range(k):
        theta[2 + 2 * i] = math.exp(x[2 + 2 * i])
        D[2 + 2 * i, 2 + 2 * i] = theta[2 + 2 * i]
    if k == 2 and theta[2] > theta[4]:  # the faster time constant first
        order = [0, 3, 4, 1, 2]
        theta, D = theta[order], D[np.ix_(order, order)]
        cov = cov[np.ix_(order, order)]
    return theta, D @ cov @ D.T


def _warm_up_time(theta: NDArray, k: int, tol: float, t_end: float
                  ) -> tuple[float, NDArray, bool]:
    """Warm-up time [s], its gradient in ``theta`` and whether it falls within the record."""
    from scipy.optimize import brentq

    a = theta[1::2][:k]
    T = theta[2::2][:k]

    def f(t: float) -> float:
        return float(np.sum(a * np.exp(-t / T)))

    grad = np.zeros(theta.size)
    # beyond t_max the transient is below tol for good (each term below tol / k)
    t_max = float(np.max(T * np.log(np.maximum(k * np.abs(a) / tol, 1.0)))) + 1e-9
    grid = np.linspace(0.0, t_max, 2001)
    vals = np.abs(np.array([f(s) for s in grid]))
    above = np.flatnonzero(vals > tol)
    if above.size == 0:
        return 0.0, grad, True
    j = int(above[-1])
    hi = grid[min(j + 1, grid.size - 1)]
    sign = math.copysign(1.0, f(grid[j]))
    t_w = float(brentq(lambda s: sign * f(s) - tol, grid[j], hi, xtol=1e-12 * max(hi, 1.0)))
    e = np.exp(-t_w / T)
    df_dt = float(np.sum(-a / T * e))
    for i in range(k):
        grad[1 + 2 * i] = e[i]
        grad[2 + 2 * i] = a[i] * e[i] * t_w / T[i] ** 2
    grad = -grad / df_dt if df_dt != 0 else np.zeros_like(grad)
    return t_w, grad, t_w <= t_end
