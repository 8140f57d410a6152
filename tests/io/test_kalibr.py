"""Kalibr / OpenVINS imu.yaml: written values, comments, round trip, bad files."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from inertest.errors import DataError
from inertest.io.kalibr import KEYS, kalibr_yaml_text, read_kalibr_yaml, write_kalibr_yaml
from inertest.noise.imu import analyse_imu_noise


@pytest.fixture(scope="module")
def result():
    g = np.random.default_rng(7)
    n, dt = 40_000, 0.01
    gyro = 1e-3 / math.sqrt(dt) * g.standard_normal((n, 3))
    accel = 2e-3 / math.sqrt(dt) * g.standard_normal((n, 2))
    return analyse_imu_noise(None, gyro, accel, rate_hz=100.0)


def test_yaml_round_trip_and_values(tmp_path, result):
    path = write_kalibr_yaml(tmp_path / "imu.yaml", result, source="sim")
    back = read_kalibr_yaml(path)
    doc = yaml.safe_load(path.read_text())  # PyYAML directly: a plain Kalibr mapping
    assert doc["rostopic"] == "/imu0" and doc["update_rate"] == 100
    for kind, key in (("gyro", "gyroscope"), ("accelerometer", "accelerometer")):
        terms = result.kalibr(kind)
        for param in ("noise_density", "random_walk"):
            want = terms[param].value
            assert back[f"{key}_{param}"] == pytest.approx(want, rel=1e-9)
            assert doc[f"{key}_{param}"] == pytest.approx(want, rel=1e-9)
            # The largest over the axes (conservative).
            axes = [getattr(c, "density" if param == "noise_density" else "random_walk").value
                    for c in result.sensor(kind)]
            assert want == max(axes)
    assert back["update_rate"] == 100.0


def test_yaml_says_what_each_number_is(result):
    text = kalibr_yaml_text(result, source="sim")
    assert "[rad/s/sqrt(Hz)]" in text and "[rad/s^2/sqrt(Hz)]" in text
    assert "[m/s^2/sqrt(Hz)]" in text and "[m/s^3/sqrt(Hz)]" in text
    assert "NOT the bias instability B" in text
    # White noise only: N fitted, K only bounded, and the yaml says so on the K line.
    for line in text.splitlines():
        if line.startswith("gyroscope_noise_density"):
            assert line.endswith("fitted")
        if line.startswith("gyroscope_random_walk"):
            assert line.endswith("upper bound")
    assert "UPPER BOUND, not a measurement" in text


def test_openvins_nested_and_opencv_header(tmp_path):
    p = tmp_path / "kalibr_imu_chain.yaml"
    p.write_text("%YAML:1.0\n\nimu0:\n  T_i_b: [[1, 0], [0, 1]]\n"
                 "  accelerometer_noise_density: 2.0000e-03\n"
                 "  accelerometer_random_walk: 3.0000e-03\n"
                 "  gyroscope_noise_density: 1.6968e-04\n"
                 "  gyroscope_random_walk: 1.9393e-05\n"
                 "  rostopic: /imu0\n  update_rate: 200.0\n")
    notes = []
    got = read_kalibr_yaml(p, notes=notes)
    assert len(notes) == 1 and "no unit comment" in notes[0]
    assert got == {"gyroscope_noise_density": 1.6968e-04, "gyroscope_random_walk": 1.9393e-05,
                   "accelerometer_noise_density": 2e-3, "accelerometer_random_walk": 3e-3,
                   "update_rate": 200.0}


@pytest.mark.parametrize(("text", "match"), [
    ("a: [1, 2\n", "not valid YAML"),
    ("- 1\n- 2\n", "no YAML mapping"),
    ("rostopic: /imu0\n", "none of the Kalibr keys"),
    ("gyroscope_noise_density: -1.0\n", "non-negative number"),
    ("gyroscope_noise_density: abc\n", "non-negative number"),
])
def test_bad_yaml(tmp_path, text, match):
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(DataError, match=match):
        read_kalibr_yaml(p)


def test_keys_are_kalibrs():
    assert KEYS == ("gyroscope_noise_density", "gyroscope_random_walk",
                    "accelerometer_noise_density", "accelerometer_random_walk")


def test_review19_unit_comments_converted_contradicting_refused_missing_warned(tmp_path):
    """Review 19: a yaml whose comments state other units was read as Kalibr's SI silently.
    0.002 deg/sqrt(h) = 0.002 (pi/180) / 60 rad/sqrt(s); 20 ug/sqrt(Hz) = 20e-6 g0."""
    p = tmp_path / "units.yaml"
    p.write_text("gyroscope_noise_density: 0.002  # [deg/sqrt(h)]\n"
                 "gyroscope_random_walk: 1.0e-09 # [rad/s^2/sqrt(Hz)]\n"
                 "accelerometer_noise_density: 20 # [ug/sqrt(Hz)]\n"
                 "accelerometer_random_walk: 1.0e-05\nupdate_rate: 100.0\n")
    notes = []
    got = read_kalibr_yaml(p, notes=notes)
    assert got["gyroscope_noise_density"] == pytest.approx(0.002 * math.pi / 180 / 60,
                                                           rel=1e-12)
    assert got["accelerometer_noise_density"] == pytest.approx(20e-6 * 9.80665, rel=1e-12)
    assert got["gyroscope_random_walk"] == 1e-9 and got["accelerometer_random_walk"] == 1e-5
    assert any("deg/sqrt(h) read as" in n for n in notes)
    assert any("no unit comment for accelerometer_random_walk;" in n for n in notes)
    with pytest.warns(UserWarning) as caught:
        read_kalibr_yaml(p)
    assert any("no unit comment" in str(w.message) for w in caught)
    p.write_text("gyroscope_noise_density: 0.002  # [deg/h]\n")
    with pytest.raises(DataError, match=r"\[deg/h\], which is not a unit of Kalibr's "
                                         r"rad/s/sqrt\(Hz\)"):
        read_kalibr_yaml(p)
    p.write_text("gyroscope_noise_density: 0.002  # [furlong/fortnight]\n")
    with pytest.raises(DataError, match="cannot read"):
        read_kalibr_yaml(p)


def _laughs(levels: int) -> str:
    """A billion-laughs yaml: 9 aliases of the level below, ``levels`` deep."""
    lines = ["gyroscope_noise_density: 1.0e-4", "a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("text", [_laughs(9), "a: &a [1, *a]\ngyroscope_noise_density: 1\n"])
def test_an_alias_bomb_is_refused_before_it_is_expanded(tmp_path, text):
    """Issue 34: 9 levels of 9 aliases (3.9e8 values from 700 bytes) ran out of memory."""
    import time

    p = tmp_path / "imu.yaml"
    p.write_text(text)
    start = time.perf_counter()
    with pytest.raises(DataError, match="larger than 100000 values once its aliases"):
        read_kalibr_yaml(p)
    assert time.perf_counter() - start < 2.0


def test_aliases_of_a_small_document_are_read(tmp_path):
    p = tmp_path / "imu.yaml"
    p.write_text(_laughs(3))  # 1 + 9 + 81 + 729 values
    assert read_kalibr_yaml(p, notes=[])["gyroscope_noise_density"] == 1e-4


def test_a_yaml_larger_than_the_cap_is_refused_unread(tmp_path):
    p = tmp_path / "imu.yaml"
    p.write_text("gyroscope_noise_density: 1.0e-4\n" + "# pad\n" * 200_000)
    with pytest.raises(DataError, match="larger than 1024 KiB"):
        read_kalibr_yaml(p)


def test_update_rate_from_float_stamps_is_rounded_to_six_digits():
    """Issue 30: stamps of a day-long 100 Hz log written in float seconds gave
    ``update_rate: 100.0000954``; the rate is written to 6 significant digits."""
    g = np.random.default_rng(3)
    n = 20_000
    t = np.round(86_400.0 * 3 + np.arange(n) * 0.01, 5)  # float seconds, 10 us resolution
    res = analyse_imu_noise(t, g.standard_normal((n, 3)) * 0.01, None)
    assert res.rate_hz != 100.0  # the median interval carries the stamps' rounding
    text = kalibr_yaml_text(res, source="float stamps")
    assert "update_rate: 100  #" in text and yaml.safe_load(text)["update_rate"] == 100
    from inertest.io.kalibr import _rate

    assert [_rate(v) for v in (199.99812345, 1e6, 0.25)] == ["199.998", "1000000", "0.25"]
