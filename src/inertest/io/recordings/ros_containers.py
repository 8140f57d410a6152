"""The raw message bytes of one topic of a ROS bag, chunk by chunk, without a Python object each.

Three containers, each read from its documented layout:

* ROS 1 bag, format 2.0 (wiki.ros.org/Bags/Format/2.0): the index at the end of the file lists
  the connections and the chunks; after each chunk, one *index data* record per connection holds
  ``(time, offset)`` of its messages in the uncompressed chunk, read here as one numpy array.
  (:mod:`rosbags`' own ROS 1 reader keeps a Python object per message in memory: about 10 GB for
  a day at 1 kHz, so a long bag is walked here instead.)
* MCAP (mcap.dev/spec): the summary's chunk indexes point to each chunk and to its *message
  index* records, ``(log_time, offset)`` per message of a channel, read as one array.
* ROS 2 SQLite3 (``.db3``): the ``messages`` table, fetched in blocks.

Each yields :class:`RawBatch` (one buffer, the start and size of every message in it, and the
bag's time of each) in the order :mod:`rosbags` gives the messages (bag time, then position in
the file). Whatever these walkers do not handle (an unindexed or truncated file, overlapping
chunks, compressed ROS 2 files, ...) returns None, and the caller reads through :mod:`rosbags`.
"""

from __future__ import annotations

import sqlite3
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError

#: Messages per batch read from SQLite (and from :mod:`rosbags` when it reads).
BATCH_MESSAGES = 1 << 16
_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class RawBatch:
    """Serialised messages of one topic: ``buf[starts[i]:starts[i] + sizes[i]]`` is message i.

    ``log_ns`` is the bag's time of each message [ns] (receive time, not the header stamp).
    """

    buf: NDArray[np.uint8]
    starts: NDArray[np.int64]
    sizes: NDArray[np.int64]
    log_ns: NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.starts.size)

    def message(self, i: int) -> bytes:
        """The bytes of message ``i``."""
        a = int(self.starts[i])
        return self.buf[a:a + int(self.sizes[i])].tobytes()


def gather(buf: NDArray[np.uint8], pos: NDArray[np.int64], dtype: np.dtype) -> NDArray:
    """Values of ``dtype`` at byte positions ``pos`` of ``buf`` (unaligned, any endianness).

    Positions in an arithmetic progression (messages of equal size back to back) are read as
    one strided view; others byte by byte into a ``(k, itemsize)`` array viewed as ``dtype``.
    """
    n = dtype.itemsize
    k = pos.size
    if k == 0:
        return np.empty(0, dtype=dtype)
    if int(pos.max()) + n > buf.size or int(pos.min()) < 0:
        raise DataError("a message is shorter than its type's layout (the bag is damaged)")
    if k > 1:
        step = int(pos[1] - pos[0])
        if step > 0 and bool(np.all(np.diff(pos) == step)):
            view = np.ndarray((k,), dtype=dtype, buffer=buf, offset=int(pos[0]),
                              strides=(step,))
            return view.copy()
    rows = buf[pos[:, None] + np.arange(n)]
    return rows.view(dtype).reshape(k)


# ------------------------------------------------------------------------------ ROS 1


@dataclass(frozen=True)
class Ros1Connection:
    """A connection record of a ROS 1 bag."""

    id: int
    topic: str
    msgtype: str  # as written, e.g. "sensor_msgs/Imu"
    md5sum: str
    msgdef: str


@dataclass(frozen=True)
class _Ros1Chunk:
    pos: int
    start_ns: int
    end_ns: int
    counts: dict[int, int]


def _fields(header: bytes) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    i = 0
    while i + 4 <= len(header):
        n = int.from_bytes(header[i:i + 4], "little")
        key, _, value = header[i + 4:i + 4 + n].partition(b"=")
        out[key.decode("ascii", "replace")] = value
        i += 4 + n
    return out


def _time_ns(b: bytes) -> int:
    sec, nsec = struct.unpack("<II", b[:8])
    return sec * 1_000_000_000 + nsec


