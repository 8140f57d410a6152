"""ROS 1 bags, ROS 2 bags (SQLite3 or MCAP storage) and MCAP files, through :mod:`rosbags`.

A topic is read as columns named after its message's fields, flattened with dots
(``angular_velocity.x``, ``header.stamp.sec``) and ``[i]`` for fixed arrays
(``orientation_covariance[0]``), plus ``bag_time_ns``, the bag's time of each message [ns].
ROS 1 names are those of ROS 2 (rosbags normalises them: ``header.stamp.sec``/``nanosec``).

``sensor_msgs/msg/Imu`` (ROS 1 and ROS 2) has a fixed layout once its ``frame_id`` is known, and
is decoded here from the raw message bytes with numpy (:func:`decode_imu`), a whole chunk at a
time, checked against rosbags' own deserialiser on the first message of every file (if they ever
differ, rosbags decodes every message instead). The raw bytes come from the container walkers of
:mod:`inertest.io.recordings.ros_containers` (or from rosbags' message iterator where those do
not apply). Every other message type is deserialised by rosbags, message by message.

Layouts (all little-endian): ROS 1 serialisation packs fields without padding; ``Header`` is
``seq`` (uint32), ``stamp`` (uint32 sec, uint32 nsec), ``frame_id`` (uint32 length + bytes).
ROS 2 CDR (OMG DDS-XTypes / CDR v1): a 4-byte encapsulation header (``00 01`` little-endian),
then ``stamp`` (int32 sec, uint32 nanosec), ``frame_id`` (uint32 length including the
terminating NUL, then the bytes), each float64 aligned to 8 bytes from the end of the
encapsulation header. Then 4 + 9 + 3 + 9 + 3 + 9 float64 in both: orientation x, y, z, w, its
covariance, angular velocity x, y, z [rad/s], its covariance, linear acceleration x, y, z
[m/s^2], its covariance (REP 145: the accelerometer's specific force, gravity included).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError, import_extra
from inertest.io.recordings.ros_containers import (
    BATCH_MESSAGES,
    McapIndex,
    RawBatch,
    Ros1Bag,
    gather,
    rebatch,
    sqlite_batches,
)

IMU_TYPE = "sensor_msgs/msg/Imu"
#: md5sum of the ROS 1 sensor_msgs/Imu definition (the layout decoded here).
ROS1_IMU_MD5 = "6a62c6daae103f4ff57a132d6f95cec2"
_WHAT = "reading ROS bags and MCAP files"
_VEC = ("x", "y", "z")
#: Fields of an Imu message after the header: (name, number of float64).
_IMU_BODY = (("orientation", 4), ("orientation_covariance", 9), ("angular_velocity", 3),
             ("angular_velocity_covariance", 9), ("linear_acceleration", 3),
             ("linear_acceleration_covariance", 9))


def imu_columns() -> list[str]:
    """Column names of an Imu message, in message order (after the header)."""
    out = []
    for name, n in _IMU_BODY:
        if n in (3, 4):
            out += [f"{name}.{a}" for a in ("x", "y", "z", "w")[:n]]
        else:
            out += [f"{name}[{i}]" for i in range(n)]
    return out


def is_ros_path(path: Path) -> bool:
    """A ROS 1 bag, an MCAP or SQLite3 file, or a ROS 2 bag folder (with metadata.yaml)."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.suffix.lower() in (".bag", ".mcap", ".db3")


@dataclass(frozen=True)
class Topic:
    """A topic of a bag: its message type and number of messages."""

    name: str
    msgtype: str
    count: int

    def describe(self) -> str:
        """``/imu (sensor_msgs/msg/Imu, 1200 messages)``."""
        return f"{self.name} ({self.msgtype}, {self.count} messages)"


