"""The gyro and accelerometer channels of a :class:`~inertest.io.recordings.Recording`, in SI.

:func:`read_imu` returns an :class:`~inertest.io.imu_recording.ImuRecording` in memory.
:func:`spill_imu` is for records too long for that (:data:`STREAM_SAMPLES` and more, a day at
1 kHz is 86.4 M samples): it reads the recording once, block by block, and writes the time
stamps and every channel as float64 into a temporary folder (8 bytes per sample and channel,
4.8 GB for 24 h of 6 channels at 1 kHz), whence :class:`~inertest.io.raw_samples.SampleFile`
reads them back in slices; memory stays that of one block whatever the length. The folder is
removed when the :class:`SpilledImu` is closed.

Columns: those of a known IMU type (ROS ``sensor_msgs/msg/Imu``, PX4 ``sensor_combined`` /
``vehicle_imu``) without options, in rad/s and m/s^2; else the common names of
:mod:`inertest.io.imu_recording` or ``--gyro-columns``/``--accel-columns``, in the unit the
format states (TDMS ``unit_string``, a layout's ``unit``) or ``--gyro-unit``/``--accel-unit``.
Time: ROS header stamps (sec + nanosec; the bag's time when every stamp is zero), PX4
``timestamp`` [us], a TDMS waveform's increment, a layout's time field, or a common time column;
integer stamps are converted exactly (``(ns - ns[0]) * 1e-9``, as for tables).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypedDict, Unpack

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, InputError, UnitError
from inertest.io.imu_recording import (
    ACCEL_SETS,
    GYRO_SETS,
    TIME_NAMES,
    ImuRecording,
    _pick,
    _split,
)
from inertest.io.raw_samples import SampleFile
from inertest.io.recordings import (
    RECORDING_FORMATS,
    Recording,
    open_recording,
    recording_format,
)
from inertest.units import ACCEL_UNITS, RATE_UNITS

#: Records of this many samples and more are streamed (:func:`spill_imu`) by ``inertest noise``.
STREAM_SAMPLES = 1 << 22
#: Rate parts compared for a change of rate within one topic (mixed-rate records).
_RATE_PARTS = 8
_TIME_TO_NS = {"s": 1_000_000_000, "ms": 1_000_000, "us": 1_000, "ns": 1}
Progress = Callable[[int, int | None], None]


@dataclass(frozen=True)
class _Plan:
    gyro: tuple[str, ...]
    accel: tuple[str, ...]
    gyro_scale: tuple[float, ...]
    accel_scale: tuple[float, ...]
    time: tuple[str, ...]
    time_unit: str
    notes: tuple[str, ...]


def _names(rec: Recording) -> list[str]:
    if rec.names:
        return list(rec.names)
    first = next(iter(rec.batches()), None)  # a type known only from its first message
    if first is None:
        raise DataError(f"{rec.path} topic {rec.topic} has no samples; what the file holds: "
                        f"{rec.listing}")
    return list(first)


def _where(rec: Recording) -> str:
    return f"{rec.path}{f' topic {rec.topic}' if rec.topic else ''}"


def _scales(rec: Recording, cols: list[str], known: bool, option: str,
            table: dict[str, float], what: str) -> tuple[float, ...]:
    out = []
    for c in cols:
        # A message type states SI (REP 145); a unit option other than SI overrides it, for a
        # driver that publishes deg/s against the standard (the notes say so). It was ignored
        # silently: a 57.3x error in every density (found by an independent review).
        unit = option if known else (rec.units.get(c) or option)
        if unit not in table:
            raise UnitError(f"column {c!r} of {_where(rec)} is in {unit!r}, which is not a "
                            f"{what} unit ({', '.join(table)}); give --{what}-unit")
        out.append(table[unit])
    return tuple(out)


class ImuOptions(TypedDict, total=False):
    """The column and unit options of :func:`plan`, passed on by the readers below."""

    time_column: str | None
    time_unit: str
    gyro_columns: str | None
    accel_columns: str | None
    gyro_unit: str
    accel_unit: str


def plan(rec: Recording, *, time_column: str | None = None, time_unit: str = "auto",
         gyro_columns: str | None = None, accel_columns: str | None = None,
         gyro_unit: str = "rad/s", accel_unit: str = "m/s^2") -> _Plan:
    """Which columns are read, their factors to SI, and the time stamps (module docstring)."""
    names = _names(rec)
    g_given, a_given = _split(gyro_columns), _split(accel_columns)
    table = dict.fromkeys(names)  # the columns a set is looked for in (values unread)
    where = Path(_where(rec))
    gyro = (list(rec.gyro) if g_given is None and rec.gyro
            else _pick(table, g_given, GYRO_SETS, "gyro", where))  # type: ignore[arg-type]
    accel = (list(rec.accel) if a_given is None and rec.accel
             else _pick(table, a_given, ACCEL_SETS, "accel", where))  # type: ignore[arg-type]
    if not gyro and not accel:
        raise DataError(f"{_where(rec)}: no gyro or accelerometer columns found among "
                        f"{', '.join(names)}; name them with --gyro-columns and "
                        "--accel-columns")
    gs = _scales(rec, gyro, g_given is None and bool(rec.gyro), gyro_unit, RATE_UNITS, "gyro")
    acs = _scales(rec, accel, a_given is None and bool(rec.accel), accel_unit, ACCEL_UNITS,
                  "accel")
    spec = _split(time_column)
    unit = time_unit
    if spec is None and rec.time_columns:
        spec, unit = list(rec.time_columns), rec.time_unit
    elif spec is None:
        spec = next(([n] for n in TIME_NAMES if n in names), None)
    elif spec is not None:
        missing = [c for c in spec if c not in names]
        if missing:
            raise DataError(f"{_where(rec)} has no time column {missing[0]!r}; it has "
                            f"{', '.join(names)}: fix --time-column")
    if spec is not None and len(spec) > 2:
        raise InputError("--time-column takes one column, or two (seconds, nanoseconds)")
    typed = (rec.gyro or rec.accel) and g_given is None and a_given is None
    if typed and gs == (1.0,) * len(gs) and acs == (1.0,) * len(acs):
        units_note = "rad/s and m/s^2 (the message type's units)"
    elif typed:
        units_note = (f"read in {gyro_unit} and {accel_unit} as the unit options say, not in "
                      "the message type's rad/s and m/s^2 (REP 145)")
    else:
        units_note = "units " + ", ".join(f"{c}: {rec.units.get(c) or u}" for c, u in
                                          [*((c, gyro_unit) for c in gyro),
                                           *((c, accel_unit) for c in accel)])
    notes = [*rec.notes, f"gyro columns {', '.join(gyro) or '(none)'}; accelerometer columns "
             f"{', '.join(accel) or '(none)'}; {units_note}"]
    if spec:
        notes.append(f"time stamps from {', '.join(spec)}"
                     + (f" in {unit}" if len(spec) == 1 and unit != "auto" else ""))
    return _Plan(tuple(gyro), tuple(accel), gs, acs, tuple(spec or ()), unit, tuple(notes))


class _Clock:
    """Time stamps of consecutive batches as seconds from the first stamp (float64).

    Integer stamps (ROS sec + nanosec, ns, us) are kept as int64 nanoseconds and converted as
    ``(ns - ns0) * 1e-9``; float seconds as ``t - t0``.
    """

    def __init__(self, p: _Plan, rec: Recording) -> None:
        self.p = p
        self.rec = rec
        self.unit = p.time_unit
        self.zero: int | float | None = None
        self.bag_time = False

    def __call__(self, b: dict[str, NDArray]) -> NDArray[np.float64] | None:
        p = self.p
        if not p.time:
            return None
        if len(p.time) == 2:
            sec, nsec = b[p.time[0]], b[p.time[1]]
            if self.zero is None and "bag_time_ns" in b and not (np.any(sec) or np.any(nsec)):
                self.bag_time = True
            if self.bag_time:
                ns = np.asarray(b["bag_time_ns"], dtype=np.int64)
            else:
                ns = (np.asarray(sec, dtype=np.int64) * 1_000_000_000
                      + np.asarray(nsec, dtype=np.int64))
            return self._from_ns(ns)
        col = np.asarray(b[p.time[0]])
        if col.dtype.kind not in "fiu":
            raise DataError(f"time column {p.time[0]!r} of {_where(self.rec)} is not numeric")
        if self.unit == "auto":
            d = np.diff(col[np.isfinite(col)].astype(np.float64))
            med = float(np.median(d[d > 0])) if np.any(d > 0) else 0.0
            self.unit = "ns" if med > 100.0 else "s"
        if col.dtype.kind in "iu" and self.unit in _TIME_TO_NS:
            return self._from_ns(col.astype(np.int64) * _TIME_TO_NS[self.unit])
        if self.zero is None:
            self.zero = float(col[0])
        t = col.astype(np.float64) - self.zero
        return t if self.unit == "s" else t * (_TIME_TO_NS[self.unit] * 1e-9)

    def _from_ns(self, ns: NDArray[np.int64]) -> NDArray[np.float64]:
        if self.zero is None:
            self.zero = int(ns[0])
        return (ns - self.zero).astype(np.float64) * 1e-9

    def note(self) -> str | None:
        """What was assumed, when it was not the stamps asked for."""
        if self.bag_time:
            return ("every header stamp is zero: time from the bag's receive time "
                    "(bag_time_ns), which carries transport jitter")
        return None


def _channels(b: dict[str, NDArray], cols: tuple[str, ...], scale: tuple[float, ...],
              rec: Recording) -> NDArray[np.float64]:
    n = len(next(iter(b.values()))) if b else 0
    out = np.empty((n, len(cols)))
    for j, (c, f) in enumerate(zip(cols, scale, strict=True)):
        v = b[c]
        if v.dtype.kind not in "fiub":
            raise DataError(f"column {c!r} of {_where(rec)} is not numeric")
        out[:, j] = v
        if f != 1.0:
            out[:, j] *= f
    return out


def check_rate(t: NDArray[np.float64], rec: Recording) -> None:
    """Raise :class:`DataError` when the rate of the stamps changes within the record.

    The record is cut into :data:`_RATE_PARTS` parts and the median positive interval of each
    compared: more than 1.5x between two parts is a mixed-rate record (gaps do not move a
    median). The message names the rates, where it changes and the topics found.
    """
    n = t.size
    if n < 16 * _RATE_PARTS:
        return
    edges = np.linspace(0, n, _RATE_PARTS + 1).astype(int)
    meds = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        d = np.diff(t[a:b])
        d = d[d > 0]
        meds.append(float(np.median(d)) if d.size else math.nan)
    _mixed(meds, [float(t[a]) for a in edges[:-1]], rec)


def _mixed(meds: list[float], starts: list[float], rec: Recording) -> None:
    good = [(m, s) for m, s in zip(meds, starts, strict=True) if math.isfinite(m) and m > 0]
    if len(good) < 2:
        return
    lo, hi = min(m for m, _ in good), max(m for m, _ in good)
    if hi <= 1.5 * lo:
        return
    first = good[0][0]
    change = next(s for m, s in good if not 1 / 1.5 < m / first < 1.5)
    raise DataError(f"{_where(rec)} changes its rate: about {1 / first:.4g} Hz at the start, "
                    f"about {1 / next(m for m, s in good if s == change):.4g} Hz from t = "
                    f"{change:.6g} s (the Allan deviation needs one rate); what the file holds: "
                    f"{rec.listing}; record or cut one rate")


def read_imu(rec: Recording, **options: Unpack[ImuOptions]) -> ImuRecording:
    """The IMU channels of ``rec`` in memory, SI (module docstring); ``options`` as :func:`plan`."""
    p = plan(rec, **options)
    clock = _Clock(p, rec)
    ts, gs, acs = [], [], []
    for b in rec.batches([*p.gyro, *p.accel, *p.time, "bag_time_ns"]):
        if not b:
            continue
        t = clock(b)
        if t is not None:
            ts.append(t)
        gs.append(_channels(b, p.gyro, p.gyro_scale, rec))
        acs.append(_channels(b, p.accel, p.accel_scale, rec))
    if not gs or sum(len(g) for g in gs) == 0:
        raise DataError(f"{_where(rec)} has no samples; what the file holds: {rec.listing}")
    t_all = np.concatenate(ts) if ts else None
    if t_all is not None:
        check_rate(t_all, rec)
    note = clock.note()
    notes = [*p.notes, *([note] if note else [])]
    return ImuRecording(t_all, np.concatenate(gs), np.concatenate(acs), p.gyro, p.accel,
                        rec.rate_hz, rec.fmt, tuple(notes))


@dataclass
class SpilledImu:
    """A recording's IMU channels written to a temporary folder, read back in slices.

    ``t`` [s from the first stamp] and every entry of ``channels`` (gyros [rad/s], then
    accelerometers [m/s^2]) are :class:`~inertest.io.raw_samples.SampleFile` of float64.
    Use as a context manager (or call :meth:`close`): the folder is removed.
    """

    n: int
    t: SampleFile | None
    channels: list[SampleFile]
    gyro_names: tuple[str, ...]
    accel_names: tuple[str, ...]
    rate_hz: float | None
    fmt: str
    notes: tuple[str, ...]
    folder: Path = field(repr=False)

    def close(self) -> None:
        """Remove the temporary folder."""
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self) -> SpilledImu:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def spill_imu(rec: Recording, *, progress: Progress | None = None,
              folder: str | None = None, **options: Unpack[ImuOptions]) -> SpilledImu:
    """Read ``rec`` once, block by block, into float64 files in a temporary folder.

    ``progress(samples_done, total_or_None)`` is called after each block. Memory: one block.
    The per-part rate check of :func:`check_rate` runs on per-block medians.
    """
    p = plan(rec, **options)
    clock = _Clock(p, rec)
    tmp = Path(tempfile.mkdtemp(prefix="inertest-stream-", dir=folder))
    names = [*p.gyro, *p.accel]
    try:
        files = [open(tmp / f"ch{j}.f64", "wb") for j in range(len(names))]  # noqa: SIM115
        tfile = open(tmp / "t.f64", "wb") if p.time else None  # noqa: SIM115
        n = 0
        meds: list[float] = []
        starts: list[float] = []
        try:
            for b in rec.batches([*p.gyro, *p.accel, *p.time, "bag_time_ns"]):
                if not b:
                    continue
                t = clock(b)
                data = np.hstack([_channels(b, p.gyro, p.gyro_scale, rec),
                                  _channels(b, p.accel, p.accel_scale, rec)])
                for j, fh in enumerate(files):
                    np.ascontiguousarray(data[:, j]).tofile(fh)
                if t is not None and tfile is not None:
                    t.tofile(tfile)
                    d = np.diff(t)
                    d = d[d > 0]
                    if d.size:
                        meds.append(float(np.median(d)))
                        starts.append(float(t[0]))
                n += data.shape[0]
                if progress is not None:
                    progress(n, rec.count)
        finally:
            for fh in files:
                fh.close()
            if tfile is not None:
                tfile.close()
        if n == 0:
            raise DataError(f"{_where(rec)} has no samples; what the file holds: "
                            f"{rec.listing}")
        if len(meds) >= 2:
            _mixed(meds, starts, rec)
        f8 = np.dtype("<f8")
        note = clock.note()
        notes = [*p.notes, *([note] if note else []),
                 f"streamed: {n} samples decoded once into temporary float64 files, analysed "
                 "in blocks"]
        return SpilledImu(n, SampleFile(tmp / "t.f64", f8, 0, n) if p.time else None,
                          [SampleFile(tmp / f"ch{j}.f64", f8, 0, n) for j in range(len(names))],
                          p.gyro, p.accel, rec.rate_hz, rec.fmt, tuple(notes), tmp)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def recording_of(path: Path, *, fmt: str = "auto", topic: str | None = None,
                 layout: str | os.PathLike[str] | None = None,
                 columns_given: bool = False) -> Recording | None:
    """The recording ``path`` is, or None for a table or PSINS text.

    ``fmt``: ``"auto"`` or one of :data:`RECORDING_FORMATS`; tables and PSINS text are read by
    :mod:`inertest.io.imu_recording`.
    """
    if fmt not in ("auto", *RECORDING_FORMATS):
        return None
    if fmt == "auto" and recording_format(path, layout=layout) is None:
        return None
    return open_recording(path, topic=topic, layout=layout, imu=not columns_given,
                          fmt=None if fmt == "auto" else fmt)


def open_imu(path: str | os.PathLike[str], *, fmt: str = "auto", topic: str | None = None,
             layout: str | os.PathLike[str] | None = None, stream_from: int | None = None,
             progress: Progress | None = None, **options: Unpack[ImuOptions]
             ) -> ImuRecording | SpilledImu:
    """An IMU recording in memory, or spilled for streaming from ``stream_from`` samples on.

    ``options`` as :func:`inertest.io.imu_recording.read_imu_recording` (columns, units).
    Tables and PSINS text are read in memory; recordings whose length is known before reading
    (bags, TDMS, binary records) are spilled (:func:`spill_imu`) when that long.
    """
    from inertest.io.imu_recording import read_imu_recording

    p = Path(path)
    given = options.get("gyro_columns") is not None or options.get("accel_columns") is not None
    rec = recording_of(p, fmt=fmt, topic=topic, layout=layout, columns_given=given) \
        if p.exists() else None
    if rec is None:
        return read_imu_recording(p, fmt=fmt, topic=topic, layout=layout, **options)
    if rec.count is not None and rec.count >= (STREAM_SAMPLES if stream_from is None
                                               else stream_from):
        return spill_imu(rec, progress=progress, **options)
    return read_imu(rec, **options)
