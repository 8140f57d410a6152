"""Test-plan design before testing: whether a plan can verify specification limits.

:func:`check_plan` predicts the uncertainty of every quantity a plan determines, from the plan and a
noise model, before anything is measured, and compares it with each limit of an instrument
specification (:mod:`inertest.quality.conformance`):

1. The test is simulated noise-free (the plan's kinematics, a nominal instrument: the given truth,
   or zero coefficients with the plan's nominal scale factor where it has one, e.g. a triad's
   ``nominal_scale_factor``) and fitted by the procedure's own identification front. A procedure
   whose simulation needs coefficients the plan does not give (the scale factor ``K1`` of a
   pendulous accelerometer, ``K`` of a counting gyro) raises :class:`NominalTruthError` naming
   them; ``inertest plan-check`` then takes the ``truth.toml`` beside the plan, if any.
2. Predicted Type-A standard uncertainty:

   - **white noise** (``sigma`` per reading): the fit of the noise-free data with the white
     noise given, ``cov = sigma^2 (A^T A)^-1`` in engineering units (exact for the least
     squares the fit runs);
   - **position offsets** (``position_offset`` per position, on top of ``sigma``) when every
     position has the same number ``n`` of readings and the design is constant within a
     position: the generalised least squares of the position means has the covariance of a white
     fit with ``sigma_eff^2 = sigma^2 + n sigma_pos^2`` (the means are independent with variance
     ``sigma^2 / n + sigma_pos^2``), which is what the fit's ``position-offsets`` model
     estimates;
   - **random walk or flicker**, or unequal positions: a Monte Carlo of simulated tests with
     that noise added to the output and fitted with the matching noise model; the scatter of the
     estimates is the prediction (:attr:`Prediction.method` says which). The replicates run in
     blocks of 25 until the relative standard error of every std, ``0.5 sqrt((kurtosis -
     (n - 3)/(n - 1)) / n)`` (about ``1 / sqrt(2 n)`` for normal estimates), is below
     ``rel_error`` (default 10 %: about 50-75 tests), at most ``n_mc`` (default 200). Every
     candidate plan draws its noise from the same seed (common random numbers), so the
     comparison between candidates is not blurred by independent draws.
3. Type B: the uncertainty budget of the plan's equipment and the site gravity
   (:func:`inertest.quality.budget.uncertainty_budget`), and ``U = k u_c`` with ``k = 2``
   (GUM G.6.6: many degrees of freedom).
4. The decision: a limit is *verifiable* when ``U <= tolerance / TUR`` (test uncertainty ratio,
   default 3, the usual 3:1 of calibration practice; ILAC-G8:09/2019 sec. 3 leaves the ratio to
   the lab); *marginal* when ``tolerance / TUR < U < tolerance`` (a guarded pass, w = U, is still
   possible for an instrument well inside the limit); *not verifiable* when ``U >= tolerance``
   (no value can get a guarded pass); *not determined* when the plan does not identify the
   quantity at all. The tolerance is ``max_abs``, half of ``max - min``, or ``|bound|`` for a
   one-sided limit.
5. For limits that are not verifiable, the cheapest change among a longer dwell (x2, x4), more
   positions or repeats (x2) and a second position set where the procedure has one (the missing
   mountings of a polar tumble) that makes every such limit verifiable, cost measured by the
   number of readings. Candidates are judged cheapest first and the search stops at the first
   that verifies (a dearer one could not be the suggestion).

Noise file (TOML or JSON), in the plan's output unit unless ``unit`` says otherwise::

    sigma = 0.002            # white noise per reading
    position_offset = 0.0    # std of an offset per position (table re-settling, bias jumps)
    random_walk = 0.0        # std of the random-walk step per reading
    flicker = 0.0            # std of band-limited 1/f noise per reading
    unit = "mA"              # optional; a rate or specific-force unit is converted

or the JSON of ``inertest allan --json`` (a rate recording), whose IEEE Std 952-1997 Annex C terms
map, with the reading interval ``tau0`` (the plan's ``sample_rate_hz`` or ``sample_interval_s``, or
``--sample-interval``) and the dwell ``T_d`` of a position, as:

- angle random walk N: ``sigma_A(tau) = N / sqrt(tau)``, so white ``sigma = N / sqrt(tau0)`` per
  reading;
- bias instability B: the flicker floor ``sigma_A = B sqrt(2 ln 2 / pi) = 0.664 B`` (C.1); for
  independent offsets per position the Allan deviation at ``tau = T_d`` of the position means
  equals the offset std, so ``position_offset = 0.664 B``;
- rate random walk K: ``sigma_A(tau) = K sqrt(tau / 3)``, a random walk of the rate with step
  ``K sqrt(tau0)`` per reading.

Unresolved terms (only an upper bound known) are taken as zero and named in the notes.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tomllib
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from inertest.errors import InertestError, PlanError, UnitError
from inertest.plan import Plan, did_you_mean
from inertest.procedures import procedure
from inertest.quality.budget import quantities_of, uncertainty_budget
from inertest.quality.conformance import Spec, model_names, not_determined_note
from inertest.quality.lab import Equipment
from inertest.units import convert

#: Default test uncertainty ratio: U <= tolerance / 3.
DEFAULT_TUR = 3.0
#: Allan deviation of flicker noise per unit of bias instability, sqrt(2 ln 2 / pi) (IEEE 952 C.1).
FLICKER_FLOOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: Coverage factor of the predicted expanded uncertainty (GUM G.6.6, many dof).
K_PREDICTED = 2.0

STATUSES = ("verifiable", "marginal", "not verifiable", "not determined")


class NoiseFileError(PlanError):
    """A noise file is missing, malformed or does not fit the plan."""


class NominalTruthError(PlanError):
    """The plan's simulation needs nominal coefficients (a scale factor) that were not given."""


