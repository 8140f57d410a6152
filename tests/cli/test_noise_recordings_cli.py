"""``inertest noise`` on recordings (issue 30): ROS 2 bag folders with --topic and --kalibr, and
a long recording streamed (here: made long by lowering the threshold), equal to the in-memory
run and leaving no temporary files, also when it fails."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml

from inertest.cli import main

pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    from recording_factory import T0_NS, write_imu_bag

    d = tmp_path_factory.mktemp("bags")
    rng = np.random.default_rng(11)
    n = 6000
    ns = T0_NS + np.arange(n, dtype=np.int64) * 5_000_000
    gyro = rng.normal(0, 0.02, (n, 3)) + np.cumsum(rng.normal(0, 1e-4, (n, 3)), axis=0)
    accel = rng.normal(0, 0.05, (n, 3)) + [0, 0, 9.81]
    gyro[[100, 2500], 1] += 5.0  # two outliers
    return {k: write_imu_bag(d / f"imu_{k}", k, ns, gyro, accel) for k in ("sqlite3", "mcap")}


@pytest.mark.parametrize("kind", ["sqlite3", "mcap"])
def test_a_ros2_bag_folder_gives_the_kalibr_yaml(bags, kind, tmp_path, capsys):
    out = tmp_path / "imu.yaml"
    assert main(["noise", str(bags[kind]), "--topic", "/imu", "--kalibr", str(out),
                 "--outliers", "clip"]) == 0
    text = capsys.readouterr().out
    assert "angular_velocity.x" in text and f"kalibr: {out}" in text
    y = yaml.safe_load(out.read_text())
    assert y["rostopic"] == "/imu" and y["update_rate"] == 200
    assert y["gyroscope_noise_density"] == pytest.approx(0.02 / np.sqrt(200), rel=0.1)


def test_a_long_recording_is_streamed_as_the_short_one_is_analysed(bags, monkeypatch,
                                                                   tmp_path, capsys):
    from inertest.io.recordings import imu

    argv = ["noise", str(bags["mcap"]), "--outliers", "clip", "--detrend", "--json"]
    assert main(argv) == 0
    ref = json.loads(capsys.readouterr().out)
    monkeypatch.setattr(imu, "STREAM_SAMPLES", 1000)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where the decoded files go
    assert main(argv) == 0
    got = json.loads(capsys.readouterr().out)
    assert any("streamed" in m for m in got["messages"])
    assert list(tmp_path.iterdir()) == []  # the temporary files are gone
    r, g = ref["result"], got["result"]
    assert g["timing"]["segment"] == r["timing"]["segment"]
    for name, ch in r["channels"].items():
        assert g["channels"][name]["outliers"] == ch["outliers"]
        np.testing.assert_allclose(g["channels"][name]["oadev"]["dev"], ch["oadev"]["dev"],
                                   rtol=1e-10)
        assert g["channels"][name]["kalibr"]["noise_density"]["value"] == pytest.approx(
            ch["kalibr"]["noise_density"]["value"], rel=1e-9)
    assert r["channels"]["angular_velocity.y"]["outliers"] == 2
    # a failure after decoding leaves nothing either
    assert main(["noise", str(bags["mcap"]), "--rate", "50"]) == 2
    assert "the time stamps say 200 Hz" in capsys.readouterr().err
    assert list(Path(tmp_path).iterdir()) == []
