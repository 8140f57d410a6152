"""What each error of a dual-axis centrifuge costs the nine-position identification (issue 5).

Sun, Ren & Wang (seed ``004_f16e7c07e7c35fdc.txt``; authors as given in its header:
孫英博 Sun Yingbo, 任順清 Ren Shunqing, 王常虹 Wang Changhong, Space Control and Inertial
Technology Research Center, Harbin Institute of Technology), sec. 4-5, redone with the exact
kinematics of :mod:`inertest.equipment.centrifuge` instead of the source's first-order
expansions:

1. **Uncertainty.** Standard uncertainty of the ten static drift coefficients of an SDF gyro
   (model in :mod:`inertest.models.sdf_gyro`) from the analytic least-squares covariance of the
   whole-revolution fit, for white output noise of known sigma; confirmed by Monte Carlo.
2. **Error transfer.** For each machine error alone (parallelism, constant non-synchronisation
   angle, phase tracking, rate tracking, radius error, dynamic misalignment, eccentricity,
   wobble) the gyro output is simulated on the exact erroneous machine (noise-free) and fitted
   with the *ideal* machine's regressors: ``error = estimate - truth``.
3. **Compensation.** The same output fitted with the regressors of the machine's error model and
   the measured ``dgamma(t)`` (sampled at the output rate, spline-interpolated): the error
   vanishes to rounding.

The fit itself (grouping into runs, whole revolutions, averaging, least squares) belongs to the
nine-position procedure; it is passed in as ``fit`` (the analysis layer may not import
procedures), with the signature of
``inertest.procedures.centrifuge_nine_position.fit_inputs``.

Plan keys (TOML, engineering units at the edge) are documented in :func:`plan_from_mapping` and
``examples/centrifuge/study.toml``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.earth import OMEGA_IE
from inertest.equipment import centrifuge as cf
from inertest.errors import InertestWarning, InputError, PlanError
from inertest.estimation.reduction import group_rows, whole_cycle_mask, whole_cycle_weights
from inertest.models.sdf_gyro import COEFFICIENTS, ENGINEERING_UNIT, coefficients_from_deg_h, drift
from inertest.plan import check_known_keys, finite_number, toml_table
from inertest.results import envelope
from inertest.units import ARCMIN_TO_RAD, DEG_PER_H_TO_RAD_PER_S, DEG_TO_RAD, G0

# TOML validation with this module's error class (PlanError).
_table = partial(toml_table, error=PlanError)
_known = partial(check_known_keys, error=PlanError)
_number = partial(finite_number, error=PlanError)

#: Signature of the nine-position fit: per-sample position, omega [rad/s], t [s], output
#: [rad/s], f_ios [m/s^2], omega_ios [rad/s]; keyword ``sigma_rad_s``. Returns (LinearFit, ...).
FitFunction = Callable[..., tuple[Any, Any]]

#: How reports cite the source paper (its header gives the authors, not the title).
REFERENCE = ("Sun Yingbo, Ren Shunqing, Wang Changhong (Space Control "
             "and Inertial Technology Research Center, Harbin Institute of Technology), "
             "calibration of a floated gyro on a dual-axis precision centrifuge with a "
             "counter-rotating platform")

#: Position and main-axis rate [rad/s] of the paper's parallelism example (its second attitude,
#: eq. 22, at 4.42 rad/s: first-harmonic output error 7.11e-6 rad/s for dth_y1 = 5e-6 rad).
PARALLELISM_EXAMPLE = (2, 4.42)

#: Representative true coefficients of a floated SDF gyro [deg/h per g^k] (our choice; the
#: source does not list its simulation truth in machine-readable form).
DEFAULT_TRUTH_DEG_H: dict[str, float] = {
    "DF": 0.5, "DI": 0.3, "DO": -0.2, "DS": 0.15,
    "DIO": 0.02, "DOS": -0.015, "DSI": 0.01, "DII": 0.03, "DOO": -0.025, "DSS": 0.02,
}

_CASE_NUMBER_KEYS = {
    f.name for f in cf.CentrifugeErrors.__dataclass_fields__.values()
    if not f.name.endswith("_poly_m") and not f.name.endswith("_poly_rad")
}
_CASE_POLY_KEYS = {"radius_poly_m", "misalignment_y_poly_rad", "misalignment_z_poly_rad"}
_CASE_DGAMMA_KEYS = {
    "dgamma_offset_arcmin", "rate_tracking_arcmin_per_s", "phase_tracking_arcmin",
    "phase_tracking_hz",
}
_CASE_KEYS = _CASE_NUMBER_KEYS | _CASE_POLY_KEYS | _CASE_DGAMMA_KEYS | {"label"}
_TABLES = {
    "site": {"latitude_deg", "gravity_m_s2"},
    "machine": {"radius_m", "platform_heading_deg", "omega_rad_s", "sample_rate_hz",
                "revolutions"},
    "noise": {"three_sigma_rad_s"},
    "truth": set(COEFFICIENTS),
    "monte_carlo": {"runs", "seed"},
}


@dataclass(frozen=True)
class ErrorCase:
    """One machine error (or a set applied together) of the error-transfer study."""

    key: str
    label: str
    errors: cf.CentrifugeErrors = field(default_factory=cf.CentrifugeErrors)
    dgamma: cf.NonSynchronisation | None = None


@dataclass(frozen=True)
class StudyPlan:
    """Settings of the study, SI (see :func:`plan_from_mapping` for the TOML keys)."""

    radius_m: float = 2.5
    latitude_rad: float = 45.0 * DEG_TO_RAD
    gravity_m_s2: float = 9.8066
    platform_heading_rad: float = 0.0
    omegas_rad_s: tuple[float, ...] = (4.43, 8.85)
    sample_rate_hz: float = 50.0
    revolutions: int = 100
    noise_sigma_rad_s: float = 1e-7 / 3.0
    truth: NDArray[np.float64] = field(
        default_factory=lambda: coefficients_from_deg_h(DEFAULT_TRUTH_DEG_H))
    cases: tuple[ErrorCase, ...] = ()
    monte_carlo_runs: int = 0
    seed: int = 1
    name: str = ""

    def __post_init__(self) -> None:
        if not (self.radius_m > 0 and self.gravity_m_s2 > 0 and self.sample_rate_hz > 0):
            raise InputError("radius, gravity and sample rate must be positive")
        if not self.omegas_rad_s or any(not (w > 0 and math.isfinite(w))
                                        for w in self.omegas_rad_s):
            raise InputError("main-axis rates must be positive numbers [rad/s]; give at least one")
        if self.revolutions < 1:
            raise InputError("revolutions must be at least 1 (whole-cycle integration)")
        if not self.noise_sigma_rad_s >= 0:
            raise InputError("noise sigma must be >= 0 [rad/s]")
        for w in self.omegas_rad_s:
            if self.sample_rate_hz < 4 * w / (2 * math.pi):
                raise InputError(
                    f"{self.sample_rate_hz:g} Hz samples a {w:g} rad/s revolution fewer than 4 "
                    "times; raise sample_rate_hz"
                )


@dataclass(frozen=True)
class Runs:
    """Per-sample records of all runs (position x rate), concatenated."""

    position: NDArray[np.int64]
    omega: NDArray[np.float64]
    t: NDArray[np.float64]
    f_ideal: NDArray[np.float64]
    omega_ideal: NDArray[np.float64]
    f_true: NDArray[np.float64]
    omega_true: NDArray[np.float64]
    f_model: NDArray[np.float64]
    omega_model: NDArray[np.float64]


@dataclass(frozen=True)
class CaseResult:
    """Identification error caused by one case [rad/s per g^k], before and after compensation."""

    case: ErrorCase
    error: NDArray[np.float64]
    error_compensated: NDArray[np.float64]
    max_run_output_error_rad_s: float
    max_run_rate_error_rad_s: float
    max_sample_rate_error_rad_s: float
    example_first_harmonic_rad_s: float | None = None


@dataclass(frozen=True)
class StudyResult:
    """Everything the report and the CLI show. Coefficients in SI (rad/s per g^k)."""

    plan: StudyPlan
    names: tuple[str, ...]
    units: tuple[str, ...]
    std: NDArray[np.float64]
    monte_carlo_std: NDArray[np.float64] | None
    cases: tuple[CaseResult, ...]
    notes: tuple[str, ...]
    closed_form_error: NDArray[np.float64]

    def to_dict(self) -> dict[str, Any]:
        """The result envelope: settings, predicted uncertainty and the cost of each case.

        Nothing is identified from data here, so ``identification`` is null; the study's own
        block (``result``) holds, per coefficient, the predicted std, in deg/h per g^k.
        """
        k = DEG_PER_H_TO_RAD_PER_S
        out: dict[str, Any] = {
            "settings": {
                "radius_m": self.plan.radius_m,
                "latitude_deg": self.plan.latitude_rad / DEG_TO_RAD,
                "gravity_m_s2": self.plan.gravity_m_s2,
                "omega_rad_s": list(self.plan.omegas_rad_s),
                "sample_rate_hz": self.plan.sample_rate_hz,
                "revolutions": self.plan.revolutions,
                "noise_sigma_rad_s": self.plan.noise_sigma_rad_s,
            },
            "coefficients": {
                n: {
                    "truth": float(self.plan.truth[i] / k),
                    "std": float(self.std[i] / k),
                    "monte_carlo_std": (None if self.monte_carlo_std is None
                                        else float(self.monte_carlo_std[i] / k)),
                    "unit": u,
                }
                for i, (n, u) in enumerate(zip(self.names, self.units, strict=True))
            },
            "closed_form_error": {
                n: float(self.closed_form_error[i] / k) for i, n in enumerate(self.names)
            },
            "cases": [
                {
                    "key": c.case.key,
                    "label": c.case.label,
                    "error": {n: float(c.error[i] / k) for i, n in enumerate(self.names)},
                    "error_compensated": {
                        n: float(c.error_compensated[i] / k) for i, n in enumerate(self.names)
                    },
                    "max_run_output_error_rad_s": c.max_run_output_error_rad_s,
                    "max_run_rate_error_rad_s": c.max_run_rate_error_rad_s,
                    "max_sample_rate_error_rad_s": c.max_sample_rate_error_rad_s,
                    "example_first_harmonic_rad_s": c.example_first_harmonic_rad_s,
                    "unit": "deg/h per g^k (see coefficients)",
                }
                for c in self.cases
            ],
        }
        site = {"latitude_deg": self.plan.latitude_rad / DEG_TO_RAD,
                "gravity_m_s2": self.plan.gravity_m_s2}
        return envelope("centrifuge-study", site=site, result=out, messages=self.notes)


def _measured(dgamma: cf.NonSynchronisation | None,
              t: NDArray[np.float64]) -> cf.NonSynchronisation | None:
    """What the encoders would give: ``dgamma`` sampled at the output times."""
    if dgamma is None:
        return None
    return cf.MeasuredDgamma(t, dgamma.evaluate(t)[0])


def simulate_runs(plan: StudyPlan, case: ErrorCase | None = None, *,
                  ideal: Runs | None = None) -> Runs:
    """Inputs of every (position, rate) run on the ideal, the real and the modelled machine.

    The real machine has ``case``'s errors and non-synchronisation; the model is the same error
    model with ``dgamma`` replaced by its samples (``MeasuredDgamma``). ``Runs.f_*`` in m/s^2,
    ``Runs.omega_*`` (inertial rates on I, O, S) in rad/s. ``ideal``, the result of
    ``simulate_runs(plan)``, supplies the error-free machine instead of computing it again.
    """
    kw: dict[str, Any] = {"radius_m": plan.radius_m, "gravity_m_s2": plan.gravity_m_s2,
          "latitude_rad": plan.latitude_rad, "platform_heading_rad": plan.platform_heading_rad}
    cols: dict[str, list[NDArray[np.float64]]] = {k: [] for k in Runs.__dataclass_fields__}
    start = 0  # of the run in ``ideal`` (same runs, same order)
    for w in plan.omegas_rad_s:
        t = cf.run_times(w, plan.sample_rate_hz, plan.revolutions)
        measured = _measured(case.dgamma if case else None, t)
        for pos in cf.POSITIONS:
            # "ideal" = the error-free machine, exactly (Earth-rate Coriolis included), so that a
            # case's error is the machine error's alone; the closed form is studied separately
            if ideal is None:
                f0, w0, _ = cf.instrument_inputs(t, w, pos, **kw)
            else:
                f0 = ideal.f_ideal[start : start + t.size]
                w0 = ideal.omega_ideal[start : start + t.size]
            start += t.size
            if case is None:
                f1, w1, fm, wm = f0, w0, f0, w0
            else:
                f1, w1, _ = cf.instrument_inputs(t, w, pos, errors=case.errors,
                                                 dgamma=case.dgamma, **kw)
                fm, wm, _ = cf.instrument_inputs(t, w, pos, errors=case.errors,
                                                 dgamma=measured, **kw)
            cols["position"].append(np.full(t.size, pos))
            cols["omega"].append(np.full(t.size, w))
            cols["t"].append(t)
            for key, v in (("f_ideal", f0), ("omega_ideal", w0), ("f_true", f1),
                           ("omega_true", w1), ("f_model", fm), ("omega_model", wm)):
                cols[key].append(v)
    return Runs(**{k: np.concatenate(v) for k, v in cols.items()})  # type: ignore[arg-type]


def gyro_output(runs: Runs, truth: NDArray[np.float64]) -> NDArray[np.float64]:
    """Noise-free rebalance output ``w_I + drift(f / g0)`` [rad/s] on the real machine."""
    return runs.omega_true[:, 0] + drift(runs.f_true / G0, truth)


def _quiet(fit: FitFunction, *args: Any, **kwargs: Any) -> Any:
    """``fit(*args, **kwargs)`` without the model check's warning.

    The study fits noise-free outputs of an imperfect machine with models that leave errors out
    on purpose (the ideal and closed-form fits), to measure the bias they cause, and repeats
    fits many times in its Monte Carlo, where a few fail the check by chance (its false-alarm
    rate): the misfit is the result there, not a warning to the user.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)
        lin, _ = fit(*args, **kwargs)
    return lin