class RosBag:
    """One bag (ROS 1 file, ROS 2 folder, ``.mcap`` or ``.db3`` file): its topics and messages."""

    def __init__(self, path: Path) -> None:
        import_extra("rosbags", _WHAT)
        self.path = path
        self.ros1 = path.is_file() and path.suffix.lower() == ".bag"
        self._ros1: Ros1Bag | None = None
        if self.ros1:
            self._ros1 = Ros1Bag(path)
            self.topics = {k: Topic(k, t, n) for k, (t, n) in self._ros1.topics().items()}
        else:
            self.topics = self._ros2_topics()

    def _any_reader(self) -> Any:
        from rosbags.highlevel import AnyReader, AnyReaderError
        from rosbags.typesys import Stores, get_typestore

        store = Stores.ROS1_NOETIC if self.ros1 else Stores.ROS2_HUMBLE
        try:
            reader = AnyReader([self.path], default_typestore=get_typestore(store))
            reader.open()
        except (AnyReaderError, FileNotFoundError, KeyError, ValueError, EOFError,
                UnicodeDecodeError) as exc:
            raise DataError(f"{self.path} cannot be read as a ROS bag: {_first(exc)}; it may "
                            "be truncated or still being written (ROS 2: `ros2 bag reindex`; "
                            "MCAP: `mcap recover`)") from None
        return reader

    def _ros2_topics(self) -> dict[str, Topic]:
        if self.path.is_file() and self.path.stat().st_size == 0:
            raise DataError(f"{self.path} is empty (0 bytes): no messages to read")
        reader = self._any_reader()
        try:
            return {name: Topic(name, info.msgtype or "?", int(info.msgcount))
                    for name, info in reader.topics.items()}
        finally:
            reader.close()

    def listing(self) -> str:
        """The topics found, for messages."""
        return ", ".join(t.describe() for t in self.topics.values()) or "none"

    # -------------------------------------------------------------------- raw messages

    def _storage_files(self) -> list[Path] | None:
        """ROS 2 storage files in order (folder: from metadata.yaml); None if compressed."""
        if self.path.is_file():
            return [self.path]
        import yaml

        try:
            meta = yaml.safe_load((self.path / "metadata.yaml").read_text(encoding="utf-8"))
            info = meta["rosbag2_bagfile_information"]
        except (yaml.YAMLError, KeyError, TypeError, OSError, UnicodeDecodeError):
            return None
        if info.get("compression_format") or info.get("compression_mode") not in (None, "", "NONE"):
            return None
        files = [self.path / f for f in info.get("relative_file_paths", [])]
        return files if files and all(f.is_file() for f in files) else None

    def raw_batches(self, topic: str) -> tuple[Iterator[RawBatch], str]:
        """The raw messages of ``topic`` and how they are read (``walker`` or ``rosbags``)."""
        if self._ros1 is not None:
            ids = [c.id for c in self._ros1.connections.values() if c.topic == topic]
            it = self._ros1.batches(ids)
            if it is not None:
                return it, "walker"
        else:
            files = self._storage_files()
            if files is not None and all(f.suffix == ".db3" for f in files):
                return sqlite_batches(files, topic), "walker"
            if files is not None and all(f.suffix == ".mcap" for f in files):
                its = []
                for f in files:
                    idx = McapIndex(f)
                    ids = [c for c, t in idx.channels.items() if t == topic]
                    it = idx.batches(ids) if ids else iter(())
                    if it is None:
                        break
                    its.append(it)
                else:
                    return (b for it in its for b in it), "walker"
        return self._library_batches(topic), "rosbags"

    def _library_batches(self, topic: str) -> Iterator[RawBatch]:
        reader = self._any_reader()
        try:
            conns = [c for c in reader.connections if c.topic == topic]
            yield from rebatch((raw, t) for _, t, raw in reader.messages(connections=conns))
        finally:
            reader.close()

    def deserializer(self) -> Any:
        """A function ``(bytes, msgtype) -> message`` (rosbags' own, with the bag's types)."""
        from rosbags.typesys import Stores, get_typestore

        if self.ros1:
            ts = get_typestore(Stores.ROS1_NOETIC)
            return ts.deserialize_ros1
        ts = get_typestore(Stores.ROS2_HUMBLE)
        return ts.deserialize_cdr

    # -------------------------------------------------------------------- columns

    def batches(self, topic: str, *, columns: Sequence[str] | None = None
                ) -> tuple[Iterator[dict[str, NDArray]], list[str]]:
        """Columns of ``topic`` batch by batch, and notes on how they were read.

        ``columns`` limits an Imu topic to those columns (stamps always come).
        """
        info = self.topics[topic]
        notes: list[str] = []
        if info.msgtype == IMU_TYPE and self._imu_layout_ok(topic):
            raw, how = self.raw_batches(topic)
            notes.append(f"{topic}: sensor_msgs/msg/Imu decoded from the raw bytes "
                         f"({'chunk walker' if how == 'walker' else 'rosbags reader'}), "
                         "checked against rosbags' deserialiser")
            return self._checked_imu(topic, raw, columns), notes
        notes.append(f"{topic}: {info.msgtype} deserialised by rosbags, message by message")
        return self._generic(topic), notes

    def _imu_layout_ok(self, topic: str) -> bool:
        if self._ros1 is None:
            return True
        return all(c.md5sum == ROS1_IMU_MD5 for c in self._ros1.connections.values()
                   if c.topic == topic)

    def _checked_imu(self, topic: str, raw: Iterator[RawBatch],
                     columns: Sequence[str] | None) -> Iterator[dict[str, NDArray]]:
        """Decoded batches, checked against rosbags on the first batch.

        If the first and last message of the first batch do not decode alike, rosbags
        decodes every message instead.
        """
        deser = self.deserializer()
        first = True
        for batch in raw:
            try:
                cols = decode_imu(batch, ros1=self.ros1, columns=columns)
                if first and len(batch):
                    for i in {0, len(batch) - 1}:
                        try:
                            msg = deser(batch.message(i), IMU_TYPE)
                        except Exception as exc:  # noqa: BLE001 - rosbags raises several kinds
                            raise DataError(_first(exc)) from None
                        check_imu_decoding(msg, cols, i, self.path)
            except DataError:
                if not first:
                    raise
                yield from self._generic(topic)
                return
            first = False
            yield cols

    def _generic(self, topic: str) -> Iterator[dict[str, NDArray]]:
        reader = self._any_reader()
        try:
            conns = [c for c in reader.connections if c.topic == topic]
            rows: list[dict[str, Any]] = []
            for conn, t, raw in reader.messages(connections=conns):
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except Exception as exc:  # noqa: BLE001 - rosbags raises several kinds
                    raise DataError(f"{self.path}: a message of {topic} cannot be decoded as "
                                    f"{conn.msgtype}: {_first(exc)}") from None
                row = {"bag_time_ns": t}
                flatten(msg, "", row)
                rows.append(row)
                if len(rows) >= BATCH_MESSAGES:
                    yield _columns(rows)
                    rows = []
            if rows:
                yield _columns(rows)
        finally:
            reader.close()


