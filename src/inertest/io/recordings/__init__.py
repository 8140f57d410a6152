"""Recordings in the formats users record in, behind one entry: :func:`read_data`.

==========  ===============================================  ==============================
format      files                                            topic (``--topic``)
==========  ===============================================  ==============================
rosbag      ROS 1 ``.bag``; ROS 2 bag folders (SQLite3 or    a ROS topic (``/imu``)
            MCAP storage); ``.mcap``; ``.db3``
ulog        PX4 ``.ulg``                                     a uORB message (``vehicle_imu:1``)
tdms        LabVIEW ``.tdms``                                a TDMS group
text        whitespace / tab tables (``.txt``, ``.dat``...)  -
layout      any binary file + a TOML record layout           -
==========  ===============================================  ==============================

(CSV, Parquet and HDF5 tables: :func:`inertest.io.data_file.read_table`; PSINS text and
compressed PSINS: :mod:`inertest.io.imu_recording`.) Each format is read with the library of
its ecosystem: :mod:`rosbags`, :mod:`pyulog`, :mod:`nptdms` (the extras ``ros``, ``px4``,
``tdms``; a missing one is named with its ``pip install``). A recording opens as a
:class:`Recording`: its columns come block by block (:meth:`Recording.batches`), so a day-long
bag is never held whole (:mod:`inertest.io.recordings.imu` streams it to the noise analysis).

Without ``topic``, the IMU topic is found by its type (``sensor_msgs/msg/Imu``; PX4
``sensor_combined``, then ``vehicle_imu``), or the only topic there is. Errors about topics
(none, several, an empty one, one of another type) name every topic found.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, InputError

#: Formats read here (``inertest noise --format``).
RECORDING_FORMATS = ("rosbag", "ulog", "tdms", "text", "layout")
#: Gyro and accelerometer columns of the IMU message types known without options.
_ROS_GYRO = tuple(f"angular_velocity.{a}" for a in "xyz")
_ROS_ACCEL = tuple(f"linear_acceleration.{a}" for a in "xyz")


@dataclass(frozen=True)
class Recording:
    """One topic of a recording, read block by block.

    Attributes
    ----------
    path : Path
    fmt : str
        One of :data:`RECORDING_FORMATS`.
    topic : str or None
        Topic, ULog message or TDMS group read (None for formats without topics).
    msgtype : str or None
        Message type (ROS), or None.
    names : tuple of str
        Columns, in order.
    units : mapping
        Unit of the columns whose format states one.
    time_columns : tuple of str
        The time stamps: one column, or two (ROS seconds and nanoseconds); empty if none known.
    time_unit : str
        ``"s"``, ``"us"`` or ``"ns"`` (of the one time column; two columns are s + ns).
    gyro, accel : tuple of str
        Columns of a known IMU type in rad/s and m/s^2; empty when the type does not say.
    rate_hz : float or None
        Sample rate the format states (a TOML layout's ``rate_hz``).
    count : int or None
        Rows, when the format says before reading.
    notes : tuple of str
        How the recording was read.
    listing : str
        What the file holds (topics with their types and counts), for messages.
    """

    path: Path
    fmt: str
    topic: str | None
    msgtype: str | None
    names: tuple[str, ...]
    units: Mapping[str, str]
    time_columns: tuple[str, ...]
    time_unit: str
    gyro: tuple[str, ...]
    accel: tuple[str, ...]
    rate_hz: float | None
    count: int | None
    notes: tuple[str, ...]
    listing: str
    source: Callable[[Sequence[str] | None], Iterator[dict[str, NDArray]]] = field(repr=False)

    def batches(self, columns: Sequence[str] | None = None) -> Iterator[dict[str, NDArray]]:
        """The columns (all, or those named) block by block."""
        return self.source(columns)

    def read(self, columns: Sequence[str] | None = None) -> dict[str, NDArray]:
        """The columns (all, or those named) whole."""
        parts: dict[str, list[NDArray]] = {}
        for b in self.batches(columns):
            for k, v in b.items():
                parts.setdefault(k, []).append(v)
        if not parts:
            raise DataError(f"{self.path}{f' topic {self.topic}' if self.topic else ''} has no "
                            f"samples; what the file holds: {self.listing}")
        return {k: v[0] if len(v) == 1 else np.concatenate(v) for k, v in parts.items()}


def recording_format(path: Path, *, layout: object = None) -> str | None:
    """The format of ``path`` among :data:`RECORDING_FORMATS`, or None (a table, PSINS text)."""
    if layout is not None:
        return "layout"
    from inertest.io.recordings.rosbag import is_ros_path
    from inertest.io.recordings.text_table import TEXT_SUFFIXES

    if is_ros_path(path):
        return "rosbag"
    suffix = path.suffix.lower()
    if suffix == ".ulg":
        return "ulog"
    if suffix == ".tdms":
        return "tdms"
    if suffix in TEXT_SUFFIXES and path.is_file():
        from inertest.io.recordings.text_table import looks_like_psins

        with path.open("r", encoding="utf-8", errors="replace") as fh:
            head = [fh.readline(1 << 16) for _ in range(40)]
        return None if looks_like_psins(head) else "text"
    return None


def open_recording(
    path: str | os.PathLike[str], *, topic: str | None = None,
    layout: str | os.PathLike[str] | None = None, imu: bool = False, fmt: str | None = None,
) -> Recording:
    """Open one topic of a recording (module docstring); ``imu``: the topic must be an IMU's.

    ``fmt`` (one of :data:`RECORDING_FORMATS`) overrides the format told by the name.

    Raises
    ------
    DataError
        Unreadable, truncated or empty file; no such topic, several candidates, or (``imu``)
        a topic of another type: the message names every topic found.
    MissingExtraError
        The format's library is not installed (the message names the ``pip install``).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    fmt = fmt or recording_format(p, layout=layout)
    if fmt == "layout" and layout is None:
        raise InputError(f"{p.name}: --format layout needs --layout LAYOUT.toml (the record's "
                         "size, fields, types, scales and units)")
    if fmt is None:
        raise InputError(f"{p} is not a recording format read here (ROS bag, MCAP, ULog, TDMS, "
                         "text table, or binary with --layout)")
    if fmt != "rosbag" and p.is_dir():
        raise InputError(f"{p} is a folder; give a file (a folder is read as a ROS 2 bag only "
                         "when it holds metadata.yaml)")
    if fmt == "rosbag":
        return _open_rosbag(p, topic, imu)
    if topic is not None and fmt in ("text", "layout"):
        raise InputError(f"{p.name}: a {fmt} file has no topics; drop --topic")
    if fmt == "ulog":
        return _open_ulog(p, topic)
    if fmt == "tdms":
        return _open_tdms(p, topic)
    if fmt == "text":
        return _open_text(p)
    assert layout is not None
    return _open_layout(p, layout)


def read_data(
    path: str | os.PathLike[str], *, topic: str | None = None,
    layout: str | os.PathLike[str] | None = None, keep_types: bool = False,
) -> dict[str, NDArray]:
    """Columns of any data file inertest reads: the one entry behind every DATA argument.

    CSV, Parquet and HDF5 tables (:func:`inertest.io.data_file.read_table`), and the
    recordings of this package (one topic, whole). ``topic`` and ``layout`` are for recordings.
    ``keep_types``: CSV and Parquet columns keep the type of the file (integers stay integers;
    ``read_table`` makes every number a float64); recordings always keep theirs.
    """
    p = Path(path)
    fmt = recording_format(p, layout=layout) if p.exists() else None
    if fmt is None:
        if topic is not None:
            raise InputError(f"{p.name}: a table has no topics; drop --topic (topics are for "
                             "ROS bags, MCAP, ULog and TDMS files)")
        from inertest.io.data_file import read_table

        if p.is_dir():
            raise InputError(f"{p} is a folder; give a data file (a folder is read as a ROS 2 "
                             "bag only when it holds metadata.yaml)")
        if keep_types and p.suffix.lower() in (".csv", ".parquet", ".pq"):
            return _typed_table(p)
        return read_table(p)
    return open_recording(p, topic=topic, layout=layout).read()


def _typed_table(p: Path) -> dict[str, NDArray]:
    """A CSV or Parquet file with its columns' own types (:func:`inertest.io.frames.columns_of`).

    Errors as :func:`inertest.io.data_file.read_table` gives them (it reads the file again).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    from inertest.io.data_file import read_table
    from inertest.io.frames import columns_of

    try:
        if p.suffix.lower() == ".csv":
            table = pacsv.read_csv(p)
        else:
            with pq.ParquetFile(p) as pf:
                table = pf.read()
        return columns_of(table, what=f"data file {p}")
    except (pa.ArrowException, UnicodeDecodeError, DataError):
        return read_table(p)  # the reader that names the problem


# ------------------------------------------------------------------------------ per format


def _open_rosbag(p: Path, topic: str | None, imu: bool) -> Recording:
    from inertest.io.recordings.rosbag import IMU_TYPE, RosBag, imu_columns

    bag = RosBag(p)
    listing = bag.listing()
    if not any(t.count for t in bag.topics.values()):
        raise DataError(f"{p} holds no messages (topics found: {listing}); the recording is "
                        "empty")
    if topic is not None:
        if topic not in bag.topics:
            raise DataError(f"{p} has no topic {topic!r}; topics found: {listing}; choose one "
                            "with --topic")
        chosen = bag.topics[topic]
        if chosen.count == 0:
            raise DataError(f"topic {topic} of {p} has no messages; topics found: {listing}")
    else:
        imus = [t for t in bag.topics.values() if t.msgtype == IMU_TYPE and t.count]
        filled = [t for t in bag.topics.values() if t.count]
        if len(imus) == 1:
            chosen = imus[0]
        elif len(imus) > 1:
            counts = {t.count for t in imus}
            why = (" at different rates (message counts differ)" if len(counts) > 1 else "")
            others = "" if len(filled) == len(imus) else f" (topics found: {listing})"
            raise DataError(f"{p} has {len(imus)} IMU topics{why}: "
                            f"{', '.join(t.describe() for t in imus)}; choose one with "
                            f"--topic{others}")
        elif len(filled) == 1 and not imu:
            chosen = filled[0]
        else:
            raise DataError(f"{p} has no sensor_msgs/msg/Imu topic; topics found: {listing}; "
                            "choose one with --topic")
    if imu and chosen.msgtype != IMU_TYPE:
        raise DataError(f"topic {chosen.name} of {p} holds {chosen.msgtype}, not IMU readings "
                        f"(sensor_msgs/msg/Imu); topics found: {listing}; choose the IMU topic "
                        "with --topic, or name the columns with --gyro-columns/--accel-columns")

    def source(columns: Sequence[str] | None) -> Iterator[dict[str, NDArray]]:
        return bag.batches(chosen.name, columns=columns)[0]

    is_imu = chosen.msgtype == IMU_TYPE
    names = (("header.stamp.sec", "header.stamp.nanosec", "header.frame_id",
              *imu_columns(), "bag_time_ns") if is_imu else ())
    how = bag.batches(chosen.name, columns=())[1]  # lazy: nothing is read here
    return Recording(
        p, "rosbag", chosen.name, chosen.msgtype, names, {},
        ("header.stamp.sec", "header.stamp.nanosec") if is_imu else (), "ns",
        _ROS_GYRO if is_imu else (), _ROS_ACCEL if is_imu else (), None, chosen.count,
        tuple(how), listing, source)


def _open_ulog(p: Path, topic: str | None) -> Recording:
    from inertest.io.recordings import ulog

    found = ulog.topics(p)  # one parse of the whole log, for the choice and the messages
    chosen = ulog.choose_topic(p, topic, found)
    gyro, accel = ulog.imu_columns(chosen)
    cache: dict[str, dict[str, NDArray]] = {}

    def source(columns: Sequence[str] | None) -> Iterator[dict[str, NDArray]]:
        if "all" not in cache:
            cache["all"] = ulog.read_topic(p, chosen)
        cols = cache["all"]
        yield {k: v for k, v in cols.items() if columns is None or k in columns}

    units = {c: "rad/s" for c in gyro} | {c: "m/s^2" for c in accel} | {"timestamp": "us"}
    notes = (f"PX4 ULog topic {chosen} read by pyulog; time stamps from timestamp [us]"
             + ("; rates = delta_angle / delta_angle_dt, delta_velocity / delta_velocity_dt"
                if chosen.startswith("vehicle_imu") else ""),)
    return Recording(p, "ulog", chosen, None, (), units, ("timestamp",), "us", gyro, accel,
                     None, found.get(chosen), notes, ulog.listing(found), source)


def _open_tdms(p: Path, topic: str | None) -> Recording:
    from inertest.io.imu_recording import ACCEL_SETS, GYRO_SETS
    from inertest.io.recordings import tdms

    def looks_like_imu(channels: list[str]) -> bool:
        return any(all(c in channels for c in s) for s in (*GYRO_SETS, *ACCEL_SETS))

    group = tdms.choose_group(p, topic, looks_like_imu)
    g = tdms.TdmsGroup(p, group)
    names = (*g.names, *([g.time_column] if g.time_column else []))
    notes = (f"TDMS group {group} read by nptdms"
             + (f"; time from the waveform increment {g.increment:g} s" if g.time_column else ""),)
    return Recording(p, "tdms", group, None, tuple(names), dict(g.units),
                     (g.time_column,) if g.time_column else (), "s", (), (),
                     None if g.increment is None else 1.0 / g.increment, g.count, notes,
                     tdms.listing(tdms.groups(p)), g.batches)


def _open_text(p: Path) -> Recording:
    from inertest.io.recordings.text_table import read_text_table

    with p.open("r", encoding="utf-8", errors="replace") as fh:
        lines = fh.readlines()
    cols = read_text_table(p, lines)

    def source(columns: Sequence[str] | None) -> Iterator[dict[str, NDArray]]:
        yield {k: v for k, v in cols.items() if columns is None or k in columns}

    n = len(next(iter(cols.values())))
    return Recording(p, "text", None, None, tuple(cols), {}, (), "s", (), (), None, n,
                     (f"text table: {len(cols)} columns ({', '.join(cols)}), {n} rows",),
                     f"columns {', '.join(cols)}", source)


def _open_layout(p: Path, layout: str | os.PathLike[str]) -> Recording:
    from inertest.io.recordings.binary_layout import BinaryRecords, read_layout

    lay = read_layout(layout)
    recs = BinaryRecords(p, lay)
    time_unit = lay.units.get(lay.time, "s") if lay.time else "s"
    if lay.time and time_unit not in ("s", "ms", "us", "ns"):
        raise InputError(f"layout {lay.source}: the time field {lay.time} has unit "
                         f"{time_unit!r}; use s, ms, us or ns")
    notes = (f"binary records of {lay.size} bytes under {lay.source}: {recs.count} records, "
             f"fields {', '.join(recs.names)}",)
    return Recording(p, "layout", None, None, tuple(recs.names), lay.units,
                     (lay.time,) if lay.time else (), time_unit, (), (), lay.rate_hz,
                     recs.count, notes, f"fields {', '.join(recs.names)}", recs.batches)
