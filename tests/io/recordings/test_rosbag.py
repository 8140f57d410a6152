"""ROS 1 bags, ROS 2 bags (SQLite3, MCAP) and MCAP files against rosbags' own reader.

Bags are written by rosbags' writers (ROS 1, ROS 2 with SQLite3 or MCAP storage) from the real
recordings in ../shared/realdata (imu_tk's Xsens MTi, PSINS' laser-gyro IMU) and read back
through inertest, bit for bit; the numpy decoding of sensor_msgs/Imu is checked against
rosbags' deserialiser message by message on bags of every container, odd frame_id lengths
(CDR alignment) and compressed chunks included.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

import inertest  # noqa: E402
from inertest.cli import main  # noqa: E402
from inertest.errors import DataError  # noqa: E402
from inertest.io.recordings import open_recording  # noqa: E402
from recording_factory import T0_NS, fast_ros1_bag, write_imu_bag  # noqa: E402

KINDS = ("ros1", "sqlite3", "mcap")
GYRO = [f"angular_velocity.{a}" for a in "xyz"]
ACCEL = [f"linear_acceleration.{a}" for a in "xyz"]


def _name(kind: str) -> str:
    return {"ros1": "imu.bag", "sqlite3": "imu_sqlite", "mcap": "imu_mcap"}[kind]


def _rosbags_columns(path: Path, topic: str = "/imu") -> dict[str, np.ndarray]:
    """Every Imu field by rosbags' AnyReader and deserialiser, message by message."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list] = {}
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic == topic]
        for conn, t, raw in r.messages(connections=conns):
            m = r.deserialize(raw, conn.msgtype)
            row = {"bag_time_ns": t, "header.stamp.sec": m.header.stamp.sec,
                   "header.stamp.nanosec": m.header.stamp.nanosec,
                   "header.frame_id": m.header.frame_id}
            for f in ("angular_velocity", "linear_acceleration"):
                for a in "xyz":
                    row[f"{f}.{a}"] = getattr(getattr(m, f), a)
            for a in "xyzw":
                row[f"orientation.{a}"] = getattr(m.orientation, a)
            for f in ("orientation_covariance", "angular_velocity_covariance",
                      "linear_acceleration_covariance"):
                for i, v in enumerate(getattr(m, f)):
                    row[f"{f}[{i}]"] = v
            for k, v in row.items():
                out.setdefault(k, []).append(v)
    return {k: np.asarray(v) for k, v in out.items()}


@pytest.fixture(scope="module")
def odd_bags(tmp_path_factory):
    """Bags of every container with varying frame_id lengths (CDR alignment), a second IMU
    topic of another rate, a non-IMU topic, and lz4 / bz2 ROS 1 chunks."""
    from recording_factory import _store

    d = tmp_path_factory.mktemp("odd")
    rng = np.random.default_rng(7)
    n = 300
    stamps = T0_NS + np.arange(n, dtype=np.int64) * 5_000_000
    gyro, accel = rng.normal(0, 0.1, (n, 3)), rng.normal(0, 1, (n, 3)) + [0, 0, 9.8]
    gyro[5] = [np.nan, -0.0, 1e300]  # values a decoder could garble
    frames = [("", "a", "ab", "abc", "imu_link", "x" * 13)[i % 6] for i in range(n)]
    bags = {}
    for kind in KINDS:
        ts = _store(kind)
        v3 = ts.types["geometry_msgs/msg/Vector3Stamped"]
        hdr, tm = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
        vec = ts.types["geometry_msgs/msg/Vector3"]
        extra = [("/mag", "geometry_msgs/msg/Vector3Stamped",
                  [(int(stamps[i]) + 1, v3(header=hdr(stamp=tm(sec=1, nanosec=i), frame_id="m")
                                           if kind != "ros1" else
                                           hdr(seq=i, stamp=tm(sec=1, nanosec=i), frame_id="m"),
                                           vector=vec(x=float(i), y=0.5, z=-1.0)))
                   for i in range(0, n, 3)])]
        bags[kind] = write_imu_bag(d / _name(kind), kind, stamps, gyro, accel,
                                   frame_ids=frames, extra=extra)
    for comp in ("lz4", "bz2"):
        bags[f"ros1-{comp}"] = write_imu_bag(d / f"imu_{comp}.bag", "ros1", stamps, gyro, accel,
                                             frame_ids=frames, compression=comp)
    bags["mcap-file"] = next((d / _name("mcap")).glob("*.mcap"))
    bags["sqlite-file"] = next((d / _name("sqlite3")).glob("*.db3"))
    bags["ros2-zstd"] = write_imu_bag(d / "imu_zstd", "mcap", stamps, gyro, accel,
                                      frame_ids=frames, compression="zstd")
    return bags, stamps, gyro, accel, frames