def _first(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0].rstrip(".") if lines else type(exc).__name__


def flatten(value: Any, prefix: str, out: dict[str, Any]) -> None:
    """Scalars of a deserialised message under dotted names (``[i]`` for array elements)."""
    if isinstance(value, bool | int | float | str | np.generic):
        out[prefix] = value
    elif isinstance(value, np.ndarray):
        if value.ndim == 1 and value.size <= 64:
            for i, v in enumerate(value):
                out[f"{prefix}[{i}]"] = v
    elif isinstance(value, list | tuple):
        for i, v in enumerate(value[:64]):
            flatten(v, f"{prefix}[{i}]", out)
    elif hasattr(value, "__dataclass_fields__"):
        for name in value.__dataclass_fields__:
            if name == "__msgtype__":
                continue
            flatten(getattr(value, name), f"{prefix}.{name}" if prefix else name, out)


def _columns(rows: list[dict[str, Any]]) -> dict[str, NDArray]:
    names = list(dict.fromkeys(k for r in rows for k in r))
    out: dict[str, NDArray] = {}
    for k in names:
        vals = [r.get(k) for r in rows]
        if any(isinstance(v, str) for v in vals):
            out[k] = np.asarray(["" if v is None else str(v) for v in vals], dtype=str)
        else:
            out[k] = np.asarray([np.nan if v is None else v for v in vals])
    return out


