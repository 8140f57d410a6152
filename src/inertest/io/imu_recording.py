"""IMU recordings (tables, ROS-style time stamps, the PSINS text format) -> rates in SI.

:func:`read_imu_recording` returns an :class:`ImuRecording`: time stamps [s] from the first one,
angular rates [rad/s] and specific forces [m/s^2], one column per axis. Only unit scaling is
done here; checks and statistics are in :mod:`inertest.noise.imu`.

Tables (CSV, Parquet, HDF5) name their columns; common names are found without options
(``gyr_x``, ``gyro_x``, ``gx``, ``wx``, ``angular_velocity.x``, ROS ``field.angular_velocity.x``,
and the same for ``acc``/``accel``/``a``/``linear_acceleration``). Time stamps: one column in
seconds or nanoseconds (ROS ``%time``, ``header.stamp``, ``timestamp``), or two columns
``secs,nsecs`` (ROS ``header.stamp.secs`` and ``.nsecs``). Integer nanosecond stamps are read
exactly (a float64 would round a stamp since 1970 to 256 ns).

PSINS text format (Yan Gongmin's PSINS toolbox, ``imufile``): ``%`` comment lines, then three
parameter lines ``pitch0 roll0 yaw0 [deg] VE0 VN0 VU0 [m/s]``, ``lat0 lon0 [deg] h0 [m] t0 [s]
sampling-interval [ms] g [m/s^2]``, ``gf_x gf_y gf_z [arcsec] af_x af_y af_z [ug*s]`` (the least
significant bits), then one line per sample of integer increments dtheta_x,y,z dv_x,y,z (and
an optional time [s]). Rates are increment x LSB / interval. The toolbox's micro-g is
1e-6 x its ``glv.g0`` = :data:`PSINS_G0` = 9.7803267714 m/s^2 (``glvf.m``), not 1e-6 g0.

Compressed PSINS files (``.gz``, ``.xz``; :data:`COMPRESSIONS`) are read transparently with the
standard library; the format is that of the name without the compression suffix
(``lasergyro.imu.xz`` is PSINS text). Nothing is decompressed to disk, so a digest of the data
is that of the file given. Tables are not read compressed: Parquet and HDF5 compress inside.
"""

from __future__ import annotations

import gzip
import lzma
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, InputError, UnitError
from inertest.io.data_file import read_table
from inertest.io.hdf5_table import HDF5_SUFFIXES
from inertest.units import ACCEL_UNITS, ARCSEC_TO_RAD, RATE_UNITS

#: The PSINS toolbox's gravity unit [m/s^2] (``glv.g0`` in ``glvf.m``); its ug is 1e-6 of it.
PSINS_G0 = 9.7803267714
FORMATS = ("auto", "csv", "parquet", "hdf5", "psins",
           # read by inertest.io.recordings (ROS bags and MCAP, PX4 ULog, TDMS, text tables,
           # binary records under a TOML layout)
           "rosbag", "ulog", "tdms", "text", "layout")
TIME_UNITS = ("auto", "s", "ms", "us", "ns")
#: Seconds per unit of a time column.
_TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Compression suffixes read transparently (PSINS text only) -> opener of the standard library.
COMPRESSIONS: dict[str, Callable[..., Any]] = {".gz": gzip.open, ".xz": lzma.open}
#: Largest decompressed size of a compressed recording [bytes]: 1 GiB of PSINS text is about
#: 25 million samples (70 h at 100 Hz); a compression bomb is refused once it passes this.
MAX_DECOMPRESSED_BYTES = 1 << 30
#: Longest line read while telling a file's format [characters].
_MAX_HEAD_LINE = 1 << 16
_TABLE_SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet",
                   **{s: "hdf5" for s in HDF5_SUFFIXES}}
_TIME_NAMES = ("t", "time", "timestamp", "time_s", "t_s", "%time", "field.header.stamp",
               "header.stamp", "stamp", "timestamp_ns", "time_ns")
_GYRO_SETS = [("gyr_x", "gyr_y", "gyr_z"), ("gyro_x", "gyro_y", "gyro_z"), ("gx", "gy", "gz"),
              ("wx", "wy", "wz"), ("omega_x", "omega_y", "omega_z"),
              *[tuple(f"{p}angular_velocity.{a}" for a in "xyz")
                for p in ("", "field.", "imu.")]]
