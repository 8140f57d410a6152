"""``inertest apply``: a Ferraris calibration applied to recordings in CSV, Parquet, HDF5."""

import json

import numpy as np
import pytest

from inertest.cli import main
from inertest.io.data_file import read_table, write_table
from inertest.io.hdf5_table import read_hdf5_table
from inertest.models.imu import ImuCalibration
from inertest.models.triad import TriadCalibration


@pytest.fixture
def session(examples_dir, tmp_path, capsys):
    """A simulated Ferraris session (no noise, no Earth rate) and its ``fit --json`` result."""
    d = examples_dir / "ferraris"
    data = tmp_path / "session.csv"
    truth = tmp_path / "truth.toml"
    text = (d / "truth.toml").read_text()
    for key in ("face_tilt_deg", "acc_noise", "gyr_noise"):
        text = "\n".join(ln for ln in text.splitlines() if not ln.startswith(key))
    truth.write_text(text)
    plan = tmp_path / "plan.toml"  # no Earth rate: the turns then integrate to exactly 360 deg
    text = (d / "plan.toml").read_text()
    assert "earth_rate = true" in text
    plan.write_text(text.replace("earth_rate = true", "earth_rate = false"))
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data)]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    cal = tmp_path / "cal.json"
    cal.write_text(capsys.readouterr().out)
    return cal, data


def test_apply_recovers_gravity_and_the_turns(session, tmp_path, capsys):
    cal, data = session
    out = tmp_path / "calibrated.csv"
    assert main(["apply", str(cal), str(data), "-o", str(out), "--gyr-unit", "deg/s"]) == 0
    assert "9" in capsys.readouterr().out
    t = read_table(out)
    a = np.column_stack([t[f"acc_{c}"] for c in "xyz"])
    w = np.column_stack([t[f"gyr_{c}"] for c in "xyz"])
    face = t["part"] == "z_a"
    np.testing.assert_allclose(a[face], [[0, 0, -9.81]] * int(face.sum()), atol=1e-9)
    turn = t["part"] == "x_rot"
    np.testing.assert_allclose(w[turn].sum(axis=0) / 200.0, [360, 0, 0], atol=1e-8)
    assert list(t) == list(read_table(data))  # the input's names, in its order


def test_apply_keeps_names_and_types_unless_asked(session, tmp_path, capsys):
    """Issue 30: an integer column stays integer, names stay, --unit-in-names renames."""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    cal, data = session
    raw = read_table(data)
    raw["sample"] = np.arange(len(raw["t_s"]), dtype=np.int64)
    src = tmp_path / "raw.csv"
    write_table(src, raw)
    out = tmp_path / "cal.parquet"
    assert main(["apply", str(cal), str(src), "-o", str(out)]) == 0
    table = pq.read_table(out)
    assert table.column_names == pacsv.read_csv(src).column_names
    assert str(table.schema.field("sample").type) == "int64"
    assert str(table.schema.field("acc_x").type) == "double"
    assert table.schema.field("acc_x").metadata == {b"unit": b"m/s^2"}
    assert "accelerometer -> m/s^2" in capsys.readouterr().out
    named = tmp_path / "named.csv"
    assert main(["apply", str(cal), str(src), "-o", str(named), "--unit-in-names"]) == 0
    cols = pacsv.read_csv(named).column_names
    assert "acc_x [m/s^2]" in cols and "gyr_z [rad/s]" in cols and "sample" in cols


def test_apply_hdf5_units_as_attributes_and_parquet(session, tmp_path):
    cal, data = session
    h5 = tmp_path / "c.h5"
    assert main(["apply", str(cal), str(data), "-o", str(h5)]) == 0
    t = read_hdf5_table(h5)
    import h5py

    with h5py.File(h5) as fh:
        assert fh["acc_x"].attrs["unit"] == "m/s^2"
        assert fh["gyr_z"].attrs["unit"] == "rad/s"
    assert set(t["part"]) >= {"x_p", "z_rot"}
    # HDF5 in, Parquet out
    pq = tmp_path / "c.parquet"
    raw_h5 = tmp_path / "raw.h5"
    from inertest.io.hdf5_table import write_hdf5_table

    write_hdf5_table(raw_h5, read_table(data))
    assert main(["apply", str(cal), str(raw_h5), "-o", str(pq)]) == 0
    np.testing.assert_allclose(read_table(pq)["acc_x"], t["acc_x"], rtol=1e-12)