def decode_imu(batch: RawBatch, *, ros1: bool,
               columns: Sequence[str] | None = None) -> dict[str, NDArray]:
    """Columns of serialised ``sensor_msgs/msg/Imu`` messages (module docstring's layout).

    Parameters
    ----------
    batch : RawBatch
        The messages.
    ros1 : bool
        ROS 1 serialisation; else ROS 2 CDR.
    columns : sequence of str, optional
        Body columns wanted (:func:`imu_columns`); default all. The stamp and ``bag_time_ns``
        always come; ``header.frame_id`` only with all columns.

    Raises
    ------
    DataError
        A message shorter than the layout, or CDR that is not little-endian.
    """
    buf, s = batch.buf, batch.starts
    u4, i4, f8 = np.dtype("<u4"), np.dtype("<i4"), np.dtype("<f8")
    out: dict[str, NDArray] = {}
    if ros1:
        out["header.seq"] = gather(buf, s, u4)
        out["header.stamp.sec"] = gather(buf, s + 4, u4).astype(np.int64)
        out["header.stamp.nanosec"] = gather(buf, s + 8, u4).astype(np.int64)
        n = gather(buf, s + 12, u4).astype(np.int64)
        frame = s + 16
        body = frame + n
    else:
        if batch.sizes.size and not np.all(buf[s + 1] == 1):
            raise DataError("a CDR message is not little-endian (encapsulation 00 01); "
                            "big-endian Imu messages are not read")
        out["header.stamp.sec"] = gather(buf, s + 4, i4).astype(np.int64)
        out["header.stamp.nanosec"] = gather(buf, s + 8, u4).astype(np.int64)
        n = gather(buf, s + 12, u4).astype(np.int64)
        frame = s + 16
        body = s + 4 + ((12 + n + 7) & ~7)
    need = body + 8 * 37 - s
    if np.any(need > batch.sizes):
        raise DataError("an Imu message is shorter than its layout (the bag is damaged, or "
                        "the type is not sensor_msgs/msg/Imu)")
    if columns is None:
        out["header.frame_id"] = _frame_ids(buf, frame, n - (0 if ros1 else 1))
    want = set(imu_columns() if columns is None else columns)
    k = 0
    for name in imu_columns():
        if name in want:
            out[name] = gather(buf, body + 8 * k, f8)
        k += 1
    out["bag_time_ns"] = batch.log_ns
    return out


def _frame_ids(buf: NDArray[np.uint8], start: NDArray[np.int64], n: NDArray[np.int64]
               ) -> NDArray:
    """``frame_id`` strings (decoded once per distinct run of equal values)."""
    if start.size == 0:
        return np.empty(0, dtype=str)
    first = buf[start[0]:start[0] + max(int(n[0]), 0)].tobytes().decode("utf-8", "replace")
    if np.all(n == n[0]):
        width = int(n[0])
        same = (width == 0 or bool(np.all(
            buf[start[:, None] + np.arange(width)] == buf[start[0]:start[0] + width])))
        if same:
            return np.full(start.size, first)
    return np.asarray([buf[a:a + max(int(b), 0)].tobytes().decode("utf-8", "replace")
                       for a, b in zip(start, n, strict=True)])


def check_imu_decoding(msg: Any, cols: dict[str, NDArray], i: int, path: Path) -> None:
    """Raise :class:`DataError` unless row ``i`` of ``cols`` is the deserialised ``msg``."""
    want = {"header.stamp.sec": msg.header.stamp.sec,
            "header.stamp.nanosec": msg.header.stamp.nanosec}
    for v in ("angular_velocity", "linear_acceleration"):
        for a in _VEC:
            want[f"{v}.{a}"] = getattr(getattr(msg, v), a)
    for name, value in want.items():
        if name in cols:
            got = cols[name][i]
            if not (got == value or (np.isnan(got) and np.isnan(value))):
                raise DataError(f"{path}: message {i}'s {name} decodes to {got!r} here and to "
                                f"{value!r} by rosbags; the Imu layout is not the standard one: "
                                "report this with the bag")
