"""PX4 ULog: the real log in ../shared/realdata/px4/sample.ulg through inertest equals what
pyulog itself returns, topic by topic, sample for sample."""

from __future__ import annotations

import json

import numpy as np
import pytest

pyulog = pytest.importorskip("pyulog")

import inertest  # noqa: E402
from inertest.cli import main  # noqa: E402
from inertest.errors import DataError  # noqa: E402
from inertest.io.recordings.ulog import vehicle_imu_rates  # noqa: E402


def test_every_topic_of_the_real_log_equals_pyulog_sample_for_sample(realdata_dir):
    path = realdata_dir / "px4" / "sample.ulg"
    ref = pyulog.ULog(str(path))
    assert len(ref.data_list) > 10
    for d in ref.data_list:
        topic = d.name if d.multi_id == 0 else f"{d.name}:{d.multi_id}"
        got = inertest.load_data(path, topic=topic)
        assert list(got) == list(d.data), topic
        for k, v in d.data.items():
            assert got[k].dtype == v.dtype and np.array_equal(got[k], v, equal_nan=True), \
                (topic, k)


def test_the_imu_topic_is_found_and_its_units_are_px4s(realdata_dir, tmp_path, capsys):
    path = realdata_dir / "px4" / "sample.ulg"
    ref = pyulog.ULog(str(path), ["sensor_combined"]).get_dataset("sensor_combined").data
    assert main(["noise", str(path), "--gaps", "longest", "--json",
                 "--kalibr", str(tmp_path / "imu.yaml")]) == 0
    doc = json.loads(capsys.readouterr().out)
    res = doc["result"]
    assert list(res["channels"]) == ["gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]",
                                     "accelerometer_m_s2[0]", "accelerometer_m_s2[1]",
                                     "accelerometer_m_s2[2]"]
    # PX4 stamps are microseconds: the median interval of sensor_combined is 4 ms (250 Hz)
    dt_us = np.median(np.diff(ref["timestamp"].astype(np.int64)))
    assert res["timing"]["interval_s"] == pytest.approx(dt_us * 1e-6, rel=1e-12)
    assert any("sensor_combined read by pyulog" in m for m in doc["messages"])
    assert "update_rate: 250" in (tmp_path / "imu.yaml").read_text()


def test_vehicle_imu_increments_become_rates():
    cols = {"delta_angle_dt": np.array([4000, 5000], dtype=np.uint16),
            "delta_velocity_dt": np.array([2000, 2000], dtype=np.uint16),
            **{f"delta_angle[{i}]": np.array([4e-3, 1e-3], dtype=np.float32) for i in range(3)},
            **{f"delta_velocity[{i}]": np.array([0.02, -0.02], dtype=np.float32)
               for i in range(3)}}
    out = vehicle_imu_rates(cols, path=None)  # type: ignore[arg-type]
    np.testing.assert_allclose(out["gyro_x"], [np.float32(4e-3) / 4e-3, np.float32(1e-3) / 5e-3])
    np.testing.assert_allclose(out["accel_z"], [np.float32(0.02) / 2e-3, np.float32(-0.02) / 2e-3])


def test_topic_errors_name_the_logged_topics(realdata_dir):
    path = realdata_dir / "px4" / "sample.ulg"
    with pytest.raises(DataError, match=r"no topic 'sensor_gyro'; topics found: .*"
                                        r"sensor_combined \(17070 messages\)"):
        inertest.load_data(path, topic="sensor_gyro")