class Ros1Bag:
    """The index of a ROS 1 bag (format 2.0): connections, chunks, and their message counts."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.size = path.stat().st_size
        self.connections: dict[int, Ros1Connection] = {}
        self.chunks: list[_Ros1Chunk] = []
        with path.open("rb") as fh:
            magic = fh.readline(64)
            if magic != _ROS1_MAGIC:
                if not magic:
                    raise DataError(f"{path} is empty (0 bytes): no messages to read")
                raise DataError(f"{path} is not a ROS 1 bag of format 2.0 (it starts with "
                                f"{magic[:16]!r}); give a .bag written by rosbag record, or a "
                                "ROS 2 bag folder / .mcap / .db3")
            fields, _ = self._record(fh, read_data=False)
            if fields.get("op") != b"\x03" or "index_pos" not in fields:
                raise DataError(f"{path}: the bag header record is damaged; the file is not a "
                                "readable ROS 1 bag")
            index_pos = struct.unpack("<Q", fields["index_pos"])[0]
            n_conn = struct.unpack("<I", fields["conn_count"])[0]
            n_chunk = struct.unpack("<I", fields["chunk_count"])[0]
            if index_pos == 0 or index_pos >= self.size:
                where = ("is missing" if index_pos == 0 else
                         f"at byte {index_pos} lies beyond the end, byte {self.size}")
                raise DataError(
                    f"{path} is truncated or was not closed (its index {where}): no topics can "
                    f"be listed; rebuild the index with `rosbag reindex {path.name}` (ROS 1) "
                    "and read the reindexed bag")
            fh.seek(index_pos)
            try:
                for _ in range(n_conn):
                    f, data = self._record(fh)
                    conn = struct.unpack("<I", f["conn"])[0]
                    d = _fields(data)
                    self.connections[conn] = Ros1Connection(
                        conn, f["topic"].decode(), d.get("type", b"").decode(),
                        d.get("md5sum", b"").decode(),
                        d.get("message_definition", b"").decode("utf-8", "replace"))
                for _ in range(n_chunk):
                    f, data = self._record(fh)
                    counts = {int(c): int(n) for c, n in
                              np.frombuffer(data, dtype="<u4").reshape(-1, 2)}
                    self.chunks.append(_Ros1Chunk(
                        struct.unpack("<Q", f["chunk_pos"])[0], _time_ns(f["start_time"]),
                        _time_ns(f["end_time"]), counts))
            except (KeyError, ValueError, struct.error, EOFError):
                raise DataError(f"{path}: the bag's index is damaged (truncated or overwritten); "
                                f"rebuild it with `rosbag reindex {path.name}`") from None
        self.chunks.sort(key=lambda c: c.pos)

    @staticmethod
    def _record(fh, read_data: bool = True) -> tuple[dict[str, bytes], bytes]:  # noqa: ANN001
        head = fh.read(4)
        if len(head) < 4:
            raise EOFError
        n = int.from_bytes(head, "little")
        header = fh.read(n)
        size_b = fh.read(4)
        if len(header) < n or len(size_b) < 4:
            raise EOFError
        size = int.from_bytes(size_b, "little")
        if not read_data:
            fh.seek(size, 1)
            return _fields(header), b""
        data = fh.read(size)
        if len(data) < size:
            raise EOFError
        return _fields(header), data

    def topics(self) -> dict[str, tuple[str, int]]:
        """``{topic: (message type, count)}``; the type normalised as ROS 2 writes it."""
        out: dict[str, tuple[str, int]] = {}
        for cid, c in self.connections.items():
            count = sum(ch.counts.get(cid, 0) for ch in self.chunks)
            t, n = out.get(c.topic, (normalize_msgtype(c.msgtype), 0))
            out[c.topic] = (t, n + count)
        return out

    def batches(self, ids: Sequence[int]) -> Iterator[RawBatch] | None:
        """Raw messages of the connections ``ids``, chunk by chunk; None if not in time order."""
        wanted = set(ids)
        chunks = [c for c in self.chunks if wanted & set(c.counts)]
        for a, b in zip(chunks, chunks[1:], strict=False):
            if b.start_ns < a.end_ns:  # overlapping chunks: the order needs a global merge
                return None
        return self._walk(chunks, wanted)

    def _walk(self, chunks: list[_Ros1Chunk], wanted: set[int]) -> Iterator[RawBatch]:
        import bz2

        entry = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])
        with self.path.open("rb") as fh:
            for ch in chunks:
                fh.seek(ch.pos)
                try:
                    f, data = self._record(fh)
                    compression = f["compression"].decode()
                    index = []
                    for _ in range(len(ch.counts)):
                        fi, di = self._record(fh)
                        conn = struct.unpack("<I", fi["conn"])[0]
                        if conn in wanted:
                            index.append(np.frombuffer(di, dtype=entry))
                except (KeyError, EOFError, struct.error):
                    raise DataError(f"{self.path}: the chunk at byte {ch.pos} is cut off or "
                                    "damaged; the bag was truncated: rebuild its index with "
                                    f"`rosbag reindex {self.path.name}`") from None
                if compression == "none":
                    raw = data
                elif compression == "bz2":
                    raw = bz2.decompress(data)
                elif compression == "lz4":
                    import lz4.frame

                    raw = lz4.frame.decompress(data)
                else:
                    raise DataError(f"{self.path}: chunk compression {compression!r} is not "
                                    "known (ROS 1 writes none, bz2 or lz4)")
                if not index:
                    continue
                idx = np.concatenate(index)
                log_ns = idx["sec"].astype(np.int64) * 1_000_000_000 + idx["nsec"]
                offset = idx["offset"].astype(np.int64)
                order = np.lexsort((offset, log_ns))
                offset, log_ns = offset[order], log_ns[order]
                buf = np.frombuffer(raw, dtype=np.uint8)
                hl = gather(buf, offset, np.dtype("<u4")).astype(np.int64)
                dl_pos = offset + 4 + hl
                sizes = gather(buf, dl_pos, np.dtype("<u4")).astype(np.int64)
                yield RawBatch(buf, dl_pos + 4, sizes, log_ns)


def normalize_msgtype(name: str) -> str:
    """``sensor_msgs/Imu`` -> ``sensor_msgs/msg/Imu`` (the ROS 2 spelling rosbags uses)."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