_ACCEL_SETS = [("acc_x", "acc_y", "acc_z"), ("accel_x", "accel_y", "accel_z"),
               ("ax", "ay", "az"), ("fx", "fy", "fz"),
               *[tuple(f"{p}linear_acceleration.{a}" for a in "xyz")
                 for p in ("", "field.", "imu.")]]
#: Column sets found without options (also by :mod:`inertest.io.recordings`).
GYRO_SETS, ACCEL_SETS, TIME_NAMES = _GYRO_SETS, _ACCEL_SETS, _TIME_NAMES
_RECORDINGS = ("rosbag", "ulog", "tdms", "text", "layout")


@dataclass(frozen=True)
class ImuRecording:
    """Samples of an IMU recording in SI.

    Attributes
    ----------
    t : (n,) array [s] or None
        Time stamps relative to the first; None when the file has none.
    gyro : (n, k) array [rad/s]
        Angular rates (k = 0..3 columns).
    accel : (n, k) array [m/s^2]
        Specific forces.
    gyro_names, accel_names : tuple of str
        Column names.
    rate_hz : float or None
        Sample rate the file states (PSINS sampling interval) [Hz].
    fmt : str
        Format read.
    notes : tuple of str
        What was assumed (units, LSBs, columns found).
    time_unit : str or None
        Unit the time column was read in ("s", "ms", "us", "ns", "s + ns"); None without one.
    """

    t: NDArray | None
    gyro: NDArray
    accel: NDArray
    gyro_names: tuple[str, ...]
    accel_names: tuple[str, ...]
    rate_hz: float | None
    fmt: str
    notes: tuple[str, ...] = ()
    time_unit: str | None = None


