"""Recordings for the tests and benchmarks, written by the formats' own libraries.

``write_imu_bag`` writes sensor_msgs/Imu messages with :mod:`rosbags`' writers (ROS 1 bag,
ROS 2 bag folder in SQLite3 or MCAP storage), serialised by rosbags' own serialisers.
``fast_ros1_bag`` writes a large ROS 1 bag with numpy, chunk by chunk (for the 1e8-message
benchmark and the memory test: rosbags' writer takes ~25 us a message); a test checks that
rosbags reads it back as written.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

ROS1_IMU_MD5 = "6a62c6daae103f4ff57a132d6f95cec2"
T0_NS = 1_700_000_000_000_000_000


def _store(kind: str):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)


def imu_message(ts, ns: int, gyro, accel, frame_id: str = "imu_link", seq: int = 0,
                ros1: bool = False):
    """A sensor_msgs/msg/Imu of the typestore ``ts``."""
    t = ts.types
    stamp = t["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000,
                                             nanosec=ns % 1_000_000_000)
    header = (t["std_msgs/msg/Header"](seq=seq, stamp=stamp, frame_id=frame_id) if ros1
              else t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id))
    v3, q = t["geometry_msgs/msg/Vector3"], t["geometry_msgs/msg/Quaternion"]
    cov = np.zeros(9)
    return t["sensor_msgs/msg/Imu"](
        header=header, orientation=q(x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=cov,
        angular_velocity=v3(x=float(gyro[0]), y=float(gyro[1]), z=float(gyro[2])),
        angular_velocity_covariance=cov,
        linear_acceleration=v3(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
        linear_acceleration_covariance=cov)


def write_imu_bag(path: Path, kind: str, stamps_ns, gyro, accel, *, topic: str = "/imu",
                  frame_ids=None, log_ns=None, extra=(), compression: str | None = None
                  ) -> Path:
    """Write Imu messages with rosbags' writer: ``kind`` ``ros1``, ``sqlite3`` or ``mcap``.

    ``extra``: more ``(topic, msgtype, [(log_ns, message), ...])`` to write beside.
    ``frame_ids``: one per message (default ``imu_link``); ``log_ns`` the bag times (default
    the stamps). ``compression``: ``lz4``/``bz2`` chunks (ROS 1) or ``zstd`` files (ROS 2).
    """
    ts = _store(kind)
    ros1 = kind == "ros1"
    if ros1:
        from rosbags.rosbag1 import Writer

        w = Writer(path)
        if compression is not None:
            w.set_compression(getattr(Writer.CompressionFormat, compression.upper()))
        ser = ts.serialize_ros1
    else:
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

        w = Writer(path, version=9, storage_plugin=(
            StoragePlugin.SQLITE3 if kind == "sqlite3" else StoragePlugin.MCAP))
        if compression is not None:
            w.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
        ser = ts.serialize_cdr
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    logs = stamps if log_ns is None else np.asarray(log_ns, dtype=np.int64)
    with w:
        conn = w.add_connection(topic, "sensor_msgs/msg/Imu", typestore=ts)
        others = [(w.add_connection(t, mt, typestore=ts), msgs) for t, mt, msgs in extra]
        pending = sorted([(int(logs[i]), 0, i) for i in range(stamps.size)]
                         + [(int(t), k + 1, m) for k, (_, msgs) in enumerate(others)
                            for t, m in msgs], key=lambda x: (x[0], x[1]))
        for t, which, item in pending:
            if which == 0:
                i = item
                fid = "imu_link" if frame_ids is None else frame_ids[i]
                msg = imu_message(ts, int(stamps[i]), gyro[i], accel[i], fid, i, ros1)
                w.write(conn, t, ser(msg, "sensor_msgs/msg/Imu"))
            else:
                c, _ = others[which - 1]
                w.write(c, t, ser(item, c.msgtype))
    return path


# ------------------------------------------------------------------------------ fast ROS 1


def _field(name: str, value: bytes) -> bytes:
    body = name.encode() + b"=" + value
    return struct.pack("<I", len(body)) + body


def _record(fields: list[bytes], data: bytes) -> bytes:
    header = b"".join(fields)
    return struct.pack("<I", len(header)) + header + struct.pack("<I", len(data)) + data


def _time(ns: int) -> bytes:
    return struct.pack("<II", ns // 1_000_000_000, ns % 1_000_000_000)


def fast_ros1_bag(path: Path, n: int, *, rate_hz: float = 1000.0, seed: int = 0,
                  chunk: int = 1 << 15, compression: str = "none", topic: str = "/imu",
                  frame_id: str = "imu", progress=None) -> Path:
    """A ROS 1 bag of ``n`` Imu messages at ``rate_hz`` (white noise, seeded), written with
    numpy a chunk at a time (memory: one chunk). Angular velocity ~ N(0, 0.01) rad/s, linear
    acceleration ~ N((0, 0, 9.81), 0.05) m/s^2, quantised to float32 values (compressible).
    """
    msgdef = _store("ros1").generate_msgdef("sensor_msgs/msg/Imu")[0]
    fid = frame_id.encode()
    payload = np.dtype([("seq", "<u4"), ("sec", "<u4"), ("nsec", "<u4"), ("flen", "<u4"),
                        ("frame", f"S{len(fid)}" if fid else "V0"), ("body", "<f8", (37,))])
    rec = np.dtype([("hlen", "<u4"), ("f_op", "<u4"), ("op_name", "S3"), ("op", "u1"),
                    ("f_conn", "<u4"), ("conn_name", "S5"), ("conn", "<u4"),
                    ("f_time", "<u4"), ("time_name", "S5"), ("sec", "<u4"), ("nsec", "<u4"),
                    ("dlen", "<u4"), ("payload", payload)])
    assert rec.itemsize == 4 + 38 + 4 + payload.itemsize
    rng = np.random.default_rng(seed)
    step_ns = round(1e9 / rate_hz)
    chunks = []
    import lz4.frame

    with path.open("wb") as fh:
        fh.write(b"#ROSBAG V2.0\n")
        head_pos = fh.tell()
        fh.write(b"\0" * 4096)
        for a in range(0, n, chunk):
            k = min(chunk, n - a)
            ns = T0_NS + (a + np.arange(k, dtype=np.int64)) * step_ns
            r = np.zeros(k, dtype=rec)
            r["hlen"], r["f_op"], r["op_name"], r["op"] = 38, 4, b"op=", 2
            r["f_conn"], r["conn_name"], r["conn"] = 9, b"conn=", 0
            r["f_time"], r["time_name"] = 13, b"time="
            r["sec"], r["nsec"] = ns // 1_000_000_000, ns % 1_000_000_000
            r["dlen"] = payload.itemsize
            p = r["payload"]
            p["seq"] = a + np.arange(k)
            p["sec"], p["nsec"], p["flen"] = r["sec"], r["nsec"], len(fid)
            if fid:
                p["frame"] = fid
            body = np.zeros((k, 37))
            body[:, 3] = 1.0
            body[:, 13:16] = rng.normal(0.0, 0.01, (k, 3)).astype(np.float32)
            body[:, 25:28] = (np.array([0.0, 0.0, 9.81])
                              + rng.normal(0.0, 0.05, (k, 3))).astype(np.float32)
            p["body"] = body
            raw = r.tobytes()
            data = raw if compression == "none" else lz4.frame.compress(raw)
            pos = fh.tell()
            fh.write(_record([_field("op", b"\x05"), _field("compression", compression.encode()),
                              _field("size", struct.pack("<I", len(raw)))], data))
            index = np.zeros(k, dtype=[("sec", "<u4"), ("nsec", "<u4"), ("off", "<u4")])
            index["sec"], index["nsec"] = r["sec"], r["nsec"]
            index["off"] = np.arange(k) * rec.itemsize
            fh.write(_record([_field("op", b"\x04"), _field("ver", struct.pack("<I", 1)),
                              _field("conn", struct.pack("<I", 0)),
                              _field("count", struct.pack("<I", k))], index.tobytes()))
            chunks.append((pos, int(ns[0]), int(ns[-1]), k))
            if progress is not None:
                progress(a + k, n)
        index_pos = fh.tell()
        conn_data = b"".join([_field("topic", topic.encode()),
                              _field("type", b"sensor_msgs/Imu"),
                              _field("md5sum", ROS1_IMU_MD5.encode()),
                              _field("message_definition", msgdef.encode())])
        fh.write(_record([_field("op", b"\x07"), _field("conn", struct.pack("<I", 0)),
                          _field("topic", topic.encode())], conn_data))
        for pos, t0, t1, k in chunks:
            fh.write(_record([_field("op", b"\x06"), _field("ver", struct.pack("<I", 1)),
                              _field("chunk_pos", struct.pack("<Q", pos)),
                              _field("start_time", _time(t0)), _field("end_time", _time(t1)),
                              _field("count", struct.pack("<I", 1))],
                             struct.pack("<II", 0, k)))
        head = _record([_field("op", b"\x03"), _field("index_pos", struct.pack("<Q", index_pos)),
                        _field("conn_count", struct.pack("<I", 1)),
                        _field("chunk_count", struct.pack("<I", len(chunks)))], b"")
        fh.seek(head_pos)
        fh.write(head[:-4] + struct.pack("<I", 4096 - len(head)) + b" " * (4096 - len(head)))
    return path