# ------------------------------------------------------------------------------ MCAP


def _u(b: bytes, i: int, fmt: str) -> tuple[int, int]:
    size = struct.calcsize(fmt)
    return struct.unpack_from(fmt, b, i)[0], i + size


def _string(b: bytes, i: int) -> tuple[str, int]:
    n, i = _u(b, i, "<I")
    return b[i:i + n].decode("utf-8", "replace"), i + n


@dataclass(frozen=True)
class _McapChunk:
    start_ns: int
    end_ns: int
    offset: int
    length: int
    index_offsets: dict[int, int]
    compression: str
    compressed_size: int
    uncompressed_size: int


class McapIndex:
    """The summary of an MCAP file: channels (topics) and chunk indexes; None if absent."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.channels: dict[int, str] = {}
        self.chunks: list[_McapChunk] = []
        size = path.stat().st_size
        with path.open("rb") as fh:
            if fh.read(8) != _MCAP_MAGIC or size < 8 + 37:
                self.ok = False
                return
            fh.seek(size - 37)
            tail = fh.read(37)
            if tail[-8:] != _MCAP_MAGIC or tail[0] != 0x02:
                self.ok = False
                return
            summary_start = struct.unpack_from("<Q", tail, 9)[0]
            if not 8 < summary_start < size - 37:
                self.ok = False
                return
            fh.seek(summary_start)
            summary = fh.read(size - 37 - summary_start)
        i = 0
        while i + 9 <= len(summary):
            op = summary[i]
            n = struct.unpack_from("<Q", summary, i + 1)[0]
            rec = summary[i + 9:i + 9 + n]
            i += 9 + n
            if op == 0x04:
                cid, j = _u(rec, 0, "<H")
                _, j = _u(rec, j, "<H")
                self.channels[cid], _ = _string(rec, j)
            elif op == 0x08:
                start, end, off, length = struct.unpack_from("<QQQQ", rec, 0)
                m, j = _u(rec, 32, "<I")
                offsets = {int(c): int(o) for c, o in
                           struct.iter_unpack("<HQ", rec[j:j + m])}
                j += m + 8  # message_index_length
                comp, j = _string(rec, j)
                csize, usize = struct.unpack_from("<QQ", rec, j)
                self.chunks.append(_McapChunk(start, end, off, length, offsets, comp, csize,
                                              usize))
        self.chunks.sort(key=lambda c: c.offset)
        self.ok = bool(self.chunks)

    def batches(self, ids: Sequence[int]) -> Iterator[RawBatch] | None:
        """Raw messages of the channels ``ids``, chunk by chunk; None if it cannot."""
        if not self.ok:
            return None
        wanted = set(ids)
        chunks = [c for c in self.chunks if wanted & set(c.index_offsets)]
        for a, b in zip(chunks, chunks[1:], strict=False):
            if b.start_ns < a.end_ns:
                return None
        if any(c.compression not in ("", "zstd", "lz4") for c in chunks):
            return None
        return self._walk(chunks, wanted)

    def _walk(self, chunks: list[_McapChunk], wanted: set[int]) -> Iterator[RawBatch]:
        entry = np.dtype([("log_time", "<u8"), ("offset", "<u8")])
        with self.path.open("rb") as fh:
            for ch in chunks:
                fh.seek(ch.offset)
                rec = fh.read(ch.length)
                if len(rec) < ch.length or rec[0] != 0x06:
                    raise DataError(f"{self.path}: the chunk at byte {ch.offset} is cut off or "
                                    "damaged; recover the file (`mcap recover`) and read that")
                j = 9 + 28
                comp, j = _string(rec, j)
                csize, j = _u(rec, j, "<Q")
                payload = rec[j:j + csize]
                raw = _decompress(comp, payload, ch.uncompressed_size)
                index = []
                for cid in sorted(wanted & set(ch.index_offsets)):
                    fh.seek(ch.index_offsets[cid])
                    head = fh.read(15)
                    m = struct.unpack_from("<I", head, 11)[0]
                    index.append(np.frombuffer(fh.read(m), dtype=entry))
                idx = np.concatenate(index)
                log_ns = idx["log_time"].astype(np.int64)
                offset = idx["offset"].astype(np.int64)
                order = np.lexsort((offset, log_ns))
                offset, log_ns = offset[order], log_ns[order]
                buf = np.frombuffer(raw, dtype=np.uint8)
                length = gather(buf, offset + 1, np.dtype("<u8")).astype(np.int64)
                yield RawBatch(buf, offset + 31, length - 22, log_ns)


def _decompress(compression: str, payload: bytes, size: int) -> bytes:
    if compression == "":
        return payload
    if compression == "lz4":
        import lz4.frame

        return lz4.frame.decompress(payload)
    try:
        from compression import zstd  # Python 3.14 (mypy checks 3.11: a missing import)
    except ImportError:
        from backports import zstd  # rosbags' dependency
    return zstd.decompress(payload)


# ------------------------------------------------------------------------------ SQLite3


def _connect(path: Path) -> object:
    """A read-only connection: apsw when installed, else :mod:`sqlite3`.

    apsw is rosbags' own SQLite binding, 1.7x faster per row than the standard library's.
    """
    try:
        import apsw
    except ImportError:
        return sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    return apsw.Connection(str(path), flags=apsw.SQLITE_OPEN_READONLY)


def sqlite_batches(files: Sequence[Path], topic: str) -> Iterator[RawBatch]:
    """Raw messages of ``topic`` from ROS 2 SQLite3 files, in blocks, ordered as rosbags does."""
    db_errors: tuple[type[BaseException], ...] = (sqlite3.DatabaseError, *_apsw_errors())
    for path in files:
        con: Any = _connect(path)
        try:
            ids = [r[0] for r in con.execute("SELECT id FROM topics WHERE name = ?", (topic,))]
            if not ids:
                continue
            # Rows in insertion order are in time order when no stamp goes back (the usual
            # recording); then rosbags' "ORDER BY timestamp" (an index scan, ties by row) gives
            # the same order, and reading by row is 3x faster than through the index.
            back = con.execute("SELECT EXISTS(SELECT 1 FROM messages a JOIN messages b ON "
                               "b.id = a.id + 1 WHERE b.timestamp < a.timestamp)").fetchone()[0]
            cur = con.execute(
                f"SELECT timestamp, data FROM messages WHERE topic_id IN "
                f"({','.join('?' * len(ids))}) ORDER BY {'timestamp' if back else 'id'}", ids)
            yield from rebatch((d, t) for t, d in cur)
        except db_errors as exc:
            raise DataError(f"{path} cannot be read as a ROS 2 SQLite3 bag: {exc}; it may be "
                            "truncated or still being written") from None
        finally:
            con.close()


def _apsw_errors() -> tuple[type[BaseException], ...]:
    try:
        import apsw
    except ImportError:
        return ()
    return (apsw.Error,)


def raw_batch(datas: Sequence[bytes], log_ns: Sequence[int]) -> RawBatch:
    """A :class:`RawBatch` of separate messages (joined into one buffer)."""
    sizes = np.fromiter((len(d) for d in datas), dtype=np.int64, count=len(datas))
    starts = np.zeros(sizes.size, dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    buf = np.frombuffer(b"".join(datas), dtype=np.uint8)
    return RawBatch(buf, starts, sizes, np.asarray(log_ns, dtype=np.int64))


def rebatch(messages: Iterator[tuple[bytes, int]],
            size: int | None = None) -> Iterator[RawBatch]:
    """Group ``(data, log_ns)`` pairs into :class:`RawBatch` of :data:`BATCH_MESSAGES`."""
    size = BATCH_MESSAGES if size is None else size
    datas: list[bytes] = []
    times: list[int] = []
    for data, t in messages:
        datas.append(data)
        times.append(t)
        if len(datas) >= size:
            yield raw_batch(datas, times)
            datas, times = [], []
    if datas:
        yield raw_batch(datas, times)

