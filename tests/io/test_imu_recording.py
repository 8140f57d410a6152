"""IMU recordings: PSINS text format, ROS-style nanosecond stamps, column detection, units."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pytest

from inertest.errors import DataError, InputError, UnitError
from inertest.io.imu_recording import read_imu_recording

PSINS = Path(__file__).parents[2] / ".." / "shared" / "realdata" / "psins" / "lasergyro.imu"
ARCSEC = np.pi / 180 / 3600


def test_psins_small_file_by_hand(tmp_path):
    # Three parameter lines, then increments; LSB 0.1 arcsec and 125 ug*s at 10 ms (PSINS ug is
    # 1e-6 of its glv.g0 = 9.7803267714 m/s^2).
    p = tmp_path / "x.imu"
    p.write_text("% comment\n0 0 -90 0 0 0\n34 108 380 0 10 9.78\n0.1 0.1 0.1 125 125 125\n"
                 + "2 0 -7 0 0 80\n" * 5)
    rec = read_imu_recording(p)
    assert rec.fmt == "psins" and rec.rate_hz == pytest.approx(100.0) and rec.t is None
    np.testing.assert_allclose(rec.gyro[0], [2 * 0.1 * ARCSEC / 0.01, 0, -7 * 0.1 * ARCSEC / 0.01])
    np.testing.assert_allclose(rec.accel[0], [0, 0, 80 * 125e-6 * 9.7803267714 / 0.01])


@pytest.mark.skipif(not PSINS.exists(), reason="shared/realdata not beside the checkout")
def test_psins_real_file_is_one_g_up():
    rec = read_imu_recording(PSINS)
    assert rec.gyro.shape == rec.accel.shape == (184718, 3)
    # Quasi-static, Z up at latitude 34.2 deg: |f| about local gravity 9.797 m/s^2.
    assert np.linalg.norm(rec.accel.mean(axis=0)) == pytest.approx(9.797, abs=0.01)
    # Earth rate 15.04 deg/h = 7.29e-5 rad/s in magnitude.
    assert np.linalg.norm(rec.gyro.mean(axis=0)) == pytest.approx(7.29e-5, rel=0.05)


def test_ros_nanosecond_stamps_read_exactly_and_columns_found(tmp_path):
    n = 50
    stamps = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 5_000_000 + 123
    cols = {"%time": pa.array(stamps, pa.int64())}
    for i, a in enumerate("xyz"):
        cols[f"field.angular_velocity.{a}"] = np.full(n, float(i))
        cols[f"field.linear_acceleration.{a}"] = np.full(n, 9.8 * (a == "z"))
    p = tmp_path / "imu.csv"
    pacsv.write_csv(pa.table(cols), p)
    rec = read_imu_recording(p)
    # Exact: every interval 5 ms (a float64 of 1.7e18 ns would be off by up to 128 ns).
    np.testing.assert_allclose(np.diff(rec.t), 5e-3, rtol=0, atol=1e-15)
    assert rec.gyro_names[0] == "field.angular_velocity.x"
    np.testing.assert_allclose(rec.accel[:, 2], 9.8)


def test_secs_nsecs_and_units(tmp_path):
    n = 20
    t = np.arange(n) * 0.01
    p = tmp_path / "imu.csv"
    pacsv.write_csv(pa.table({
        "secs": pa.array(100 + (t // 1).astype(np.int64)),
        "nsecs": pa.array(np.round((t % 1) * 1e9).astype(np.int64)),
        "wx": np.full(n, 90.0), "az": np.full(n, 1.0)}), p)
    rec = read_imu_recording(p, time_column="secs,nsecs", gyro_columns="wx",
                             accel_columns="az", gyro_unit="deg/s", accel_unit="g")
    np.testing.assert_allclose(rec.t, t, atol=1e-12)
    np.testing.assert_allclose(rec.gyro[:, 0], np.pi / 2)
    np.testing.assert_allclose(rec.accel[:, 0], 9.80665)


def test_errors(tmp_path):
    p = tmp_path / "imu.csv"
    pacsv.write_csv(pa.table({"t": np.arange(5.0), "u": np.zeros(5)}), p)
    with pytest.raises(DataError, match="no gyro or accelerometer columns.*--gyro-columns"):
        read_imu_recording(p)
    with pytest.raises(DataError, match="no column 'gx'.*fix --gyro-columns"):
        read_imu_recording(p, gyro_columns="gx")
    with pytest.raises(UnitError, match="--gyro-unit"):
        read_imu_recording(p, gyro_columns="u", gyro_unit="rpm")
    with pytest.raises(InputError, match="--format parquet needs"):
        read_imu_recording(p, fmt="parquet")
    bad = tmp_path / "bad.imu"
    bad.write_text("0 0 0 0 0 0\n0 0 0 0 0 0\n0.1 0.1 0.1 125 125 125\n1 2 3\n")
    with pytest.raises(DataError, match="sampling interval"):
        read_imu_recording(bad, fmt="psins")


PSINS_HEAD = b"% psins\n0 0 0 0 0 0\n34 108 380 0 10 9.8\n0.1 0.1 0.1 125 125 125\n"


@pytest.mark.parametrize("suffix", [".xz", ".gz"])
def test_a_compression_bomb_is_refused_before_it_is_parsed(tmp_path, monkeypatch, suffix):
    """Issue 34: a small .xz of a few GB of text ran into out-of-memory after 100 s. It is
    measured while decompressing, nothing kept, and refused past the cap (here 1 MiB)."""
    import gzip
    import lzma

    from inertest.io import imu_recording

    monkeypatch.setattr(imu_recording, "MAX_DECOMPRESSED_BYTES", 1 << 20)
    body = PSINS_HEAD + b"1 2 3 4 5 6\n" * 100_000  # 1.2 MB of text
    p = tmp_path / f"bomb.imu{suffix}"
    p.write_bytes(lzma.compress(body) if suffix == ".xz" else gzip.compress(body))
    assert p.stat().st_size < 20_000
    with pytest.raises(DataError, match=r"bomb.imu\.(xz|gz) is larger than 1 MiB when "
                       "decompressed"):
        read_imu_recording(p)
    small = tmp_path / f"ok.imu{suffix}"
    part = body[:len(PSINS_HEAD) + 12 * 10_000]
    small.write_bytes(lzma.compress(part) if suffix == ".xz" else gzip.compress(part))
    assert read_imu_recording(small).gyro.shape[1] == 3


def test_a_file_of_one_endless_line_is_sniffed_in_bounded_memory(tmp_path):
    import lzma

    p = tmp_path / "one.imu.xz"
    p.write_bytes(lzma.compress(b"1" * 5_000_000))  # more than 40 sniffed lines of 64 KiB
    with pytest.raises((DataError, InputError)):
        read_imu_recording(p)
