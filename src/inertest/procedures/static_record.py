"""Shared parts of the static acceptance tests: records of an instrument at rest, in SI.

The turn-on repeatability, warm-up and in-run stability tests (IEEE Std 952-1997 for
single-axis fibre-optic gyros, IEEE Std 1293-2018 for linear accelerometers) all read the
output of an instrument at rest: a gyro (output in a rate unit, its bias in deg/h) or an
accelerometer (output in a specific-force unit, its bias in ug). The input the instrument
feels at rest (the Earth rate along the gyro's input axis, gravity along the accelerometer's)
is removed, so the bias is the output at zero input (IEEE Std 528 terminology: bias, the
output at zero input). Nothing here is a procedure (no ``PROCEDURE``): the procedures import
it.

Data columns: ``output`` (the reading [output unit], one row per sample, in time order), an
optional ``run`` label (one label per power-on run, its rows together) and an optional time
column ``time_s`` (checked against the plan's ``sample_rate_hz``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from inertest.earth import earth_rate_enu, specific_force_enu
from inertest.equipment.rate_table import direction_vector
from inertest.errors import DataError, PlanError
from inertest.noise.identification import simulate_noise
from inertest.noise.record_noise import RecordNoise
from inertest.plan import Field, Instrument, Plan
from inertest.procedures.spec import require_columns
from inertest.units import (
    ACCEL_UNITS,
    DEG_PER_H_TO_RAD_PER_S,
    DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S,
    M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S,
    MICRO_G_TO_M_PER_S2,
    RATE_UNITS,
)

#: Instrument kinds a static gyro test accepts (one axis read as a rate).
GYRO_KINDS = ("rate-gyro", "sdf-gyro")
#: Instrument kinds a static accelerometer test accepts.
ACCEL_KINDS = ("accelerometer",)

#: Plan fields every static test shares.
STATIC_FIELDS = (
    Field("sample_rate_hz", positive=True, unit="Hz", doc="readings per second"),
    Field("bias_time_scale", default=2.0, minimum=1.0,
          doc="flicker from 1/(2 x this x the record's duration): the bias of a record is its "
              "mean over this many record lengths"),
)


@dataclass(frozen=True)
class Sensor:
    """How a static test reads its instrument: SI per output unit and the engineering units.

    Attributes
    ----------
    kind : {"gyro", "accelerometer"}
    si_per_output : float
        SI (rad/s or m/s^2) per output unit.
    bias_unit : str
        ``deg/h`` (gyro) or ``ug`` (accelerometer).
    si_per_bias_unit : float
    random_walk_unit, si_per_random_walk_unit : str, float
        Angle random walk ``deg/sqrt(h)`` or velocity random walk ``m/s/sqrt(h)``.
    """

    kind: str
    si_per_output: float
    output_unit: str
    bias_unit: str
    si_per_bias_unit: float
    random_walk_unit: str
    si_per_random_walk_unit: float

    @property
    def rate_random_walk_unit(self) -> str:
        """Unit of the rate random walk K: ``deg/h/sqrt(h)`` or ``ug/sqrt(h)``."""
        return "deg/h/sqrt(h)" if self.kind == "gyro" else "ug/sqrt(h)"

    @property
    def si_per_rate_random_walk_unit(self) -> float:
        """SI value of one unit of :attr:`rate_random_walk_unit`."""
        return self.si_per_bias_unit / math.sqrt(3600.0)


def sensor_of(instrument: Instrument, kind: str) -> Sensor:
    """The sensor of a static test: a gyro with a rate output or an accelerometer.

    Raises
    ------
    PlanError
        Another instrument kind, or an output that is not a rate (gyro) or a specific force
        (accelerometer): a static test reads a calibrated output.
    """
    unit = instrument.output_unit
    if instrument.kind in GYRO_KINDS:
        if unit not in RATE_UNITS:
            raise PlanError(
                f'{kind} reads a calibrated rate: [instrument] output_unit must be one of '
                f'{", ".join(RATE_UNITS)} for a gyro, got "{unit}" (apply the scale factor '
                "first, or test it on a rate table)")
        return Sensor("gyro", RATE_UNITS[unit], unit, "deg/h", DEG_PER_H_TO_RAD_PER_S,
                      "deg/sqrt(h)", DEG_PER_SQRT_H_TO_RAD_PER_SQRT_S)
    if instrument.kind in ACCEL_KINDS:
        if unit not in ACCEL_UNITS:
            raise PlanError(
                f'{kind} reads a calibrated specific force: [instrument] output_unit must be '
                f'one of {", ".join(ACCEL_UNITS)} for an accelerometer, got "{unit}"')
        return Sensor("accelerometer", ACCEL_UNITS[unit], unit, "ug", MICRO_G_TO_M_PER_S2,
                      "m/s/sqrt(h)", M_PER_S_PER_SQRT_H_TO_M_PER_S_PER_SQRT_S)
    raise PlanError(
        f'{kind} tests a single-axis gyro or accelerometer at rest, but [instrument] kind is '
        f'"{instrument.kind}"; use one of {", ".join((*GYRO_KINDS, *ACCEL_KINDS))} (one axis '
        "of a triad: one plan per axis)")


def read_axis(params: Mapping[str, object], key: str = "input_axis") -> str | tuple[float, ...]:
    """A plan's input axis: an ENU letter (E W N S U D) or three numbers; validated now."""
    given = params.get(key, "U")
    axis: str | tuple[float, ...] = (given if isinstance(given, str)
                                     else tuple(given))  # type: ignore[arg-type]
    try:
        direction_vector(axis)
    except Exception as exc:  # noqa: BLE001 - one message for every malformed axis
        raise PlanError(f"[procedure] {key}: {exc}") from None
    return axis