def test_bare_calibration_block_and_custom_columns(tmp_path, capsys):
    """A hand-written block: calibrated = matrix @ (raw - offset), closed form."""
    block = ImuCalibration(accelerometer=TriadCalibration(
        np.diag([0.5, 0.25, 2.0]), np.array([1.0, 2.0, 3.0]), unit="m/s^2")).to_dict()
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(block))
    data = tmp_path / "d.csv"
    data.write_text("ax,ay,az\n3,6,4\n1,2,3\n")
    out = tmp_path / "o.csv"
    assert main(["apply", str(cal), str(data), "-o", str(out), "--acc-columns", "ax,ay,az",
                 "--acc-unit", "g"]) == 0
    t = read_table(out)
    np.testing.assert_allclose(t["ax"], np.array([1.0, 0.0]) / 9.80665)
    np.testing.assert_allclose(t["az"], np.array([2.0, 0.0]) / 9.80665)


def test_bad_input_is_one_line_and_writes_nothing(session, tmp_path, capsys):
    cal, data = session
    out = tmp_path / "o.csv"
    assert main(["apply", str(cal), str(data), "-o", str(out), "--acc-columns", "a,b,c",
                 "--gyr-columns", "p,q,r"]) != 0
    err = capsys.readouterr().err
    assert "lacks the raw column(s) a, b, c, p, q, r" in err and "--acc-columns" in err
    assert "Traceback" not in err and not out.exists()
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["apply", str(bad), str(data), "-o", str(out)]) != 0
    assert "is not JSON" in capsys.readouterr().err
    bad.write_text('{"calibration": {"accelerometer": {"matrix": [[1, 0], [0, 1]], '
                   '"offset": [0, 0, 0], "unit": "m/s^2"}}}')
    assert main(["apply", str(bad), str(data), "-o", str(out)]) != 0
    assert "3x3" in capsys.readouterr().err
    assert main(["apply", str(cal), str(data), "-o", str(out), "--acc-columns", "a,b"]) != 0
    assert "three comma-separated" in capsys.readouterr().err
    assert not out.exists()


def test_ferraris_fit_report_and_missing_turn_through_the_cli(examples_dir, tmp_path, capsys):
    d = examples_dir / "ferraris"
    data = tmp_path / "s.csv"
    assert main(["simulate", str(d / "plan.toml"), "--truth", str(d / "truth.toml"), "-o",
                 str(data), "--seed", "4"]) == 0
    capsys.readouterr()
    rep = tmp_path / "rep"
    assert main(["fit", str(d / "plan.toml"), str(data), "--no-store", "--report",
                 str(rep)]) == 0
    html = (rep / "index.html").read_text()
    assert "calibrated = matrix @ (raw - offset)" in html and "data:image/png" in html
    t = read_table(data)
    keep = t["part"] != "y_rot"
    cut = tmp_path / "cut.csv"
    write_table(cut, {k: v[keep] for k, v in t.items()})
    capsys.readouterr()
    assert main(["fit", str(d / "plan.toml"), str(cut), "--no-store", "--json"]) != 0
    err = capsys.readouterr().err
    assert "no rows with part y_rot" in err and "Kg_y, Mg_xy, Mg_zy" in err
    assert "Traceback" not in err


def test_review19_missing_accelerometer_column_refused_unless_only_gyroscope(
        session, tmp_path, capsys):
    """Review 19 (bad/of_noaccz.parquet): a recording without acc_z was silently calibrated
    for the gyro only. Now refused naming acc_z; --only gyroscope corrects the gyro alone."""
    cal, data = session
    t = read_table(data)
    del t["acc_z"]
    noz = tmp_path / "noz.csv"
    write_table(noz, t)
    out = tmp_path / "o.csv"
    assert main(["apply", str(cal), str(noz), "-o", str(out)]) != 0
    err = capsys.readouterr().err
    assert "lacks the raw column(s) acc_z " in err and "--only gyroscope" in err
    assert "Traceback" not in err and not out.exists()
    assert main(["apply", str(cal), str(noz), "-o", str(out), "--only", "gyroscope"]) == 0
    assert "gyroscope -> rad/s" in capsys.readouterr().out
    got = read_table(out)
    assert "gyr_x" in got and "acc_x" in got and "acc_x [m/s^2]" not in got