def _fit(fit: FitFunction, runs: Runs, output: NDArray[np.float64], which: str,
         sigma: float | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    f = getattr(runs, f"f_{which}")
    w = getattr(runs, f"omega_{which}")
    lin = _quiet(fit, runs.position, runs.omega, runs.t, output, f, w, sigma_rad_s=sigma)
    return np.asarray(lin.x, dtype=float), np.sqrt(np.diag(np.asarray(lin.covariance)))


def _run_means(runs: Runs, values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean of ``values`` per (position, rate) run over its whole revolutions.

    Weighted with :func:`~inertest.estimation.reduction.whole_cycle_weights`, exactly as the fit
    averages the output, so a pure first or second harmonic of the arm averages to zero.
    """
    out = []
    for w in np.unique(runs.omega):
        for pos in cf.POSITIONS:
            sel = (runs.omega == w) & (runs.position == pos)
            whole, _ = whole_cycle_mask(runs.t[sel], w)
            out.append(whole_cycle_weights(runs.t[sel][whole], w) @ values[sel][whole])
    return np.asarray(out)


def example_first_harmonic(plan: StudyPlan, case: ErrorCase) -> float:
    """First-harmonic amplitude [rad/s] of the output error at the paper's parallelism example.

    The noise-free output error (real minus error-free machine, rate on I plus drift) at
    position 2 and 4.42 rad/s (:data:`PARALLELISM_EXAMPLE`) over 10 whole revolutions, fitted
    with a constant and the arm's first harmonic; the amplitude is ``sqrt(a^2 + b^2)``.
    """
    pos, w = PARALLELISM_EXAMPLE
    t = cf.run_times(w, plan.sample_rate_hz, 10)
    kw: dict[str, Any] = {"radius_m": plan.radius_m, "gravity_m_s2": plan.gravity_m_s2,
          "latitude_rad": plan.latitude_rad, "platform_heading_rad": plan.platform_heading_rad}
    f0, w0, _ = cf.instrument_inputs(t, w, pos, **kw)
    f1, w1, _ = cf.instrument_inputs(t, w, pos, errors=case.errors, dgamma=case.dgamma, **kw)
    err = (w1[:, 0] + drift(f1 / G0, plan.truth)) - (w0[:, 0] + drift(f0 / G0, plan.truth))
    whole, _ = whole_cycle_mask(t, w)
    a = w * t[whole]
    basis = np.column_stack([np.ones_like(a), np.cos(a), np.sin(a)])
    c, *_ = np.linalg.lstsq(basis, err[whole], rcond=None)
    return float(np.hypot(c[1], c[2]))


def closed_form_inputs(plan: StudyPlan, runs: Runs) -> tuple[NDArray[np.float64], ...]:
    """Inputs of the issue's closed form (no Earth-rate terms in the acceleration) for ``runs``."""
    f = np.empty((runs.t.size, 3))
    w_ios = np.empty((runs.t.size, 3))
    groups = group_rows(runs.position, runs.omega)
    for r, (pos, w) in enumerate(zip(*groups.keys, strict=True)):
        idx = groups.rows(r)
        f[idx], w_ios[idx] = cf.ideal_inputs(
            runs.t[idx], float(w), int(pos), radius_m=plan.radius_m,
            gravity_m_s2=plan.gravity_m_s2, latitude_rad=plan.latitude_rad,
            platform_heading_rad=plan.platform_heading_rad)
    return f, w_ios


def monte_carlo_std(plan: StudyPlan, fit: FitFunction, runs: Runs, n: int,
                    seed: int | np.random.SeedSequence, *, executor: Any = None,
                    chunks: int | None = None) -> NDArray[np.float64]:
    """Scatter [rad/s per g^k] of the estimates over ``n`` noisy repetitions (ideal machine).

    Parameters
    ----------
    plan, fit, runs
        The study plan, the nine-position fit and the error-free runs (:func:`simulate_runs`).
    n : int
        Repetitions (at least 2).
    seed : int or numpy.random.SeedSequence
        Repetition ``i`` draws its white output noise (sigma ``plan.noise_sigma_rad_s``
        [rad/s]) from ``default_rng(SeedSequence(seed).spawn(n)[i])``, so the result does not
        depend on where or in which order the repetitions run.
    executor : optional
        Anything with ``submit(fn, *args)`` returning futures with ``result()``
        (:class:`concurrent.futures.ProcessPoolExecutor`, ``dask.distributed.Client``); None
        runs here. Serial, pool and Dask results are identical bit for bit.
    chunks : int, optional
        Number of tasks the repetitions are split into (each carries the runs once); default
        ``min(n, 16)`` on an executor.

    Returns
    -------
    ndarray, shape (10,)
        Sample standard deviation (ddof 1) of each coefficient estimate [rad/s per g^k].
    """
    if n < 2:
        raise InputError("Monte Carlo needs at least 2 runs; give --monte-carlo N >= 2")
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    children = ss.spawn(n)
    inputs = (runs.position, runs.omega, runs.t, runs.f_true, runs.omega_true,
              gyro_output(runs, plan.truth))
    if executor is None:
        est = _monte_carlo_chunk(fit, inputs, plan.noise_sigma_rad_s, children)
    else:
        k = min(n, 16) if chunks is None else max(1, min(int(chunks), n))
        bounds = np.linspace(0, n, k + 1).astype(int)
        futures = [executor.submit(_monte_carlo_chunk, fit, inputs, plan.noise_sigma_rad_s,
                                   children[a:b])
                   for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        est = np.concatenate([f.result() for f in futures])
    return est.std(axis=0, ddof=1)


def _monte_carlo_chunk(fit: FitFunction, inputs: tuple[NDArray[Any], ...], sigma: float,
                       seeds: list[np.random.SeedSequence]) -> NDArray[np.float64]:
    """Estimates, shape (len(seeds), 10), of the repetitions with these noise seeds."""
    position, omega, t, f, w, clean = inputs
    est = np.empty((len(seeds), len(COEFFICIENTS)))
    for i, s in enumerate(seeds):
        noisy = clean + np.random.default_rng(s).normal(0.0, sigma, clean.size)
        lin = _quiet(fit, position, omega, t, noisy, f, w, sigma_rad_s=sigma)
        est[i] = np.asarray(lin.x, dtype=float)
    return est


def run_study(plan: StudyPlan, fit: FitFunction, *, monte_carlo_runs: int | None = None,
              executor: Any = None) -> StudyResult:
    """Run the three parts of the study (module docstring).

    Parameters
    ----------
    plan : StudyPlan
    fit : callable
        ``fit_inputs`` of the nine-position procedure.
    monte_carlo_runs : int, optional
        Overrides ``plan.monte_carlo_runs`` (0 = no Monte Carlo).
    executor : optional
        Where the Monte Carlo repetitions run (see :func:`monte_carlo_std`); None: here.
    """
    sigma = plan.noise_sigma_rad_s if plan.noise_sigma_rad_s > 0 else None
    base = simulate_runs(plan)
    x0, std = _fit(fit, base, gyro_output(base, plan.truth), "true", sigma)
    f_cf, w_cf = closed_form_inputs(plan, base)
    lin_cf = _quiet(fit, base.position, base.omega, base.t, gyro_output(base, plan.truth), f_cf,
                    w_cf, sigma_rad_s=None)
    closed_form_error = np.asarray(lin_cf.x) - plan.truth
    mc_n = plan.monte_carlo_runs if monte_carlo_runs is None else monte_carlo_runs
    mc = (monte_carlo_std(plan, fit, base, mc_n, plan.seed, executor=executor)
          if mc_n and sigma is not None else None)
    results = []
    for case in plan.cases:
        runs = simulate_runs(plan, case, ideal=base)
        out = gyro_output(runs, plan.truth)
        est_ideal = _fit(fit, runs, out, "ideal", None)[0]
        est_model = _fit(fit, runs, out, "model", None)[0]
        ideal_out = runs.omega_ideal[:, 0] + drift(runs.f_ideal / G0, plan.truth)
        results.append(CaseResult(
            case=case,
            error=est_ideal - plan.truth,
            error_compensated=est_model - plan.truth,
            max_run_output_error_rad_s=float(np.abs(_run_means(runs, out - ideal_out)).max()),
            max_run_rate_error_rad_s=float(np.abs(
                _run_means(runs, runs.omega_true[:, 0] - runs.omega_ideal[:, 0])).max()),
            max_sample_rate_error_rad_s=float(np.abs(
                runs.omega_true[:, 0] - runs.omega_ideal[:, 0]).max()),
            example_first_harmonic_rad_s=(
                example_first_harmonic(plan, case)
                if case.errors.parallelism_x_rad or case.errors.parallelism_y_rad else None),
        ))
    names = tuple(COEFFICIENTS)
    return StudyResult(
        plan=plan, names=names, units=tuple(ENGINEERING_UNIT[n] for n in names), std=std,
        monte_carlo_std=mc, cases=tuple(results), closed_form_error=closed_form_error,
        notes=_notes(plan, x0, std, results, closed_form_error),
    )


def _notes(plan: StudyPlan, x0: NDArray[np.float64], std: NDArray[np.float64],
           results: list[CaseResult], closed_form_error: NDArray[np.float64]) -> tuple[str, ...]:
    """Where the exact kinematics disagree with Sun, Ren & Wang's first-order results."""
    k = DEG_PER_H_TO_RAD_PER_S
    coriolis = 2 * OMEGA_IE * max(plan.omegas_rad_s) * plan.radius_m
    cf_ratio = np.abs(closed_form_error) / std
    i_cf = int(np.argmax(cf_ratio))
    notes = [
        "Error-free machine, noise-free: largest |estimate - truth| = "
        f"{np.abs(x0 - plan.truth).max() / k:.2e} deg/h per g^k (whole-revolution fit exact).",
        "Sun, Ren & Wang list a Coriolis part (Ak) in its specific force (eq. 9); "
        "the closed form without the Earth-rate terms 2 W x v and W x (W x p) is this "
        f"project's simplification. On this machine 2 W w R reaches {coriolis:.2e} m/s^2 "
        f"({coriolis / G0:.2e} g); fitting the error-free machine with that closed form costs "
        f"up to {cf_ratio[i_cf]:.2g} sigma ({COEFFICIENTS[i_cf]}: "
        f"{closed_form_error[i_cf] / k:.2e} {ENGINEERING_UNIT[COEFFICIENTS[i_cf]]}), which is "
        "why the nine-position fit uses the exact inputs.",
    ]
    by_key = {r.case.key: r for r in results}
    for r in results:
        ratio = np.abs(r.error) / std
        worst = np.argsort(ratio)[::-1][:4]
        least = [COEFFICIENTS[i] for i in np.argsort(ratio)[:2]]
        notes.append(
            f"{r.case.label}: largest run-mean output error {r.max_run_output_error_rad_s:.3e} "
            f"rad/s (of which input-rate {r.max_run_rate_error_rad_s:.3e} rad/s); most affected "
            + ", ".join(f"{COEFFICIENTS[i]} ({ratio[i]:.2g} sigma)" for i in worst)
            + f"; least affected {', '.join(least)}; after compensation the largest error is "
            f"{np.abs(r.error_compensated).max() / k:.1e} deg/h per g^k."
        )
    for r in by_key.values():
        if isinstance(r.case.dgamma, cf.RateTracking) and r.case.dgamma.rate_rad_s:
            notes.append(
                f"{r.case.label}: the servo's residual rate d(dgamma)/dt = "
                f"{r.case.dgamma.rate_rad_s:.3e} rad/s acts on the gyro directly wherever I has "
                "a component along the azimuth axis (largest run mean "
                f"{r.max_run_rate_error_rad_s:.3e} rad/s); Sun, Ren & Wang keep only "
                "the angle dgamma to first order and misses this term, which dominates the "
                "rate-tracking result."
            )
        elif isinstance(r.case.dgamma, cf.RateTracking):
            arcmin = r.case.dgamma.offset_rad / ARCMIN_TO_RAD
            off = r.case.dgamma.offset_rad
            earth = 2 * OMEGA_IE * math.cos(plan.latitude_rad) * abs(math.sin(off / 2))
            notes.append(
                f"{r.case.label}: a constant dgamma turns the gyro about the vertical, so the "
                "horizontal Earth rate on I changes by up to 2 W cos(L) sin(dgamma / 2) = "
                f"{earth:.3e} rad/s (exact run-mean output error "
                f"{r.max_run_output_error_rad_s:.3e} rad/s). "
                "Sun, Ren & Wang quote 1.823e-7 rad/s for 1000' and 'of order 1e-8' for "
                "200' and finds "
                "mainly DSS, DOO, DIO, DSI affected; exactly, the specific-force regressors are "
                "unchanged over whole revolutions (a turn about the vertical only shifts the phase "
                "of the rotating centripetal force) and the error enters through the Earth rate, "
                f"at {arcmin:g}' mainly into "
                + ", ".join(COEFFICIENTS[i] for i in np.argsort(np.abs(r.error) / std)[::-1][:4])
                + "."
            )
        elif isinstance(r.case.dgamma, cf.PhaseTracking):
            d = r.case.dgamma
            notes.append(
                f"{r.case.label}: a bounded dgamma still has a residual rate of amplitude "
                f"2 pi f A = {2 * math.pi * d.frequency_hz * d.amplitude_rad:.3e} rad/s on the "
                "azimuth axis, which whole-revolution averaging cancels only when f is a multiple "
                "of the revolution frequency; its largest run-mean rate error here is "
                f"{r.max_run_rate_error_rad_s:.3e} rad/s. Sun, Ren & Wang's conclusion "
                "holds: "
                "phase tracking costs far less than rate tracking (compare the tables), but not "
                "nothing."
            )
        elif r.case.errors.parallelism_y_rad or r.case.errors.parallelism_x_rad:
            pos, w = PARALLELISM_EXAMPLE
            w_max = max(abs(x) for x in plan.omegas_rad_s)
            second = w_max * (r.case.errors.parallelism_x_rad ** 2
                              + r.case.errors.parallelism_y_rad ** 2) / 2
            example = ("" if r.example_first_harmonic_rad_s is None else
                       f"; exactly, at that position and rate the first-harmonic amplitude of "
                       f"the output error is {r.example_first_harmonic_rad_s:.3e} rad/s")
            notes.append(
                f"{r.case.label}: Sun, Ren & Wang quote a first-harmonic output error of "
                f"7.11e-6 rad/s for its second attitude (position {pos}) at {w:g} rad/s"
                f"{example}. Over all runs the largest rate error on I is "
                f"{r.max_sample_rate_error_rad_s:.3e} rad/s per sample, and over the whole "
                "revolutions of each run, with the fit's weights, it averages to at most "
                f"{r.max_run_rate_error_rad_s:.3e} rad/s: the first harmonic cancels and what is "
                "left is the second-order vertical part w dth^2 / 2 of the relative rotation "
                f"({second:.3e} rad/s at {w_max:g} rad/s), so after whole-cycle integration "
                f"parallelism costs at most {(np.abs(r.error) / std).max():.2g} sigma here."
            )
        elif r.case.errors.eccentricity_x_m or r.case.errors.eccentricity_y_m:
            notes.append(
                f"{r.case.label}: the counter-rotating platform carries the eccentric point on a "
                "circular translation, so its acceleration equals the ideal one exactly; the "
                "eccentricity costs nothing (largest error "
                f"{np.abs(r.error).max() / k:.1e} deg/h per g^k, rounding)."
            )
    return tuple(notes)


# ------------------------------------------------------------------------------------------
# Plan files
# ------------------------------------------------------------------------------------------


def plan_from_mapping(doc: Mapping[str, Any], *, source: str = "plan") -> StudyPlan:
    """Build a :class:`StudyPlan` from a parsed TOML document.

    Tables and keys (all optional; defaults are the source's settings)::

        name = "..."
        [site]        latitude_deg, gravity_m_s2
        [machine]     radius_m, platform_heading_deg, omega_rad_s = [..], sample_rate_hz,
                      revolutions
        [noise]       three_sigma_rad_s
        [truth]       DF = .. (deg/h per g^k, names of inertest.models.sdf_gyro)
        [monte_carlo] runs, seed
        [errors.KEY]  one table per case, applied alone: label, any CentrifugeErrors field
                      (radius_poly_m, misalignment_y_poly_rad, misalignment_z_poly_rad as lists
                      [c1, c2] for c1 w + c2 w^2; parallelism_x_rad, parallelism_y_rad,
                      wobble_x_rad, wobble_y_rad, wobble_x_phase_rad, wobble_y_phase_rad,
                      eccentricity_x_m, eccentricity_y_m) and one non-synchronisation:
                      dgamma_offset_arcmin (constant), rate_tracking_arcmin_per_s, or
                      phase_tracking_arcmin with phase_tracking_hz.

    Raises
    ------
    PlanError
        Unknown tables or keys (with the known ones), wrong types, impossible values.
    """
    unknown = sorted(set(doc) - set(_TABLES) - {"errors", "name"})
    if unknown:
        raise PlanError(f"{source}: unknown table(s) {', '.join(unknown)}; known: "
                        f"{', '.join(sorted([*_TABLES, 'errors', 'name']))}")
    t = {name: _table(doc, name, source) for name in _TABLES}
    for name, known in _TABLES.items():
        _known(t[name], known, f"{source} [{name}]")
    site, machine = t["site"], t["machine"]
    omegas = machine.get("omega_rad_s", [4.43, 8.85])
    if not isinstance(omegas, list) or not omegas:
        raise PlanError(f"{source}: [machine] omega_rad_s must be a list of rates [rad/s], "
                        "e.g. [4.43, 8.85]")
    revolutions = machine.get("revolutions", 100)
    if isinstance(revolutions, bool) or not isinstance(revolutions, int):
        raise PlanError(f"{source}: [machine] revolutions must be a whole number, "
                        f"got {revolutions!r}")
    try:
        truth = coefficients_from_deg_h(
            {k: _number(v, k, source) for k, v in t["truth"].items()} or DEFAULT_TRUTH_DEG_H)
        errors_t = doc.get("errors", {})
        if not isinstance(errors_t, Mapping):
            raise PlanError(f"{source}: [errors] must hold one table per case, e.g. "
                            "[errors.parallelism]")
        cases = tuple(_case(key, v, source) for key, v in errors_t.items())
        mc = t["monte_carlo"]
        runs = mc.get("runs", 0)
        seed = mc.get("seed", 1)
        if any(isinstance(v, bool) or not isinstance(v, int) or v < 0 for v in (runs, seed)):
            raise PlanError(f"{source}: [monte_carlo] runs and seed must be whole numbers >= 0")
        return StudyPlan(
            radius_m=_number(machine.get("radius_m", 2.5), "radius_m", source),
            latitude_rad=_number(site.get("latitude_deg", 45.0), "latitude_deg", source)
            * DEG_TO_RAD,
            gravity_m_s2=_number(site.get("gravity_m_s2", 9.8066), "gravity_m_s2", source),
            platform_heading_rad=_number(machine.get("platform_heading_deg", 0.0),
                                         "platform_heading_deg", source) * DEG_TO_RAD,
            omegas_rad_s=tuple(_number(w, "omega_rad_s", source) for w in omegas),
            sample_rate_hz=_number(machine.get("sample_rate_hz", 50.0), "sample_rate_hz",
                                   source),
            revolutions=revolutions,
            noise_sigma_rad_s=_number(t["noise"].get("three_sigma_rad_s", 1e-7),
                                      "three_sigma_rad_s", source) / 3.0,
            truth=truth,
            cases=cases,
            monte_carlo_runs=runs,
            seed=seed,
            name=str(doc.get("name", "")),
        )
    except PlanError:
        raise
    except InputError as exc:
        raise PlanError(f"{source}: {exc}") from None


def _case(key: str, t: Any, source: str) -> ErrorCase:
    where = f"{source} [errors.{key}]"
    if not isinstance(t, Mapping):
        raise PlanError(f"{where} must be a table of error values")
    _known(t, _CASE_KEYS, where)
    kw: dict[str, Any] = {}
    for k in _CASE_NUMBER_KEYS & set(t):
        kw[k] = _number(t[k], k, where)
    for k in _CASE_POLY_KEYS & set(t):
        v = t[k]
        if not isinstance(v, list):
            raise PlanError(f"{where}: {k} must be a list [c1, c2, ...] for c1 w + c2 w^2 + ...")
        kw[k] = tuple(_number(x, k, where) for x in v)
    given = [k for k in ("dgamma_offset_arcmin", "rate_tracking_arcmin_per_s",
                         "phase_tracking_arcmin") if k in t]
    if len(given) > 1:
        raise PlanError(f"{where}: give one non-synchronisation ({', '.join(given)}); split "
                        "them into separate cases")
    dgamma: cf.NonSynchronisation | None = None
    if "phase_tracking_hz" in t and "phase_tracking_arcmin" not in t:
        raise PlanError(f"{where}: phase_tracking_hz needs phase_tracking_arcmin")
    if "dgamma_offset_arcmin" in t:
        dgamma = cf.RateTracking(0.0, _number(t["dgamma_offset_arcmin"], "dgamma_offset_arcmin",
                                              where) * ARCMIN_TO_RAD)
    elif "rate_tracking_arcmin_per_s" in t:
        dgamma = cf.RateTracking(_number(t["rate_tracking_arcmin_per_s"],
                                         "rate_tracking_arcmin_per_s", where) * ARCMIN_TO_RAD)
    elif "phase_tracking_arcmin" in t:
        if "phase_tracking_hz" not in t:
            raise PlanError(f"{where}: phase_tracking_arcmin needs phase_tracking_hz (the "
                            "frequency of the bounded tracking error)")
        dgamma = cf.PhaseTracking(
            _number(t["phase_tracking_arcmin"], "phase_tracking_arcmin", where) * ARCMIN_TO_RAD,
            _number(t["phase_tracking_hz"], "phase_tracking_hz", where))
    label = t.get("label", key)
    if not isinstance(label, str):
        raise PlanError(f"{where}: label must be a string")
    return ErrorCase(key=key, label=label, errors=cf.CentrifugeErrors(**kw), dgamma=dgamma)