@dataclass(frozen=True)
class NoiseModel:
    """Noise of the instrument's output, per reading, in the plan's output unit.

    Attributes
    ----------
    sigma : float
        White noise per reading [output unit].
    position_offset : float
        Std of an independent offset per position [output unit].
    random_walk : float
        Std of the random-walk step per reading [output unit].
    flicker : float
        Std of band-limited 1/f noise per reading [output unit].
    unit : str
        The output unit.
    notes : tuple of str
        How the levels were obtained (mapping from Allan terms, unresolved terms).
    """

    sigma: float
    position_offset: float = 0.0
    random_walk: float = 0.0
    flicker: float = 0.0
    unit: str = ""
    notes: tuple[str, ...] = ()

    @property
    def white_only(self) -> bool:
        """True when only the white part is non-zero."""
        return self.position_offset == 0 and self.random_walk == 0 and self.flicker == 0

    def to_dict(self) -> dict[str, object]:
        """JSON form, every level with its unit."""
        return {"sigma": self.sigma, "position_offset": self.position_offset,
                "random_walk": self.random_walk, "flicker": self.flicker, "unit": self.unit,
                "notes": list(self.notes)}


@dataclass(frozen=True)
class LimitCheck:
    """Whether a plan can verify one limit.

    Attributes
    ----------
    quantity, unit, limit, clause : str
        The limited quantity, the limit's unit, the limit as written, its clause.
    tolerance : float
        [unit] (see the module docstring).
    std_a, type_b, expanded : float or None
        Predicted Type-A std, Type-B combined std, U (k = 2) [unit]; None when not determined.
    status : str
        One of :data:`STATUSES`.
    note : str
    """

    quantity: str
    unit: str
    limit: str
    clause: str
    tolerance: float
    std_a: float | None
    type_b: float | None
    expanded: float | None
    status: str
    note: str = ""

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        return {"quantity": self.quantity, "unit": self.unit, "limit": self.limit,
                "clause": self.clause, "tolerance": self.tolerance,
                "predicted_std_type_a": self.std_a, "predicted_std_type_b": self.type_b,
                "predicted_expanded": self.expanded, "coverage_factor": K_PREDICTED,
                "status": self.status, "note": self.note}


