"""Input checks and simulated noise shared by the procedures (columns, plan keys, counts)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, PlanError
from inertest.plan import did_you_mean

#: Largest magnitude accepted as a reading: beyond it, squares and sums overflow double
#: precision, and no instrument output (counts included) comes near it.
MAX_READING = 1e100


def require_columns(
    data: Mapping[str, object], numeric: Sequence[str], text: Sequence[str], *, procedure: str
) -> dict[str, NDArray]:
    """Return the named columns as arrays, checking presence, length and finiteness."""
    missing = [c for c in (*text, *numeric) if c not in data]
    if missing:
        raise DataError(
            f"{procedure} data lacks column(s) {', '.join(missing)}; it needs "
            f"{', '.join((*text, *numeric))} (found: {', '.join(map(str, data)) or 'none'})"
        )
    out: dict[str, NDArray] = {}
    n = None
    for c in numeric:
        try:
            a = np.asarray(data[c], dtype=float)
        except (TypeError, ValueError):
            raise DataError(f'column "{c}" must be numeric') from None
        # Good data pass on the extremes (NaN propagates and compares False): no temporary of
        # the column's size, as abs(a) <= MAX_READING made.
        if a.size == 0 or (-MAX_READING <= np.min(a) and np.max(a) <= MAX_READING):
            out[c] = a
            continue
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise DataError(
                f'column "{c}" has {bad.size} NaN/inf value(s) (first at data row {bad[0] + 1}); '
                "remove or repair those rows"
            )
        huge = np.flatnonzero(np.abs(a) > MAX_READING)
        if huge.size:
            raise DataError(
                f'column "{c}" has {huge.size} value(s) beyond {MAX_READING:g} (first at data '
                f"row {huge[0] + 1}: {a[huge[0]]:g}); no instrument reads that: repair those rows"
            )
        out[c] = a
    for c in text:
        out[c] = np.asarray(data[c]).astype(str, copy=False)
    lengths = {c: len(a) for c, a in out.items()}
    n = next(iter(lengths.values()))
    if any(v != n for v in lengths.values()):
        raise DataError(f"columns have different lengths: {lengths}")
    if n == 0:
        raise DataError(f"{procedure} data has no rows")
    return out


def check_samples_per_position(value: object) -> int:
    """Validate ``samples_per_position`` (a positive integer)."""
    if not isinstance(value, int) or isinstance(value, bool) or value < 1:
        raise PlanError(f"samples_per_position must be a positive integer, got {value!r}")
    return value


def check_no_unknown_keys(params: Mapping[str, object], known: Sequence[str], kind: str) -> None:
    """Reject misspelt procedure parameters instead of silently using defaults."""
    unknown = sorted(set(params) - set(known) - {"kind"})
    if unknown:
        raise PlanError(
            f"[procedure] of kind {kind} has unknown parameter(s) {', '.join(unknown)}"
            f"{did_you_mean(unknown[0], known)}; known: {', '.join(known)}"
        )


def noise_samples(
    n: int, sigma: float, rng: np.random.Generator | int | None
) -> NDArray[np.float64]:
    """White Gaussian noise of standard deviation ``sigma`` (zero when sigma is 0)."""
    if not np.isfinite(sigma) or sigma < 0:
        raise PlanError(f"noise sigma must be finite and >= 0, got {sigma}")
    gen = np.random.default_rng(rng)
    return gen.normal(0.0, sigma, size=n) if sigma > 0 else np.zeros(n)


def known_sigma(sigma: float | None, si_per_output_unit: float) -> float | None:
    """A user-given noise level per reading [output unit] in SI; None stays None."""
    if sigma is None:
        return None
    if not np.isfinite(sigma) or sigma <= 0:
        raise PlanError(f"noise sigma must be finite and positive, got {sigma}")
    s = float(sigma) * si_per_output_unit
    if not (math.isfinite(s * s) and s * s > 0):  # variances are computed with it
        size, what = ("large", "overflows") if s > 1 else ("small", "underflows to 0")
        raise PlanError(f"noise sigma {sigma:g} (output unit) is too {size} to compute with (its "
                        f"square {what}); give the noise per reading in the plan's output unit")
    return s


#: Names of a time column [s] that :func:`check_sample_rate` compares with the plan's rate.
TIME_COLUMNS = ("t_s", "time_s", "time", "t")


def check_sample_rate(
    columns: Mapping[str, NDArray], sample_rate_hz: float, *, source: str = "data",
    tolerance: float = 0.05,
) -> None:
    """Refuse a plan's sample rate that the data's own time column contradicts.

    A rate 10 times too low silently makes every integral over the samples (the Ferraris
    turns) 10 times too large, and so the gyro scale factors. The median step of the first
    column in :data:`TIME_COLUMNS` [s] must match ``1 / sample_rate_hz`` within ``tolerance``
    (relative); steps that are not positive (a new segment restarting its clock) are ignored,
    unless most steps are negative: a time column running backwards is refused as such.
    Data without a time column are not checked.

    Raises
    ------
    DataError
        Naming both rates and the fix.
    """
    name = next((c for c in TIME_COLUMNS if c in columns), None)
    if name is None or not (np.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        return
    t = np.asarray(columns[name])
    if t.dtype.kind not in "fiu" or t.size < 3:
        return
    dt = np.diff(np.asarray(t, dtype=float))
    forward = dt > 0  # NaN steps are neither
    n_back = np.count_nonzero(dt < 0)
    if n_back > np.count_nonzero(forward):  # restarts of the clock are few; this is most
        back = np.flatnonzero(dt < 0)
        raise DataError(
            f"{source}: the time column {name!r} runs backwards ({n_back} of {dt.size} steps "
            f"are negative, the first at data row {int(back[0]) + 2}); sort the rows by time, "
            "or fix the time column")
    if not np.isfinite(np.max(dt, initial=0.0, where=forward)):
        forward &= np.isfinite(dt)
    if not forward.all():
        dt = dt[forward]
    if dt.size < 2:
        return
    step = float(np.median(dt, overwrite_input=True))  # dt is this function's own
    rate = 1.0 / step
    if abs(rate * (1.0 / sample_rate_hz) - 1.0) > tolerance:
        raise DataError(
            f"{source}: the plan's sample_rate_hz = {sample_rate_hz:g} Hz, but the time column "
            f"{name!r} steps by {step:.6g} s ({rate:.6g} Hz); fix sample_rate_hz in the plan "
            "(or the time column)")


#: A time step longer than this many times the median step is a gap in the recording.
GAP_STEP_FACTOR = 2.5


def check_time_gaps(time_s: NDArray, *, name: str = "t_s", source: str = "data",
                    factor: float = GAP_STEP_FACTOR) -> None:
    """Refuse a recording whose time column jumps by more than ``factor`` median steps.

    Procedures that integrate the rate between static intervals need continuous samples: a
    gap hides a rotation that no sample measured. A single dropped sample (two steps) passes.

    Raises
    ------
    DataError
        Naming the column, the time and length of the first gap, and the fix.
    """
    t = np.asarray(time_s, dtype=float)
    if t.size < 3:
        return
    dt = np.diff(t)
    step = float(np.median(dt))
    if not (np.isfinite(step) and step > 0):
        return
    gaps = np.flatnonzero(dt > factor * step)
    if gaps.size:
        k = int(gaps[0])
        raise DataError(
            f"{source}: column {name!r} has {gaps.size} gap(s) in time, the first of "
            f"{dt[k]:.6g} s after t = {t[k]:.6g} s (the median step is {step:.6g} s); the "
            "integration between static intervals needs continuous samples: record again, "
            "or cut the recording at the gap")