def _split(text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [s.strip() for s in text.split(",") if s.strip()]
    return names or None


def _compression(path: Path) -> str | None:
    """The compression suffix of ``path`` (``.gz``, ``.xz``), or None."""
    suffix = path.suffix.lower()
    return suffix if suffix in COMPRESSIONS else None


def _read_text_lines(path: Path, count: int | None = None) -> list[str]:
    """Lines of a text file, plain or compressed (:data:`COMPRESSIONS`); ``count`` from the top.

    A compressed file is first decompressed without keeping anything, and refused once it
    passes :data:`MAX_DECOMPRESSED_BYTES` (a few kB of ``.xz`` can hold gigabytes); lines read
    from the top are cut at :data:`_MAX_HEAD_LINE` characters.
    """
    comp = _compression(path)
    opener = COMPRESSIONS[comp] if comp is not None else open
    try:
        fh: IO[str]
        if count is None and comp is not None:
            _check_decompressed_size(path, opener)
        with opener(path, "rt", encoding="utf-8", errors="replace") as fh:
            if count is None:
                return fh.readlines()
            return [fh.readline(_MAX_HEAD_LINE) for _ in range(count)]
    except (gzip.BadGzipFile, lzma.LZMAError, EOFError) as exc:
        raise DataError(f"{path} is not a readable {comp} file ({exc or 'truncated'}); "
                        f"check the download, or give the file uncompressed") from None


def _check_decompressed_size(path: Path, opener: Callable[..., Any]) -> None:
    """Refuse a compressed file larger than :data:`MAX_DECOMPRESSED_BYTES` once decompressed."""
    total = 0
    with opener(path, "rb") as raw:
        while block := raw.read(1 << 22):
            total += len(block)
            if total > MAX_DECOMPRESSED_BYTES:
                size = (f"{MAX_DECOMPRESSED_BYTES / (1 << 30):g} GiB"
                        if MAX_DECOMPRESSED_BYTES >= 1 << 30
                        else f"{MAX_DECOMPRESSED_BYTES / (1 << 20):g} MiB")
                raise DataError(f"{path} is larger than {size} when decompressed (a compressed "
                                "recording is read whole in memory); decompress it yourself "
                                "and analyse it in parts")


def detect_format(path: Path) -> str:
    """``csv``, ``parquet``, ``hdf5`` by suffix, else ``psins`` when the text looks like it.

    A compression suffix (``.gz``, ``.xz``) is looked through: ``x.imu.xz`` is judged by its
    content, ``x.csv.gz`` is refused (tables are not read compressed).
    """
    comp = _compression(path)
    inner = path.with_suffix("") if comp is not None else path
    fmt = _TABLE_SUFFIXES.get(inner.suffix.lower())
    if fmt is not None:
        if comp is not None:
            raise InputError(f"{path.name}: a compressed {fmt} table is not read; decompress it "
                             f"(e.g. {'gunzip' if comp == '.gz' else 'unxz'} {path.name}) or "
                             "save it as Parquet, which compresses inside")
        return fmt
    head = _read_text_lines(path, 40)
    from inertest.io.recordings.text_table import looks_like_psins

    if looks_like_psins([h for h in head if h.strip()]):
        return "psins"
    text = "".join(head)
    if comp is None and text.strip() and "\x00" not in text and "\ufffd" not in text:
        return "text"  # spaces or tabs between numbers (a header line is allowed)
    raise InputError(f"cannot tell the format of {path}; give --format "
                     f"({', '.join(FORMATS[1:])})")


def read_psins(path: str | os.PathLike[str]) -> ImuRecording:
    """Read a PSINS text IMU file (module docstring); rates in rad/s and m/s^2."""
    p = Path(path)
    lines = [ln for ln in _read_text_lines(p)
             if ln.strip() and not ln.lstrip().startswith("%")]
    if len(lines) < 4:
        raise DataError(f"{p}: a PSINS file has three parameter lines and then samples; found "
                        f"{len(lines)} non-comment lines")
    try:
        params = [[float(v) for v in ln.split()] for ln in lines[:3]]
    except ValueError:
        raise DataError(f"{p}: the three PSINS parameter lines must hold numbers") from None
    if any(len(row) != 6 for row in params):
        raise DataError(f"{p}: each PSINS parameter line has 6 numbers; got "
                        f"{[len(r) for r in params]}")
    interval_ms = params[1][4]
    lsb = params[2]
    if not (math.isfinite(interval_ms) and interval_ms > 0):
        raise DataError(f"{p}: PSINS sampling interval {interval_ms} ms must be positive")
    if not all(math.isfinite(v) and v > 0 for v in lsb):
        raise DataError(f"{p}: PSINS LSBs {lsb} (arcsec, ug*s) must be positive")
    try:
        d = np.loadtxt(lines[3:], ndmin=2)
    except ValueError:
        raise DataError(f"{p}: {_psins_bad_row(lines[3:])}; PSINS samples are rows of 6 "
                        "increments (and an optional time): repair or cut the file at the last "
                        "complete row") from None
    if d.shape[1] not in (6, 7):
        raise DataError(f"{p}: PSINS samples have 6 increments (and an optional time); got "
                        f"{d.shape[1]} columns")
    dt = interval_ms * 1e-3
    gyro = d[:, :3] * (np.asarray(lsb[:3]) * ARCSEC_TO_RAD / dt)
    accel = d[:, 3:6] * (np.asarray(lsb[3:]) * 1e-6 * PSINS_G0 / dt)
    t = None if d.shape[1] == 6 else d[:, 6] - d[0, 6]
    notes: tuple[str, ...] = (
        f"PSINS: interval {interval_ms:g} ms, gyro LSB {lsb[:3]} arcsec, accelerometer LSB "
        f"{lsb[3:]} ug*s (ug = 1e-6 x {PSINS_G0} m/s^2); increments / interval = rates",)
    if _compression(p) is not None:
        notes += (f"read through {p.suffix} decompression (in memory)",)
    return ImuRecording(t, gyro, accel, ("gyro_x", "gyro_y", "gyro_z"),
                        ("accel_x", "accel_y", "accel_z"), 1e3 / interval_ms, "psins", notes,
                        None if t is None else "s")


def _psins_bad_row(rows: list[str]) -> str:
    """What is wrong with the first malformed PSINS sample row (1-based, after the header)."""
    width = len(rows[0].split())
    for k, ln in enumerate(rows, start=1):
        tokens = ln.split()
        for tok in tokens:
            try:
                float(tok)
            except ValueError:
                return f"sample row {k} holds {tok[:20]!r}, which is not a number"
        if len(tokens) != width:
            last = " (the last row: the file is truncated)" if k == len(rows) else ""
            return (f"sample row {k} has {len(tokens)} numbers where the rows before it have "
                    f"{width}{last}")
    return "the sample rows cannot be read as numbers"


def _exact_int_column(path: Path, fmt: str, name: str) -> NDArray | None:
    """An integer column read without a float64 round trip (CSV/Parquet), or None."""
    if fmt not in ("csv", "parquet"):
        return None
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    try:
        if fmt == "csv":
            col = pacsv.read_csv(path, convert_options=pacsv.ConvertOptions(
                include_columns=[name])).column(name)
        else:
            col = pq.read_table(path, columns=[name]).column(name)
    except (pa.ArrowInvalid, KeyError):
        return None
    if not pa.types.is_integer(col.type) or col.null_count:
        return None
    return col.to_numpy().astype(np.int64)


def _time_seconds(path: Path, fmt: str, table: dict[str, NDArray], spec: list[str],
                  unit: str) -> tuple[NDArray, str]:
    for name in spec:
        if name not in table:
            raise DataError(f"{path} has no time column {name!r}; it has {', '.join(table)}: "
                            "fix --time-column")
    if len(spec) == 2:  # ROS secs + nsecs
        secs = _exact_int_column(path, fmt, spec[0])
        nsecs = _exact_int_column(path, fmt, spec[1])
        if secs is None or nsecs is None:
            s, ns = table[spec[0]], table[spec[1]]
            return (s - s[0]) + (ns - ns[0]) * 1e-9, "s + ns"
        total = secs * 1_000_000_000 + nsecs
        return (total - total[0]).astype(float) * 1e-9, "s + ns"
    if len(spec) != 1:
        raise InputError("--time-column takes one column, or two (seconds, nanoseconds)")
    col = table[spec[0]]
    if col.dtype.kind != "f":
        raise DataError(f"time column {spec[0]!r} of {path} is not numeric")
    if unit == "auto":
        d = np.diff(col[np.isfinite(col)])
        med = float(np.median(d[d > 0])) if np.any(d > 0) else 0.0
        unit = "ns" if med > 100.0 else "s"  # no IMU samples slower than once per 100 s
    exact = _exact_int_column(path, fmt, spec[0]) if unit != "s" else None
    if exact is not None:
        return (exact - exact[0]).astype(float) * _TIME_SCALE[unit], unit
    return (col - col[0]) * _TIME_SCALE[unit], unit


def _pick(table: dict[str, NDArray], given: list[str] | None,
          sets: list[tuple[str, ...]], what: str, path: Path) -> list[str]:
    if given is not None:
        missing = [c for c in given if c not in table]
        if missing:
            raise DataError(f"{path} has no column {missing[0]!r}; it has "
                            f"{', '.join(table)}: fix --{what}-columns")
        if len(given) > 3:
            raise InputError(f"--{what}-columns takes at most 3 columns, got {len(given)}")
        return given
    for s in sets:
        if all(c in table for c in s):
            return list(s)
    return []


def read_imu_recording(
    path: str | os.PathLike[str],
    *,
    fmt: str = "auto",
    time_column: str | None = None,
    time_unit: str = "auto",
    gyro_columns: str | None = None,
    accel_columns: str | None = None,
    gyro_unit: str = "rad/s",
    accel_unit: str = "m/s^2",
    topic: str | None = None,
    layout: str | os.PathLike[str] | None = None,
) -> ImuRecording:
    """Read the gyro and accelerometer channels of a recording, in SI.

    Parameters
    ----------
    path : path
        CSV, Parquet, HDF5 table, or PSINS text file (also ``.gz`` / ``.xz`` compressed); a
        recording of :mod:`inertest.io.recordings` (ROS bag or folder, MCAP, ULog, TDMS, text
        table, binary records with ``layout``).
    fmt : {"auto", "csv", "parquet", "hdf5", "psins", "rosbag", "ulog", "tdms", "text", "layout"}
        File format; ``auto`` by suffix, else by content (PSINS, else a text table).
    time_column : str, optional
        Time column name, or ``"secs,nsecs"``; default a common name if there is one, else no
        time stamps (then a sample rate must be given to the analysis).
    time_unit : {"auto", "s", "ms", "us", "ns"}
        ``auto``: nanoseconds when the median interval exceeds 100 (units), else seconds.
    gyro_columns, accel_columns : str, optional
        Comma-separated columns (x, y, z order; 1 to 3); default common names.
    gyro_unit : {"rad/s", "deg/s", "deg/h"}
    accel_unit : {"m/s^2", "g", "mg", "ug"}
        Units of the table columns ("g" is g0 = 9.80665 m/s^2). PSINS files carry their own.
    topic : str, optional
        ROS topic, ULog message or TDMS group (:mod:`inertest.io.recordings`); default the
        IMU topic found by its type.
    layout : path, optional
        TOML layout of a binary record (:mod:`inertest.io.recordings.binary_layout`).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    if fmt not in FORMATS:
        raise InputError(f"unknown --format {fmt!r}; use one of {', '.join(FORMATS)}")
    if time_unit not in TIME_UNITS:
        raise InputError(f"unknown --time-unit {time_unit!r}; use one of {', '.join(TIME_UNITS)}")
    if gyro_unit not in RATE_UNITS:
        raise UnitError(f"unknown --gyro-unit {gyro_unit!r}; use one of {', '.join(RATE_UNITS)}")
    if accel_unit not in ACCEL_UNITS:
        raise UnitError(f"unknown --accel-unit {accel_unit!r}; use one of "
                        f"{', '.join(ACCEL_UNITS)}")
    if fmt not in ("auto", "psins") and _compression(p) is not None:
        raise InputError(f"--format {fmt}: {p.name} is compressed and tables are not read "
                         "compressed; decompress it, or save it as Parquet (compressed inside)")
    if fmt == "auto" or fmt in _RECORDINGS:
        from inertest.io.recordings.imu import read_imu, recording_of

        given = gyro_columns is not None or accel_columns is not None
        rec = recording_of(p, fmt=fmt, topic=topic, layout=layout, columns_given=given)
        if rec is None and fmt == "auto":
            fmt = detect_format(p)
            if fmt == "text":
                rec = recording_of(p, fmt="text", columns_given=given)
        if rec is not None:
            return read_imu(rec, time_column=time_column, time_unit=time_unit,
                            gyro_columns=gyro_columns, accel_columns=accel_columns,
                            gyro_unit=gyro_unit, accel_unit=accel_unit)
    if topic is not None or layout is not None:
        raise InputError(f"{p.name}: --topic and --layout are for recordings (ROS bags, MCAP, "
                         "ULog, TDMS; binary records); drop them")
    if fmt == "psins":
        if gyro_columns or accel_columns or time_column:
            raise InputError("a PSINS file has fixed columns; drop --gyro-columns, "
                             "--accel-columns and --time-column")
        return read_psins(p)
    expected = {"csv": (".csv",), "parquet": (".parquet", ".pq"), "hdf5": HDF5_SUFFIXES}[fmt]
    if p.suffix.lower() not in expected:
        raise InputError(f"--format {fmt} needs a file named {' or '.join(expected)}; "
                         f"got {p.name}")
    table = read_table(p)
    if not table or len(next(iter(table.values()))) == 0:
        raise DataError(f"{p} has no data rows (only a header: {', '.join(table) or 'none'}); "
                        "give a recording with samples")
    gyro_names = _pick(table, _split(gyro_columns), _GYRO_SETS, "gyro", p)
    accel_names = _pick(table, _split(accel_columns), _ACCEL_SETS, "accel", p)
    if not gyro_names and not accel_names:
        raise DataError(f"{p}: no gyro or accelerometer columns found among "
                        f"{', '.join(table)}; name them with --gyro-columns and "
                        "--accel-columns")
    for c in (*gyro_names, *accel_names):
        if table[c].dtype.kind != "f":
            raise DataError(f"column {c!r} of {p} is not numeric")
    spec = _split(time_column)
    if spec is None:
        spec = next(([n] for n in _TIME_NAMES if n in table), None)
    notes = [f"gyro columns {', '.join(gyro_names) or '(none)'} in {gyro_unit}; "
             f"accelerometer columns {', '.join(accel_names) or '(none)'} in {accel_unit}"]
    t = None
    used = None
    if spec is not None:
        t, used = _time_seconds(p, fmt, table, spec, time_unit)
        notes.append(f"time stamps from {', '.join(spec)} in {used}")
    n = len(next(iter(table.values())))
    gyro = (np.column_stack([table[c] for c in gyro_names]) * RATE_UNITS[gyro_unit]
            if gyro_names else np.empty((n, 0)))
    accel = (np.column_stack([table[c] for c in accel_names]) * ACCEL_UNITS[accel_unit]
             if accel_names else np.empty((n, 0)))
    return ImuRecording(t, gyro, accel, tuple(gyro_names), tuple(accel_names), None, fmt,
                        tuple(notes), used)