@pytest.mark.parametrize("which", ["ros1", "sqlite3", "mcap", "ros1-lz4", "ros1-bz2",
                                   "mcap-file", "sqlite-file", "ros2-zstd"])
def test_imu_decoding_equals_rosbags_deserialiser_field_by_field(odd_bags, which):
    bags, stamps, gyro, accel, frames = odd_bags
    path = bags[which]
    got = inertest.load_data(path, topic="/imu")
    ref = _rosbags_columns(path)
    assert set(ref) <= set(got)
    for k, v in ref.items():
        if v.dtype.kind == "f":
            assert np.array_equal(got[k], v, equal_nan=True), k
            assert np.array_equal(np.signbit(got[k]), np.signbit(v)), k  # -0.0 stays -0.0
        else:
            assert list(got[k]) == list(v), k
    # and what was written, bit for bit
    assert np.array_equal(np.column_stack([got[c] for c in GYRO]), gyro, equal_nan=True)
    assert np.array_equal(np.column_stack([got[c] for c in ACCEL]), accel)
    assert np.array_equal(got["header.stamp.sec"] * 1_000_000_000 + got["header.stamp.nanosec"],
                          stamps)
    assert list(got["header.frame_id"]) == frames


def test_the_container_walkers_read_what_rosbags_reads(odd_bags):
    bags = odd_bags[0]
    from inertest.io.recordings.rosbag import RosBag

    for which in ("ros1", "ros1-lz4", "sqlite3", "mcap", "mcap-file", "sqlite-file"):
        assert RosBag(bags[which]).raw_batches("/imu")[1] == "walker", which
    assert RosBag(bags["ros2-zstd"]).raw_batches("/imu")[1] == "rosbags"  # compressed files


def test_other_message_types_through_rosbags(odd_bags):
    bags = odd_bags[0]
    for kind in KINDS:
        got = inertest.load_data(bags[kind], topic="/mag")
        assert np.array_equal(got["vector.x"], np.arange(0, 300, 3.0))
        assert set(got["header.frame_id"]) == {"m"} and "bag_time_ns" in got


def test_topics_are_named_in_every_topic_error(odd_bags):
    bags = odd_bags[0]
    with pytest.raises(DataError, match=r"no topic '/imu0'; topics found: /imu "
                                        r"\(sensor_msgs/msg/Imu, 300 messages\), /mag "):
        inertest.load_data(bags["ros1"], topic="/imu0")
    with pytest.raises(DataError, match=r"holds geometry_msgs/msg/Vector3Stamped, not IMU "
                                        r"readings .*topics found: /imu"):
        open_recording(bags["mcap"], topic="/mag", imu=True)


def test_a_fast_written_bag_reads_back_in_rosbags(tmp_path):
    """The benchmark's numpy writer (tests/recording_factory.py) writes what rosbags reads."""
    path = fast_ros1_bag(tmp_path / "f.bag", 5000, chunk=1500, compression="lz4")
    ref = _rosbags_columns(path)
    got = inertest.load_data(path)
    assert ref["angular_velocity.x"].size == 5000
    for k in ("angular_velocity.x", "linear_acceleration.z", "header.stamp.nanosec",
              "bag_time_ns"):
        assert np.array_equal(got[k], ref[k]), k


# ------------------------------------------------------------------------------ real records


def _xsens(realdata: Path):
    acc = np.loadtxt(realdata / "imu_tk" / "xsens_acc.txt")
    gyr = np.loadtxt(realdata / "imu_tk" / "xsens_gyro.txt")
    assert np.array_equal(acc[:, 0], gyr[:, 0])
    ns = np.round(acc[:, 0] * 1e9).astype(np.int64)
    return ns, gyr[:, 1:], acc[:, 1:]