def input_at_rest(plan: Plan, sensor: Sensor, axis: str | Sequence[float]) -> float:
    """What the instrument feels at rest along ``axis`` [SI]: Earth rate or gravity.

    Gyro: ``W_ie . a`` (ENU, WGS-84 Earth rate); accelerometer: ``g a_up`` (the specific
    force at rest is ``+g`` up, the plan's site gravity).
    """
    a = direction_vector(axis)
    if sensor.kind == "gyro":
        return float(a @ earth_rate_enu(plan.site.latitude_rad))
    return float(a @ specific_force_enu(plan.site.gravity_m_s2))


@dataclass(frozen=True)
class Runs:
    """Static readings split into power-on runs (rows of a run together, runs in time order).

    ``labels`` of the runs, ``values`` per run [SI, the input at rest removed], ``start`` the
    first data row of each run (1-based, for messages).
    """

    labels: tuple[str, ...]
    values: tuple[NDArray[np.float64], ...]
    start: tuple[int, ...]

    @property
    def lengths(self) -> NDArray[np.intp]:
        """Readings of each run."""
        return np.array([v.size for v in self.values], dtype=np.intp)


def read_runs(data: Mapping[str, object], *, procedure: str, sensor: Sensor, at_rest: float,
              settle_readings: int = 0, need_run: bool = False) -> Runs:
    """The ``output`` column in SI, split by the ``run`` column (one run when there is none).

    Parameters
    ----------
    settle_readings : int
        Readings left out at the start of each run (the warm-up).
    need_run : bool
        Require a ``run`` column.

    Raises
    ------
    DataError
        Missing columns, NaN, a run whose rows are not together, a run with too few readings.
    """
    has_run = "run" in data
    if need_run and not has_run:
        raise DataError(
            f"{procedure} data need a run column (the power-on run of each reading, e.g. "
            f"run = 1, 2, ...) to tell the turn-ons apart (found: {', '.join(map(str, data))})")
    cols = require_columns(data, ("output",), ("run",) if has_run else (), procedure=procedure)
    y = cols["output"] * sensor.si_per_output - at_rest
    if not has_run:
        labels_row = np.full(y.size, "run 1")
    else:
        labels_row = cols["run"]
    change = np.ones(y.size, dtype=bool)
    change[1:] = labels_row[1:] != labels_row[:-1]
    starts = np.flatnonzero(change)
    names = labels_row[starts]
    seen: dict[str, int] = {}
    for k, name in enumerate(names):
        if name in seen:
            raise DataError(
                f'{procedure} data: the rows of run "{name}" are not together (rows from data '
                f"row {starts[seen[name]] + 1} and again from row {starts[k] + 1}); sort the "
                "rows by run, then time")
        seen[str(name)] = k
    ends = np.append(starts[1:], y.size)
    t = np.asarray(data["time_s"], dtype=float) if "time_s" in data else None
    values, begin = [], []
    for s, e, name in zip(starts, ends, names, strict=True):
        if t is not None:  # within a run the clock runs forward (a run may restart it)
            bad = np.flatnonzero(~(np.diff(t[s:e]) > 0))
            if bad.size:
                i = int(s + bad[0] + 1)
                raise DataError(
                    f'{procedure} data: in run "{name}" the time_s column does not increase at '
                    f"data row {i + 1} ({t[i - 1]:.9g} s, then {t[i]:.9g} s; {bad.size} such "
                    "step(s)): remove duplicated rows and sort each run by time")
        v = y[s + settle_readings:e]
        if v.size < 16:
            raise DataError(
                f'{procedure} data: run "{name}" has {v.size} reading(s) after the '
                f"{settle_readings} left out for settling; at least 16 are needed (an Allan "
                "variance over two octaves): record longer runs or shorten settle_s")
        values.append(v)
        begin.append(int(s + 1))
    return Runs(tuple(str(n) for n in names), tuple(values), tuple(begin))


def c4(n: int) -> float:
    """``E[s] / sigma`` for the sample standard deviation of ``n`` normal values (n >= 2)."""
    return math.exp(math.lgamma(n / 2.0) - math.lgamma((n - 1) / 2.0)) * math.sqrt(2.0 / (n - 1))


