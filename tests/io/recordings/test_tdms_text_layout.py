"""TDMS (nptdms), whitespace text tables and TOML binary layouts, on the real recordings."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import inertest
from inertest.cli import main
from inertest.errors import DataError, InputError
from inertest.io.imu_recording import read_imu_recording
from inertest.io.recordings.binary_layout import layout_from_dict
from inertest.io.recordings.text_table import looks_like_psins


def _psins(realdata: Path):
    from inertest.io.imu_recording import read_psins

    return read_psins(realdata / "psins" / "lasergyro.imu")


# ------------------------------------------------------------------------------ TDMS


def test_tdms_group_channels_units_and_waveform_time(realdata_dir, tmp_path, capsys):
    nptdms = pytest.importorskip("nptdms")
    rec = _psins(realdata_dir)
    path = tmp_path / "bench.tdms"
    gyro_deg_s = np.degrees(rec.gyro)
    with nptdms.TdmsWriter(str(path)) as w:
        w.write_segment([nptdms.GroupObject("Notes")] + [
            nptdms.ChannelObject("IMU", name, values, properties={
                "unit_string": unit, "wf_increment": 0.01})
            for name, values, unit in [
                *((f"gyro_{a}", gyro_deg_s[:, i], "deg/s") for i, a in enumerate("xyz")),
                *((f"accel_{a}", rec.accel[:, i], "m/s^2") for i, a in enumerate("xyz"))]])
    got = inertest.load_data(path)  # the only group with channels
    assert np.array_equal(got["gyro_x"], gyro_deg_s[:, 0])
    assert np.array_equal(got["time_s"], np.arange(rec.gyro.shape[0]) * 0.01)
    # the channels' unit_string is used: deg/s back to rad/s without --gyro-unit
    imu = read_imu_recording(path)
    np.testing.assert_allclose(imu.gyro, rec.gyro, rtol=1e-15, atol=0)
    assert main(["noise", str(path), "--topic", "IMU", "--kalibr", str(tmp_path / "imu.yaml"),
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["result"]
    assert res["rate_hz"] == pytest.approx(100.0, rel=1e-9)
    with pytest.raises(DataError, match=r"no group 'imu'; groups found: Notes \(no channels\); "
                                        r"IMU \(gyro_x"):
        inertest.load_data(path, topic="imu")


# ------------------------------------------------------------------------------ text


def test_the_xsens_whitespace_text_reads_as_numpy_reads_it(realdata_dir):
    path = realdata_dir / "imu_tk" / "xsens_gyro.txt"
    ref = np.loadtxt(path)
    got = inertest.load_data(path)
    assert list(got) == ["column_1", "column_2", "column_3", "column_4"]
    for j, c in enumerate(got):
        assert np.array_equal(got[c], ref[:, j])


def test_a_whitespace_imu_log_is_not_taken_for_psins(tmp_path, capsys):
    """Issue 30: 't gx gy gz ax ay az' text got "the three PSINS parameter lines must hold
    numbers"; now it is a table with a header, its columns found by name."""
    rng = np.random.default_rng(3)
    n = 4000
    rows = np.column_stack([np.arange(n) * 0.005, rng.normal(0, 0.01, (n, 3)),
                            rng.normal(0, 0.02, (n, 3)) + [0, 0, 9.81]])
    text = "t\tgx\tgy\tgz\tax\tay\taz\n" + "\n".join("\t".join(f"{v:.9g}" for v in r)
                                                    for r in rows) + "\n"
    for name in ("imu.txt", "imu.log"):
        (tmp_path / name).write_text(text)
        assert main(["noise", str(tmp_path / name), "--kalibr", str(tmp_path / f"{name}.yaml"),
                     "--json"]) == 0
        res = json.loads(capsys.readouterr().out)["result"]
        assert list(res["channels"]) == ["gx", "gy", "gz", "ax", "ay", "az"]
        assert res["rate_hz"] == pytest.approx(200.0, rel=1e-6)
        assert "update_rate: 200  #" in (tmp_path / f"{name}.yaml").read_text()
    bad = tmp_path / "bad.txt"
    bad.write_text(text.replace("\n12.5\t", "\n12.5\tn/a\t", 1) if "\n12.5\t" in text
                   else text[:-40])
    assert main(["noise", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "numbers separated by spaces or tabs" in err


def test_psins_is_still_told_by_its_content(realdata_dir):
    head = (realdata_dir / "psins" / "lasergyro.imu").read_text().splitlines(True)[:40]
    assert looks_like_psins(head)
    seven = ["0.01 1 2 3 4 5 6\n"] * 10  # a 7-column table of reals is not PSINS
    assert not looks_like_psins(seven)


# ------------------------------------------------------------------------------ layouts


def test_psins_binary_through_a_toml_layout_equals_numpy(realdata_dir, tmp_path):
    """imusysclbt.bin: 98,200 records of 7 little-endian float32 (README of realdata)."""
    src = realdata_dir / "psins" / "imusysclbt.bin"
    ref = np.fromfile(src, dtype="<f4").reshape(-1, 7)
    names = ["dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z", "t"]
    layout = tmp_path / "psins.toml"
    layout.write_text("[record]\nsize = 28\ntime = \"t\"\n" + "".join(
        f"[fields.{n}]\noffset = {4 * i}\ntype = \"float32\"\nscale = {100.0 if i < 6 else 1.0}"
        f"\nunit = \"{'rad/s' if i < 3 else 'm/s^2' if i < 6 else 's'}\"\n"
        for i, n in enumerate(names)))
    got = inertest.load_data(src, layout=layout)
    assert list(got) == names
    for i, n in enumerate(names):
        scale = 100.0 if i < 6 else 1.0  # increments per 0.01 s -> rates
        assert np.array_equal(got[n], ref[:, i].astype(np.float64) * scale)
    imu = read_imu_recording(src, layout=layout, gyro_columns="dtheta_x,dtheta_y,dtheta_z",
                             accel_columns="dv_x,dv_y,dv_z")
    assert imu.gyro.shape == (98_200, 3) and imu.t[1] == pytest.approx(0.01, rel=1e-6)


def test_a_stim300_like_big_endian_int24_record_with_sync(tmp_path):
    rng = np.random.default_rng(5)
    raw = rng.integers(-(1 << 23), 1 << 23, size=(500, 3))
    rec = bytearray()
    for r in raw:
        rec += b"\x93" + b"".join(int(v).to_bytes(3, "big", signed=True) for v in r) + b"\0\0"
    path = tmp_path / "stim.bin"
    path.write_bytes(bytes(rec))
    doc = {"record": {"size": 12, "byte_order": "big", "rate_hz": 125.0,
                      "sync": {"offset": 0, "value": 0x93}},
           "fields": {f"gyro_{a}": {"offset": 1 + 3 * i, "type": "int24", "scale": 2.0 ** -21,
                                    "unit": "deg/s"} for i, a in enumerate("xyz")}}
    layout = tmp_path / "stim.toml"
    layout.write_text(
        "[record]\nsize = 12\nbyte_order = \"big\"\nrate_hz = 125.0\n"
        "sync = { offset = 0, value = 0x93 }\n" + "".join(
            f"[fields.gyro_{a}]\noffset = {1 + 3 * i}\ntype = \"int24\"\n"
            f"scale = {2.0 ** -21!r}\nunit = \"deg/s\"\n" for i, a in enumerate("xyz")))
    assert layout_from_dict(doc).fields[0].size == 3
    got = inertest.load_data(path, layout=layout)
    assert np.array_equal(got["gyro_y"], raw[:, 1] * 2.0 ** -21)
    imu = read_imu_recording(path, layout=layout)
    assert imu.rate_hz == 125.0 and imu.t is None
    np.testing.assert_allclose(imu.gyro[:, 2], np.radians(raw[:, 2] * 2.0 ** -21), rtol=1e-15)
    path.write_bytes(bytes(rec)[:-5])
    with pytest.raises(DataError, match="ends 7 bytes into a record"):
        inertest.load_data(path, layout=layout)
    rec[12 * 7] = 0x00
    path.write_bytes(bytes(rec))
    with pytest.raises(DataError, match="record 7 .* does not hold the sync byte 0x93"):
        inertest.load_data(path, layout=layout)


@pytest.mark.parametrize("doc, match", [
    ({"fields": {}}, "needs a \\[record\\] table"),
    ({"record": {"size": 0}, "fields": {"a": {"offset": 0, "type": "int8"}}}, "positive whole"),
    ({"record": {"size": 4}, "fields": {"a": {"offset": 2, "type": "int32"}}}, "runs past the end"),
    ({"record": {"size": 4}, "fields": {"a": {"offset": 0, "type": "int12"}}}, "not known"),
    ({"record": {"size": 4, "time": "t"}, "fields": {"a": {"offset": 0, "type": "int8"}}},
     "names no field"),
])
def test_layout_errors_name_the_key(doc, match):
    with pytest.raises(InputError, match=match):
        layout_from_dict(doc)