@dataclass(frozen=True)
class Prediction:
    """Predicted uncertainties of one plan and the verdict on each limit.

    Attributes
    ----------
    label : str
        ``"plan as written"`` or the change applied (``"dwell x2 (samples_per_position 10)"``).
    readings : int
        Readings of the test (its cost).
    method : str
        How the Type-A std was predicted (closed form or Monte Carlo, see the module docstring).
    std_a : dict of str to (float, str)
        Predicted Type-A std and unit per determined quantity.
    limits : tuple of LimitCheck
    plan : Plan or None
        The plan predicted (with the change applied).
    """

    label: str
    readings: int
    method: str
    std_a: dict[str, tuple[float, str]]
    limits: tuple[LimitCheck, ...]
    plan: Plan | None = dataclasses.field(default=None, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """True when every limit is verifiable."""
        return all(c.status == "verifiable" for c in self.limits)

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        return {"plan": self.label, "readings": self.readings, "method": self.method,
                "predicted_std_type_a": {k: {"std": v, "unit": u}
                                         for k, (v, u) in self.std_a.items()},
                "limits": [c.to_dict() for c in self.limits], "all_verifiable": self.ok}


@dataclass(frozen=True)
class PlanCheck:
    """The outcome of :func:`check_plan`.

    Attributes
    ----------
    plan : Prediction
        The plan as written.
    suggestion : Prediction or None
        The cheapest change that makes every limit verifiable (None when the plan already
        does, or when no candidate does).
    candidates : tuple of Prediction
        Every change tried, cheapest first.
    noise : NoiseModel
    tur : float
    rule : str
        The decision rule in words.
    not_determined : tuple of str
        What the plan cannot determine, and why (from the fit).
    nominal : str
        The nominal instrument simulated (where its coefficients came from).
    """

    plan: Prediction
    suggestion: Prediction | None
    candidates: tuple[Prediction, ...]
    noise: NoiseModel
    tur: float
    rule: str
    not_determined: tuple[str, ...]
    nominal: str = "zero coefficients (the plan's nominal scale factor where it has one)"

    @property
    def ok(self) -> bool:
        """True when the plan as written can verify every limit."""
        return self.plan.ok

    def to_dict(self) -> dict[str, object]:
        """The ``plan-check`` JSON document."""
        return {"kind": "plan-check", "rule": self.rule, "test_uncertainty_ratio": self.tur,
                "noise": self.noise.to_dict(), "nominal_instrument": self.nominal,
                "plan": self.plan.to_dict(),
                "all_verifiable": self.ok, "not_determined": list(self.not_determined),
                "suggestion": None if self.suggestion is None else self.suggestion.to_dict(),
                "candidates": [c.to_dict() for c in self.candidates]}


# --- noise file ------------------------------------------------------------------------------

_NOISE_KEYS = {"sigma", "position_offset", "random_walk", "flicker", "unit"}


def read_noise(path: str | os.PathLike[str], plan: Plan, *,
               sample_interval_s: float | None = None) -> NoiseModel:
    """Read a noise file (TOML, JSON or ``inertest allan --json``) into the plan's output unit.

    Parameters
    ----------
    path : path-like
    plan : Plan
        Gives the output unit (and the torquer scale factor of an electrical output).
    sample_interval_s : float, optional
        Interval between readings [s], to map Allan terms; default the plan's
        ``sample_rate_hz`` / ``sample_interval_s``.

    Raises
    ------
    NoiseFileError
        Missing or unreadable file, unknown keys, a negative or missing level, a unit that cannot
        be expressed in the output unit, Allan terms without a sample interval.
    """
    source = f"noise file {os.fspath(path)}"
    doc = _noise_document(path, source, "a TOML/JSON with sigma per reading, or the JSON of "
                          "inertest allan --json")
    tau0 = sample_interval_s if sample_interval_s is not None else _plan_interval(plan)
    if isinstance(doc.get("result"), Mapping) and "noise_terms" in doc["result"]:
        return _from_allan(doc["result"]["noise_terms"], plan, tau0, source)
    return _from_levels(doc, plan, source)


def _noise_document(path: str | os.PathLike[str], source: str, what: str) -> Mapping[str, Any]:
    """The table of a noise file (JSON, else TOML); NoiseFileError naming ``what`` to give."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except FileNotFoundError:
        raise NoiseFileError(f"{source} does not exist; give --noise {what}") from None
    except OSError as exc:
        raise NoiseFileError(f"{source} cannot be read: {exc.strerror}") from None
    doc: Any
    try:
        doc = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError):
        try:
            doc = tomllib.loads(raw.decode("utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise NoiseFileError(f"{source} is neither JSON nor valid TOML: {exc}") from None
    if not isinstance(doc, Mapping):
        raise NoiseFileError(f"{source} must hold a table of noise levels")
    return doc


def _plan_interval(plan: Plan) -> float | None:
    spec = plan.procedure
    rate = getattr(spec, "sample_rate_hz", None)
    if rate:
        return 1.0 / float(rate)
    dt = getattr(spec, "sample_interval_s", None)
    return float(dt) if dt else None


def _number(doc: Mapping[str, Any], key: str, source: str, default: float | None) -> float:
    v = doc.get(key, default)
    if v is None:
        raise NoiseFileError(f"{source} has no {key}; give the white noise per reading, e.g. "
                             "sigma = 0.002 (in the plan's output unit)")
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
        raise NoiseFileError(f"{source}: {key} must be a number >= 0, got {v!r}")
    if not math.isfinite(float(v) * v):  # variances are computed with it
        raise NoiseFileError(f"{source}: {key} = {v!r} is too large to compute with (its square "
                             "overflows); give the level per reading in the plan's output unit")
    return float(v)


def _from_levels(doc: Mapping[str, Any], plan: Plan, source: str) -> NoiseModel:
    unknown = sorted(set(doc) - _NOISE_KEYS)
    if unknown:
        raise NoiseFileError(
            f"{source}: unknown key(s) {', '.join(unknown)}"
            f"{did_you_mean(unknown[0], sorted(_NOISE_KEYS))}; known: "
            f"{', '.join(sorted(_NOISE_KEYS))}")
    out = plan.instrument.output_unit
    unit = doc.get("unit", out)
    if not isinstance(unit, str):
        raise NoiseFileError(f"{source}: unit must be text, got {unit!r}")
    levels = {k: _number(doc, k, source, None if k == "sigma" else 0.0)
              for k in ("sigma", "position_offset", "random_walk", "flicker")}
    if levels["sigma"] == 0 and not any(levels.values()):
        raise NoiseFileError(f"{source}: every noise level is zero; a plan cannot be judged "
                             "against noise-free data (give sigma > 0)")
    factor = _to_output(1.0, unit, plan, source)
    return NoiseModel(**{k: v * factor for k, v in levels.items()}, unit=out,
                      notes=(f"levels from {source}",))


def _to_output(x: float, unit: str, plan: Plan, source: str) -> float:
    """``x`` in ``unit`` as the plan's output unit (electrical outputs via the scale factor)."""
    inst = plan.instrument
    if unit == inst.output_unit:
        return x
    try:
        return convert(x, unit, inst.output_unit)
    except UnitError:
        pass
    if inst.scale_factor:   # electrical output: scale_factor deg/h per output unit
        try:
            return convert(x, unit, "deg/h") / float(inst.scale_factor)
        except UnitError:
            pass
    raise NoiseFileError(f'{source}: noise in "{unit}" cannot be expressed in the plan\'s output '
                         f'unit "{inst.output_unit}"; give the levels in {inst.output_unit}')


def _from_allan(terms_doc: Mapping[str, Any], plan: Plan, tau0: float | None,
                source: str) -> NoiseModel:
    if tau0 is None or not tau0 > 0:
        raise NoiseFileError(f"{source}: mapping Allan terms needs the interval between readings; "
                             "give --sample-interval SECONDS (the plan has no sample rate)")
    terms = terms_doc.get("terms") if isinstance(terms_doc, Mapping) else None
    if not isinstance(terms, Mapping) or "N" not in terms:
        raise NoiseFileError(f"{source}: no IEEE 952 terms (N, B, K) in its noise_terms; run "
                             "inertest allan without --no-noise-id")
    kind = str(terms_doc.get("instrument", "gyro"))
    si_rate = "rad/s" if kind == "gyro" else "m/s^2"
    notes = [f"levels mapped from the IEEE Std 952 terms of {source} at tau0 = {tau0:g} s"]

    def term(name: str) -> float:
        t = terms.get(name) or {}
        if not t.get("resolved") or t.get("value_si") is None:
            if t:
                notes.append(f"{name} not resolved by the Allan fit: taken as 0 (upper bound "
                             f"{t.get('upper_bound')} {t.get('unit')})")
            return 0.0
        return float(t["value_si"])

    n_si, b_si, k_si = term("N"), term("B"), term("K")
    sigma = _to_output(n_si / math.sqrt(tau0), si_rate, plan, source)
    offset = _to_output(FLICKER_FLOOR * b_si, si_rate, plan, source)
    walk = _to_output(k_si * math.sqrt(tau0), si_rate, plan, source)
    if sigma <= 0:
        raise NoiseFileError(f"{source}: the angle random walk N is not resolved; the white "
                             "noise per reading is unknown (give a noise TOML with sigma)")
    return NoiseModel(sigma=sigma, position_offset=offset, random_walk=walk,
                      unit=plan.instrument.output_unit, notes=tuple(notes))


# --- prediction ------------------------------------------------------------------------------


def _with_procedure(plan: Plan, **changes: Any) -> Plan:
    return dataclasses.replace(plan, procedure=dataclasses.replace(plan.procedure, **changes))


def _noise_model_plan(plan: Plan, model: str) -> Plan:
    names = {f.name for f in dataclasses.fields(plan.procedure)}
    return _with_procedure(plan, noise_model=model) if "noise_model" in names else plan


def _simulate(plan: Plan, truth: Mapping[str, float]) -> tuple[dict[str, Any], list[str]]:
    """Noise-free data and the output columns (those the noise reaches)."""
    proc = procedure(plan.kind)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            clean = proc.simulate(plan, dict(truth), noise=0.0, rng=0)
        except PlanError as exc:
            if truth:
                raise
            raise NominalTruthError(
                f"{plan.kind}: plan-check simulates the test on a nominal instrument, and zero "
                f"coefficients do not make one ({exc}); give the nominal coefficients with "
                "--truth FILE (a [coefficients] table like examples/*/truth.toml; the scale "
                "factors suffice)") from None
        noisy = proc.simulate(plan, dict(truth), noise=1.0, rng=0)
    outputs = [k for k in clean if np.asarray(clean[k]).dtype.kind == "f"
               and not np.array_equal(np.asarray(clean[k]), np.asarray(noisy[k]))]
    return clean, outputs


def _positions(data: Mapping[str, Any], outputs: Sequence[str]) -> np.ndarray:
    """Position index of each row: runs of equal values of the non-output columns."""
    cols = [np.asarray(v) for k, v in data.items() if k not in outputs]
    n = len(next(iter(data.values())))
    cols = [c for c in cols if len(np.unique(c)) < n]   # time stamps are no position label
    change = np.zeros(n, dtype=bool)
    change[0] = True
    for c in cols:
        change[1:] |= c[1:] != c[:-1]
    return np.cumsum(change) - 1


def _fit(plan: Plan, data: Mapping[str, Any], sigma: float | None) -> Any:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return procedure(plan.kind).fit(plan, data, sigma=sigma)


def _noise(noise: NoiseModel, pos: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One series of the noise model over the rows (time order)."""
    n = pos.size
    e = rng.normal(0.0, noise.sigma, n)
    if noise.position_offset:
        e += rng.normal(0.0, noise.position_offset, int(pos.max()) + 1)[pos]
    if noise.random_walk:
        e += np.cumsum(rng.normal(0.0, noise.random_walk, n))
    if noise.flicker:
        f = np.fft.rfftfreq(2 * n)
        amp = np.r_[0.0, 1.0 / np.sqrt(f[1:])]
        z = rng.normal(size=f.size) + 1j * rng.normal(size=f.size)
        x = np.fft.irfft(z * amp, 2 * n)[:n]
        e += noise.flicker * x / x.std()
    return e


def predict_std(plan: Plan, noise: NoiseModel, *, truth: Mapping[str, float] | None = None,
                n_mc: int = 200, rng: np.random.Generator | int | None = 0,
                rel_error: float = 0.1,
                ) -> tuple[dict[str, tuple[float, str]], str, Any, int]:
    """Predicted Type-A std of every quantity the plan determines (module docstring, step 2).

    ``n_mc`` is the most Monte Carlo tests run; they stop earlier when every std's relative
    standard error is below ``rel_error`` (0 runs all ``n_mc``).

    Returns
    -------
    std : dict of str to (float, str)
        Std and unit per quantity.
    method : str
    nominal : procedure result
        The fit of the noise-free data (what the plan determines, and what it cannot).
    readings : int
    """
    truth = dict(truth or {})
    white_plan = _noise_model_plan(plan, "white")
    data, outputs = _simulate(white_plan, truth)
    if not outputs:
        raise PlanError(f"{plan.kind}: the simulated test has no noisy output column; "
                        "plan-check cannot predict its uncertainty")
    n = len(next(iter(data.values())))
    pos = _positions(data, outputs)
    counts = np.bincount(pos)
    nominal = _fit(white_plan, data, noise.sigma if noise.sigma > 0 else None)
    equal = bool(np.all(counts == counts[0]))
    if noise.white_only or (equal and noise.random_walk == 0 and noise.flicker == 0):
        eff = math.sqrt(noise.sigma**2 + counts[0] * noise.position_offset**2)
        fitted = nominal if eff == noise.sigma else _fit(white_plan, data, eff)
        std = {k: (float(s), u) for k, (_, s, u) in quantities_of(fitted).items()}
        method = ("closed form: white noise, cov = sigma^2 (A^T A)^-1" if noise.white_only else
                  f"closed form: position offsets, sigma_eff^2 = sigma^2 + n sigma_pos^2 "
                  f"(n = {int(counts[0])} readings per position)")
        return std, method, nominal, n
    model = ("flicker" if noise.flicker else "random-walk" if noise.random_walk
             else "position-offsets")
    mc_plan = _noise_model_plan(plan, model)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    samples: dict[str, list[float]] = {}
    units: dict[str, str] = {}
    done = 0
    err = math.inf
    while done < n_mc:
        for _ in range(min(_MC_BLOCK, n_mc - done)):
            done += 1
            d = dict(data)
            for c in outputs:
                d[c] = np.asarray(data[c], dtype=float) + _noise(noise, pos, gen)
            try:
                q = quantities_of(_fit(mc_plan, d, None))
            except InertestError:
                continue
            for k, (v, _, u) in q.items():
                samples.setdefault(k, []).append(v)
                units[k] = u
        if samples:
            err = max(std_relative_error(v) for v in samples.values())
            if done >= min(_MC_MIN, n_mc) and err < rel_error:
                break
    if not samples:
        raise PlanError(f"{plan.kind}: no simulated test could be fitted with the "
                        f"{model} noise model")
    std = {k: (float(np.std(v, ddof=1)), units[k]) for k, v in samples.items()}
    fitted = min(len(v) for v in samples.values())
    return std, (f"Monte Carlo: {fitted} simulated tests with the noise model added, fitted "
                 f"with noise_model = {model}; std = scatter of the estimates (relative "
                 f"standard error {err:.0%})"), nominal, n


#: Monte Carlo replicates per block, and the fewest before the relative error may stop it.
_MC_BLOCK = 25
_MC_MIN = 50


def std_relative_error(x: Sequence[float]) -> float:
    """Relative standard error of the sample std of ``x`` (inf for fewer than 4 values).

    ``SE(s) / s = 0.5 SE(s^2) / s^2`` with ``Var(s^2) = sigma^4 (kurtosis - (n - 3)/(n - 1)) / n``
    (the variance of the sample variance for any distribution with a fourth moment); ``1 /
    sqrt(2 (n - 1))`` for normal values.
    """
    a = np.asarray(x, dtype=float)
    n = a.size
    if n < 4:
        return math.inf
    d = a - a.mean()
    m2 = float(np.mean(d**2))
    if m2 == 0:
        return 0.0
    kurt = float(np.mean(d**4)) / m2**2
    return 0.5 * math.sqrt(max(kurt - (n - 3) / (n - 1), 0.0) / n)


def _tolerance(lim: Any) -> float:
    if lim.max_abs is not None:
        return float(lim.max_abs)
    if lim.minimum is not None and lim.maximum is not None:
        return 0.5 * float(lim.maximum - lim.minimum)
    return abs(float(lim.minimum if lim.minimum is not None else lim.maximum))


def _judge(label: str, plan: Plan, spec: Spec, noise: NoiseModel,
           equipment: Sequence[Equipment], truth: Mapping[str, float] | None, n_mc: int,
           tur: float, rng: np.random.Generator | int | None,
           rel_error: float) -> tuple[Prediction, Any]:
    std, method, nominal, n = predict_std(plan, noise, truth=truth, n_mc=n_mc, rng=rng,
                                          rel_error=rel_error)
    budget = uncertainty_budget(plan, nominal, equipment)
    checks = limit_checks(spec, std, nominal, budget, tur, kind=plan.kind)
    return Prediction(label, n, method, std, tuple(checks), plan), nominal


def limit_checks(spec: Spec, std: Mapping[str, tuple[float, str]], nominal: Any, budget: Any,
                 tur: float, *, kind: str, k: float = K_PREDICTED) -> list[LimitCheck]:
    """Each limit of ``spec`` against a predicted Type-A std and the budget's Type B, U = k u_c.

    The same rule and wording as a fit's verdicts: a model coefficient the plan does not
    determine is "not determined", a name that is no quantity of the procedure an error.
    """
    spec.check_quantities(list(std), model_names(nominal), kind=kind)
    checks = []
    for lim in spec.limits:
        tol = _tolerance(lim)
        if lim.quantity not in std:
            checks.append(LimitCheck(lim.quantity, lim.unit, lim.text(), lim.clause, tol,
                                     None, None, None, "not determined",
                                     not_determined_note(nominal, lim.quantity)))
            continue
        s_a, unit = std[lim.quantity]
        b = budget.quantities.get(lim.quantity)
        checks.append(_limit_check(lim, spec, s_a, b.type_b if b is not None else 0.0, unit,
                                   tur, k=k))
    return checks


def candidate_changes(plan: Plan) -> list[tuple[str, Plan]]:
    """Plan changes tried by :func:`check_plan`: longer dwell, more positions/repeats, more sets."""
    spec = plan.procedure
    fields = {f.name for f in dataclasses.fields(spec)}
    out: list[tuple[str, Plan]] = []
    for name in ("samples_per_position", "samples_per_rate", "revolutions", "duration_h",
                 "static_window_s", "face_duration_s"):
        if name in fields and getattr(spec, name) is not None:
            v = getattr(spec, name)
            for m in (2, 4):
                out.append((f"dwell x{m} ({name} = {v * m:g})", _with_procedure(plan, **{
                    name: type(v)(v * m)})))
    if "angles_deg" in fields and getattr(spec, "angles_deg", None):
        a = np.asarray(spec.angles_deg, dtype=float)
        step = 360.0 / a.size
        if np.allclose(np.diff(a), step):
            b = tuple(float(x) for x in a[0] + np.arange(2 * a.size) * step / 2)
            out.append((f"positions x2 ({2 * a.size} table angles)",
                        _with_procedure(plan, angles_deg=b)))
    for name in ("positions", "repeats"):
        v = getattr(spec, name, None) if name in fields else None
        if isinstance(v, int) and not isinstance(v, bool):
            out.append((f"{name} x2 ({name} = {2 * v})", _with_procedure(plan, **{name: 2 * v})))
    if plan.kind == "polar-tumble" and "mountings" in fields:
        from inertest.equipment.polar_axis_table import MOUNTINGS

        missing = [m for m in MOUNTINGS if m not in spec.mountings]
        if missing:
            out.append((f"all four mountings (add {', '.join(missing)})",
                        _with_procedure(plan, mountings=tuple(MOUNTINGS))))
    return out


def check_plan(plan: Plan, spec: Spec, noise: NoiseModel, *,
               equipment: Sequence[Equipment] = (), truth: Mapping[str, float] | None = None,
               tur: float = DEFAULT_TUR, n_mc: int = 200,
               rng: np.random.Generator | int | None = 0, rel_error: float = 0.1,
               nominal: str | None = None) -> PlanCheck:
    """Predict each limited quantity's U and whether the plan can verify its limit.

    Parameters
    ----------
    plan : Plan
    spec : Spec
        Limits to verify (:func:`inertest.quality.conformance.read_spec`).
    noise : NoiseModel
        The instrument's noise in the plan's output unit (:func:`read_noise`).
    equipment : sequence of Equipment
        Lab records of the plan's equipment (their Type B enters U).
    truth : mapping, optional
        Nominal coefficients to simulate with (default zero, with the plan's nominal scale
        factor where it has one; :class:`NominalTruthError` when the simulation needs a scale
        factor the plan does not give).
    tur : float
        Test uncertainty ratio: verifiable when U <= tolerance / tur (default 3).
    n_mc : int
        Most simulated tests of the Monte Carlo (non-white noise with unequal positions, random
        walk, flicker).
    rng : Generator, int or None
        For the Monte Carlo; an int (or None: 0) seeds every candidate plan alike.
    rel_error : float
        The Monte Carlo stops when every std's relative standard error is below this (0: always
        ``n_mc`` tests).
    nominal : str, optional
        Where ``truth`` came from, for the output (default: "zero coefficients ..." or "the
        given truth").

    Returns
    -------
    PlanCheck
        The plan's prediction and, when a limit is not verifiable, the cheapest verifying change.
    """
    if not tur >= 1:
        raise PlanError(f"the test uncertainty ratio must be >= 1, got {tur!r}")
    if not rel_error >= 0:
        raise PlanError(f"rel_error must be >= 0, got {rel_error!r}")
    if isinstance(rng, np.random.Generator):  # one stream for every candidate: a seed
        rng = int(rng.integers(2**63))
    elif rng is None:
        rng = 0
    base, fitted = _judge("plan as written", plan, spec, noise, equipment, truth, n_mc, tur,
                          rng, rel_error)
    rule = (f"verifiable when U (k = 2, Type A predicted + Type B of the equipment) <= "
            f"tolerance / {tur:g} (test uncertainty ratio {tur:g}:1); marginal when below the "
            "tolerance (a guarded pass, ILAC-G8:09/2019 w = U, only for an instrument well inside "
            "the limit); not verifiable when U >= tolerance")
    candidates: list[Prediction] = []
    suggestion = None
    if not base.ok and any(c.status != "not determined" for c in base.limits if
                           c.status != "verifiable"):
        wanted = {c.quantity for c in base.limits if c.status in ("marginal", "not verifiable")}
        for label, p in _by_cost(candidate_changes(plan), truth or {}):
            try:
                pred, _ = _judge(label, p, spec, noise, equipment, truth, n_mc, tur, rng,
                                 rel_error)
            except InertestError:
                continue
            candidates.append(pred)
            if all(x.status == "verifiable" for x in pred.limits if x.quantity in wanted):
                suggestion = pred
                break
    if nominal is None:
        nominal = ("the given truth" if truth else
                   "zero coefficients (the plan's nominal scale factor where it has one)")
    return PlanCheck(base, suggestion, tuple(candidates), noise, tur, rule,
                     tuple(fitted.identification.not_separable), nominal)


# --- sequences of a systematic IMU calibration -----------------------------------------------

#: Keys of an IMU noise file (plan-check of a systematic calibration), with their units: the
#: white noise of the gyros and accelerometers, and optionally a slow bias process.
IMU_NOISE_KEYS = {"gyro_arw_deg_rt_h": "deg/sqrt(h)", "acc_vrw_ug_rt_hz": "ug/sqrt(Hz)",
                  "gyro_rrw_deg_h_rt_h": "deg/h/sqrt(h)", "acc_rrw_ug_rt_s": "ug/sqrt(s)",
                  "gyro_bias_instability_deg_h": "deg/h", "acc_bias_instability_ug": "ug"}


@dataclass(frozen=True)
class ImuNoise:
    """Noise of a strapdown IMU for plan-check, in the units of :data:`IMU_NOISE_KEYS`.

    ``levels``: key -> value (the white keys required; a random walk or a bias instability
    optional, not both).
    """

    levels: Mapping[str, float]

    def to_dict(self) -> dict[str, object]:
        """JSON form, each level with its unit."""
        return {k: {"value": v, "unit": IMU_NOISE_KEYS[k]} for k, v in self.levels.items()}


def read_imu_noise(path: str | os.PathLike[str]) -> ImuNoise:
    """An IMU noise file (TOML or JSON) with the keys of :data:`IMU_NOISE_KEYS`.

    Raises
    ------
    NoiseFileError
        Missing file, unknown key, a level that is not a non-negative number, or a missing
        white level.
    """
    source = f"noise file {os.fspath(path)}"
    doc = _noise_document(path, source, f"a TOML with {', '.join(IMU_NOISE_KEYS)}")
    unknown = sorted(set(doc) - set(IMU_NOISE_KEYS))
    if unknown:
        raise NoiseFileError(f"{source}: unknown key(s) {', '.join(unknown)}"
                             f"{did_you_mean(unknown[0], IMU_NOISE_KEYS)}; an IMU noise file "
                             f"has {', '.join(IMU_NOISE_KEYS)}")
    levels = {k: _number(doc, k, source, None) for k in IMU_NOISE_KEYS if k in doc}
    for k in ("gyro_arw_deg_rt_h", "acc_vrw_ug_rt_hz"):
        if not levels.get(k, 0.0) > 0:
            raise NoiseFileError(f"{source} needs {k} [{IMU_NOISE_KEYS[k]}] > 0")
    rw = any(levels.get(k) for k in ("gyro_rrw_deg_h_rt_h", "acc_rrw_ug_rt_s"))
    fl = any(levels.get(k) for k in ("gyro_bias_instability_deg_h", "acc_bias_instability_ug"))
    if rw and fl:
        raise NoiseFileError(f"{source}: give a rate random walk or a bias instability, not "
                             "both (the systematic calibration models one slow process)")
    return ImuNoise(levels)


@dataclass(frozen=True)
class SequencePrediction:
    """Predicted std of every state of a systematic calibration's sequence, before the run.

    Attributes
    ----------
    label : str
        The plan (its file or name).
    turns : int
    duration_s : float
        Length of the sequence [s].
    std_a : dict of str to (float, str)
        Type-A std and unit per determined state (GLS covariance with the given noise).
    type_b : dict of str to float
        Combined Type-B std per state [its unit] (site gravity; the table's angle, rate and
        tilt do not enter: the method reads no table angle).
    not_determined : tuple of str
        What the sequence cannot determine, and why.
    """

    label: str
    turns: int
    duration_s: float
    std_a: dict[str, tuple[float, str]]
    type_b: dict[str, float]
    not_determined: tuple[str, ...]

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        return {"plan": self.label, "turns": self.turns,
                "duration": {"value": self.duration_s, "unit": "s"},
                "predicted_std_type_a": {k: {"std": v, "unit": u}
                                         for k, (v, u) in self.std_a.items()},
                "predicted_std_type_b": {k: {"std": v, "unit": self.std_a[k][1]}
                                         for k, v in self.type_b.items() if k in self.std_a},
                "not_determined": list(self.not_determined)}


def predict_sequence(plan: Plan, noise: ImuNoise, *, label: str = "plan",
                     truth: Mapping[str, float] | None = None,
                     equipment: Sequence[Equipment] = ()) -> SequencePrediction:
    """The std of every state a systematic calibration's sequence determines, before the run.

    The sequence is simulated noise-free on a nominal IMU (``truth``, default zero errors)
    and fitted with the noise levels given (the plan's noise keys set from ``noise``): the
    fit's covariance is then the generalised least squares prediction ``(J^T V^-1 J)^-1`` of
    :mod:`inertest.procedures.systematic`, ``V`` from the white and slow noise through the
    navigation equations (exact for the linearised problem; no Monte Carlo needed). Type B:
    :func:`inertest.quality.budget.uncertainty_budget` (the site gravity; the table's angle,
    rate and tilt errors do not enter, the gyros measure the turns).
    """
    if plan.kind != "systematic":
        raise PlanError(f"predict_sequence is for systematic plans, got {plan.kind}")
    levels = dict(noise.levels)
    given = {k: v for k, v in levels.items()
             if k in {f.name for f in dataclasses.fields(plan.procedure)}}
    model = "random-walk" if any(k.endswith(("rrw_deg_h_rt_h", "rrw_ug_rt_s"))
                                 and v for k, v in given.items()) else (
        "flicker" if any("instability" in k and v for k, v in given.items()) else "white")
    p = _with_procedure(plan, noise_model=model, **given)
    proc = procedure("systematic")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = proc.simulate(p, dict(truth or {}), noise=0.0, rng=0)
        fitted = proc.fit(p, data)
    std = {k: (float(s), u) for k, (_, s, u) in quantities_of(fitted).items()}
    budget = uncertainty_budget(p, fitted, equipment)
    type_b = {k: float(q.type_b) for k, q in budget.quantities.items()}
    motion = proc.motion(p)
    return SequencePrediction(label, len(plan.procedure.turns),
                              float(motion.duration_s) if motion is not None else 0.0,
                              std, type_b, tuple(fitted.identification.not_separable))


def judge_sequence(pred: SequencePrediction, spec: Spec, *, names: Sequence[str],
                   tur: float = DEFAULT_TUR) -> tuple[LimitCheck, ...]:
    """Whether a sequence's predicted U (k = 2, Type A and B) verifies each limit of ``spec``.

    The rule of :func:`check_plan`; ``names``: every state of the procedure (a limited one the
    sequence does not determine is "not determined", any other name an error).
    """
    spec.check_quantities(list(pred.std_a), list(names), kind="systematic")
    out = []
    for lim in spec.limits:
        tol = _tolerance(lim)
        if lim.quantity not in pred.std_a:
            out.append(LimitCheck(lim.quantity, lim.unit, lim.text(), lim.clause, tol, None,
                                  None, None, "not determined",
                                  "the sequence does not determine it (see not determined)"))
            continue
        s_a, unit = pred.std_a[lim.quantity]
        out.append(_limit_check(lim, spec, s_a, pred.type_b.get(lim.quantity, 0.0), unit, tur))
    return tuple(out)


def _limit_check(lim: Any, spec: Spec, s_a: float, u_b: float, unit: str, tur: float,
                 *, k: float = K_PREDICTED) -> LimitCheck:
    """The verdict on one limit from a Type-A and a Type-B std [``unit``] (module docstring).

    ``U = k sqrt(s_a^2 + u_b^2)``.
    """
    tol = _tolerance(lim)
    big_u = k * math.sqrt(s_a**2 + u_b**2)
    try:
        s_a_l, u_b_l, big_u_l = (convert(x, unit, lim.unit) for x in (s_a, u_b, big_u))
    except UnitError:
        raise PlanError(f'{spec.source}: limit on "{lim.quantity}" is in "{lim.unit}" but '
                        f'the result gives it in "{unit}"') from None
    status = ("verifiable" if big_u_l <= tol / tur else "marginal" if big_u_l < tol
              else "not verifiable")
    return LimitCheck(lim.quantity, lim.unit, lim.text(), lim.clause, tol, s_a_l, u_b_l,
                      big_u_l, status, f"U/tolerance = {big_u_l / tol:.3g}" if tol > 0 else "")


def _by_cost(changes: Sequence[tuple[str, Plan]], truth: Mapping[str, float]
             ) -> list[tuple[str, Plan]]:
    """The candidate plans, fewest readings first (a noise-free simulation counts them)."""
    costed = []
    for label, p in changes:
        try:
            data, _ = _simulate(p, truth)
        except InertestError:
            continue
        costed.append((len(next(iter(data.values()))), label, p))
    costed.sort(key=lambda c: c[0])  # stable: ties keep candidate_changes' order
    return [(label, p) for _, label, p in costed]


__all__ = ["DEFAULT_TUR", "FLICKER_FLOOR", "IMU_NOISE_KEYS", "ClauseCheck", "ImuNoise",
           "LimitCheck", "NoiseFileError", "NoiseModel", "NominalTruthError", "PlanCheck",
           "Prediction", "STATUSES", "SequencePrediction", "SeriesCheck", "SeriesTest",
           "candidate_changes", "check_plan", "check_series", "judge_sequence", "limit_checks",
           "predict_by_simulation", "predict_sequence", "predict_std", "read_imu_noise",
           "read_noise", "std_relative_error"]


# --- a series of tests (an acceptance campaign) -------------------------------------------------


def predict_by_simulation(plan: Plan, truth: Mapping[str, float], *, noise: float = 0.0,
                          n_mc: int = 200, rng: np.random.Generator | int | None = 0,
                          rel_error: float = 0.1, min_tests: int = _MC_MIN
                          ) -> tuple[dict[str, tuple[float, str]], str, Any, int]:
    """Predicted Type-A std of every quantity by simulating the whole test on the nominal unit.

    The procedure's own virtual instrument (:meth:`inertest.procedures.base.Procedure.
    simulate`) with ``truth``, which for the static acceptance tests carries the instrument's
    own noise (angle random walk, bias instability, rate random walk, turn-on std) and ``noise``
    white per reading [output unit]; each simulated test is fitted as data would be, and the
    scatter of the estimates is the prediction. Stops like :func:`predict_std`'s Monte Carlo.

    Returns
    -------
    std, method, nominal, readings
        As :func:`predict_std` (``nominal``: the first simulated test's fit).
    """
    proc = procedure(plan.kind)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    samples: dict[str, list[float]] = {}
    units: dict[str, str] = {}
    nominal: Any = None
    readings = 0
    done, err = 0, math.inf
    while done < n_mc:
        for _ in range(min(_MC_BLOCK, n_mc - done)):
            done += 1
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                data = proc.simulate(plan, dict(truth), noise=noise, rng=gen)
                try:
                    fitted = proc.fit(plan, data)
                except InertestError:
                    continue
            if nominal is None:
                nominal, readings = fitted, len(next(iter(data.values())))
            for k, (v, _, u) in quantities_of(fitted).items():
                samples.setdefault(k, []).append(v)
                units[k] = u
        if samples:
            most = max(len(v) for v in samples.values())
            err = max(std_relative_error(v) for v in samples.values() if len(v) >= most // 2)
            if done >= min(min_tests, n_mc) and err < rel_error:
                break
    if nominal is None:
        raise PlanError(f"{plan.kind}: no simulated test of the nominal unit could be fitted")
    most = max(len(v) for v in samples.values())   # a quantity resolved in half the tests
    std = {k: (float(np.std(v, ddof=1)), units[k]) for k, v in samples.items()
           if len(v) >= max(most // 2, 2)}
    return std, (f"Monte Carlo: {done} simulated tests of the nominal unit (its own noise from "
                 f"the truth, white {noise:g} per reading), fitted as data; std = scatter of "
                 f"the estimates (relative standard error {err:.0%})"), nominal, readings


@dataclass(frozen=True)
class SeriesTest:
    """A test of a series to predict: its name, plan, nominal unit, noise, clauses, equipment."""

    name: str
    plan: Plan
    truth: Mapping[str, float] | None
    noise: float
    verifies: tuple[str, ...]
    equipment: Sequence[Equipment] = ()


@dataclass(frozen=True)
class ClauseCheck:
    """Whether the planned series can verify one clause (one row per verifying test)."""

    clause_id: str
    test: str | None
    check: LimitCheck | None
    status: str
    note: str = ""

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        out: dict[str, object] = {"clause": self.clause_id, "test": self.test,
                                  "status": self.status, "note": self.note}
        if self.check is not None:
            c = self.check.to_dict()
            c["reference"] = c.pop("clause")      # the standard's clause; "clause" is the id
            out.update({k: v for k, v in c.items() if k != "status"})
        return out


@dataclass(frozen=True)
class SeriesCheck:
    """The outcome of :func:`check_series`: per test its prediction, per clause its status."""

    predictions: tuple[tuple[str, Prediction], ...]
    clauses: tuple[ClauseCheck, ...]
    tur: float
    rule: str

    @property
    def ok(self) -> bool:
        """True when the planned series can verify every clause."""
        return all(c.status == "verifiable" for c in self.clauses)

    def to_dict(self) -> dict[str, object]:
        """The ``plan-check`` JSON document of a campaign."""
        return {"kind": "plan-check-series", "rule": self.rule, "test_uncertainty_ratio": self.tur,
                "all_verifiable": self.ok, "clauses": [c.to_dict() for c in self.clauses],
                "tests": {name: p.to_dict() for name, p in self.predictions}}


def check_series(tests: Sequence[SeriesTest], spec: Spec, *, tur: float = DEFAULT_TUR,
                 n_mc: int = 100, rng: int = 0, rel_error: float = 0.15) -> SeriesCheck:
    """Which clauses of ``spec`` a planned series of tests can verify, before testing.

    Each test is simulated on its nominal unit (:func:`predict_by_simulation`), its limits
    (the clauses it verifies) judged as :func:`check_plan` judges them (U = 2 sqrt(Type A^2 +
    Type B^2) against tolerance / TUR). A clause no test verifies is "not verified".

    Raises
    ------
    PlanError
        A test without a nominal unit (truth), a clause a test names that the spec lacks.
    """
    if not tur >= 1:
        raise PlanError(f"the test uncertainty ratio must be >= 1, got {tur!r}")
    ids = [lim.clause_id for lim in spec.limits]
    predictions: list[tuple[str, Prediction]] = []
    rows: list[ClauseCheck] = []
    by_test: dict[str, dict[str, LimitCheck]] = {}
    for k, t in enumerate(tests):
        unknown = [v for v in t.verifies if v not in ids]
        if unknown:
            raise PlanError(f"test {t.name!r} verifies clause {unknown[0]!r}, which "
                            f"{spec.source} does not have{did_you_mean(unknown[0], ids)}")
        if not t.verifies:
            continue
        if t.truth is None:
            raise NominalTruthError(
                f"test {t.name!r}: plan-check simulates each test on the nominal unit; give "
                "truth = \"FILE\" in the campaign's [[test]] (or put truth.toml beside its "
                "plan): its coefficients and its own noise (ARW, bias_instability, ...)")
        sub = dataclasses.replace(spec, limits=tuple(
            lim for lim in spec.limits if lim.clause_id in t.verifies))
        std, method, nominal, n = predict_by_simulation(
            t.plan, t.truth, noise=t.noise, n_mc=n_mc, rng=rng + 7919 * k, rel_error=rel_error,
            min_tests=30)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            budget = uncertainty_budget(t.plan, nominal, t.equipment)
        # the coverage factor of the test's own degrees of freedom (few runs: large k)
        dof = int(getattr(nominal.identification, "dof", 0) or 0)
        cover = K_PREDICTED if dof <= 0 or dof > 1000 else float(
            scipy_stats_t_ppf(0.5 + COVERAGE / 2, dof))
        checks = limit_checks(sub, std, nominal, budget, tur, kind=t.plan.kind, k=cover)
        predictions.append((t.name, Prediction("plan as written", n, method, std,
                                               tuple(checks), t.plan)))
        by_test[t.name] = {lim.clause_id: c for lim, c in zip(sub.limits, checks, strict=True)}
    for lim in spec.limits:
        cid = lim.clause_id
        verifying = [t.name for t in tests if cid in t.verifies]
        if not verifying:
            rows.append(ClauseCheck(cid, None, None, "not verified",
                                    "no test of the campaign verifies this clause"))
        for name in verifying:
            c = by_test[name][cid]
            rows.append(ClauseCheck(cid, name, c, c.status, c.note))
    rule = (f"verifiable when U (Type A predicted by simulating the test on the nominal unit + "
            "Type B of the equipment; k of the test's degrees of freedom for 95.45 %) <= "
            f"tolerance / {tur:g}; marginal below the tolerance; not verifiable from it on; not "
            "verified: no test verifies the clause")
    return SeriesCheck(tuple(predictions), tuple(rows), tur, rule)


#: Coverage probability of a predicted U with few degrees of freedom (GUM G.3.2).
COVERAGE = 0.9545


def scipy_stats_t_ppf(p: float, dof: int) -> float:
    """Student's t quantile (``scipy.special.stdtrit``)."""
    from scipy.special import stdtrit

    return float(stdtrit(dof, p))