def std_of_std(s: float, n: int) -> float:
    """Standard uncertainty of a sample standard deviation ``s`` of ``n`` normal values.

    ``sigma sqrt(1 - c4^2)`` with ``sigma`` estimated as ``s / c4`` (the exact standard
    deviation of ``s`` for normal data; about ``s / sqrt(2 (n - 1))`` for many values).
    """
    c = c4(n)
    return float(s * math.sqrt(max(1.0 - c * c, 0.0)) / c)


def chi2_std_interval(s: float, dof: int, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided interval of a standard deviation ``s`` with ``dof`` degrees of freedom.

    ``[s sqrt(dof / chi2_{1-a/2}), s sqrt(dof / chi2_{a/2})]`` (normal data).
    """
    from scipy.special import chdtri

    a = 1.0 - confidence
    return (float(s * math.sqrt(dof / chdtri(dof, a / 2.0))),
            float(s * math.sqrt(dof / chdtri(dof, 1.0 - a / 2.0))))


def noise_term_block(terms: Mapping[str, Mapping[str, object]]) -> dict[str, object]:
    """The in-run noise terms of the Allan fit as JSON (N, B, K; Q and the ramp left out)."""
    names = {"N": "random walk (angle / velocity)", "B": "bias instability",
             "K": "rate random walk"}
    out: dict[str, object] = {}
    for k, label in names.items():
        t = terms.get(k)
        if t is None:
            continue
        out[k] = {"description": label, "resolved": t.get("resolved"), "value": t.get("value"),
                  "std": t.get("std"), "upper_bound": t.get("upper_bound"),
                  "unit": t.get("unit")}
    return out


def with_allan_check(doc: dict[str, object], noise: RecordNoise) -> dict[str, object]:
    """``doc`` with a check of the five-term Allan model of the in-run noise (and its message)."""
    checks = doc.get("checks")
    entry: dict[str, object] = {
        "name": "in-run noise: five-term Allan model (IEEE Std 952-1997 Annex C)",
        "verdict": "consistent" if noise.fits else "model does not fit",
        "detail": noise.verdict,
        "message": None if noise.fits else (
            "the in-run noise is not described by the five-term Allan model "
            f"({noise.verdict}); the in-run uncertainties rest on it: check the record for "
            "steps, trends or vibration"),
    }
    if isinstance(checks, list):
        checks.append(entry)
    messages = doc.get("messages")
    if not noise.fits and isinstance(messages, list) and entry["message"] not in messages:
        messages.append(entry["message"])
    return doc


def in_run_noise(truth: Mapping[str, float], sensor: Sensor, n: int, rate_hz: float,
                 rng: np.random.Generator) -> NDArray[np.float64]:
    """IEEE 952 noise of a virtual instrument over ``n`` readings [SI] from the truth's terms."""
    arw = float(truth.get("ARW", 0.0)) * sensor.si_per_random_walk_unit
    b = float(truth.get("bias_instability", 0.0)) * sensor.si_per_bias_unit
    k = float(truth.get("RRW", 0.0)) * sensor.si_per_rate_random_walk_unit
    if arw == b == k == 0.0:
        return np.zeros(n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate_noise(n, rate_hz, n_rw=arw, b=b, k=k, rng=rng)


def with_white(noise: RecordNoise, sigma_si: float) -> RecordNoise:
    """``noise`` with its white term set to a known ``sigma`` per reading (no uncertainty)."""
    p = noise.p.copy()
    p[1] = sigma_si**2 / noise.rate_hz
    cov = noise.cov.copy()
    cov[1, :] = cov[:, 1] = 0.0
    return replace(noise, p=p, cov=cov)


def read_static(plan: Plan, data: Mapping[str, object], kind: str, *, need_run: bool = False
                ) -> tuple[Runs, Sensor, float]:
    """A static test's runs in SI, its sensor and the input at rest [SI].

    The input at rest is removed and ``settle_s`` left out at the start of each run, from a plan
    whose procedure has ``input_axis``, ``settle_s`` and ``sample_rate_hz``.
    """
    spec = plan.procedure
    sensor = sensor_of(plan.instrument, kind)
    at_rest = input_at_rest(plan, sensor, spec.input_axis)
    settle = int(round(spec.settle_s * spec.sample_rate_hz))
    runs = read_runs(data, procedure=kind, sensor=sensor, at_rest=at_rest,
                     settle_readings=settle, need_run=need_run)
    return runs, sensor, at_rest


def noise_of(records: Sequence[NDArray[np.float64]], plan: Plan, sensor: Sensor,
             sigma: float | None) -> RecordNoise:
    """The records' noise from their pooled Allan variance.

    A given ``sigma`` per reading [output unit] replaces the fitted white noise (with no
    uncertainty).
    """
    from inertest.noise.record_noise import fit_record_noise
    from inertest.procedures.spec import known_sigma

    spec = plan.procedure
    noise = fit_record_noise(records, float(spec.sample_rate_hz), instrument=sensor.kind,
                             bias_time_scale=spec.bias_time_scale)
    if sigma is None:
        return noise
    s_si = known_sigma(sigma, sensor.si_per_output)
    assert s_si is not None
    return with_white(noise, s_si)