@pytest.fixture(scope="module")
def xsens_bags(tmp_path_factory, request):
    realdata = Path(__file__).resolve().parents[3].parent / "shared" / "realdata"
    if not realdata.is_dir():
        pytest.skip("../shared/realdata not present")
    d = tmp_path_factory.mktemp("xsens")
    ns, gyr, acc = _xsens(realdata)
    return {k: write_imu_bag(d / _name(k), k, ns, gyr, acc) for k in KINDS}, ns, gyr, acc


@pytest.mark.parametrize("kind", KINDS)
def test_xsens_recording_through_a_bag_is_bit_exact(xsens_bags, kind):
    bags, ns, gyr, acc = xsens_bags
    got = inertest.load_data(bags[kind])
    assert np.array_equal(np.column_stack([got[c] for c in GYRO]), gyr)
    assert np.array_equal(np.column_stack([got[c] for c in ACCEL]), acc)
    assert np.array_equal(got["header.stamp.sec"] * 1_000_000_000 + got["header.stamp.nanosec"],
                          ns)


@pytest.mark.slow
def test_psins_recording_bag_and_mcap_bit_exact_and_noise_to_the_last_digit(
        realdata_dir, tmp_path, capsys):
    """PSINS' laser-gyro IMU (1847 s at 100 Hz) as Imu messages in a ROS 1 bag and an MCAP
    file: read back bit for bit; ``inertest noise`` gives the same channels, every digit."""
    from inertest.io.imu_recording import read_psins

    rec = read_psins(realdata_dir / "psins" / "lasergyro.imu")
    n = rec.gyro.shape[0]
    ns = T0_NS + np.arange(n, dtype=np.int64) * 10_000_000
    outs = {}
    assert main(["noise", str(realdata_dir / "psins" / "lasergyro.imu"), "--json"]) == 0
    original = json.loads(capsys.readouterr().out)["result"]
    for kind in ("ros1", "mcap"):
        path = write_imu_bag(tmp_path / _name(kind), kind, ns, rec.gyro, rec.accel)
        if kind == "mcap":
            path = next(path.glob("*.mcap"))
        got = inertest.load_data(path, topic="/imu")
        assert np.array_equal(np.column_stack([got[c] for c in GYRO]), rec.gyro)
        assert np.array_equal(np.column_stack([got[c] for c in ACCEL]), rec.accel)
        assert main(["noise", str(path), "--topic", "/imu", "--rate", "100", "--json"]) == 0
        outs[kind] = json.loads(capsys.readouterr().out)["result"]
    names = dict(zip([*GYRO, *ACCEL], [*rec.gyro_names, *rec.accel_names], strict=True))
    for kind, doc in outs.items():
        assert doc["rate_hz"] == original["rate_hz"] == 100.0
        assert doc["timing"]["n_samples"] == original["timing"]["n_samples"] == n
        for ros_name, psins_name in names.items():
            a, b = dict(doc["channels"][ros_name]), dict(original["channels"][psins_name])
            a.pop("name"), b.pop("name")
            a["messages"] = [m.replace(ros_name, psins_name) for m in a["messages"]]
            assert a == b, (kind, ros_name)  # every number, every digit


def test_unit_options_apply_to_imu_messages_and_say_so(tmp_path):
    """A driver publishing deg/s against REP 145: --gyro-unit deg/s is applied, and noted.

    (It was silently ignored: densities 57.3x too large, found by an independent review.)
    """
    from inertest.io.recordings.imu import open_imu

    rng = np.random.default_rng(3)
    n = 200
    ns = T0_NS + np.arange(n, dtype=np.int64) * 5_000_000
    gyr, acc = rng.normal(0, 1, (n, 3)), rng.normal(0, 0.1, (n, 3)) + [0, 0, 1]
    bag = write_imu_bag(tmp_path / "imu.bag", "ros1", ns, gyr, acc)
    si = open_imu(bag, topic="/imu")
    assert np.array_equal(si.gyro, gyr) and "message type's units" in " ".join(si.notes)
    other = open_imu(bag, topic="/imu", gyro_unit="deg/s", accel_unit="g")
    np.testing.assert_allclose(other.gyro, gyr * np.pi / 180, rtol=1e-15)
    np.testing.assert_allclose(other.accel, acc * 9.80665, rtol=1e-15)
    assert "REP 145" in " ".join(other.notes)
