"""``inertest allan`` through ``main(argv)``: formats, JSON layout, figure, bad input."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pytest

from inertest.cli import main
from inertest.io.data_file import write_table
from inertest.noise.deviations import deviations
from inertest.noise.identification import simulate_noise
from nist_reference_sets import NBS9, NBS9_PUBLISHED, SP1065_TABLE31, nbs_1000


@pytest.fixture
def gyro():
    return simulate_noise(20_000, 50.0, n_rw=1e-4, rng=2)


def _json(capsys):
    return json.loads(capsys.readouterr().out)["result"]


def test_csv_json_layout_and_values(tmp_path, capsys, gyro):
    path = tmp_path / "gyro.csv"
    pacsv.write_csv(pa.table({"t": np.arange(gyro.size) / 50.0, "gyro_x": gyro}), path)
    assert main(["allan", str(path), "--column", "gyro_x", "--rate", "50",
                 "--stats", "oadev,mdev,totdev", "--json"]) == 0
    out = _json(capsys)
    ref = deviations(gyro, 50.0, ["oadev", "mdev", "totdev"])
    assert out["unit"] == "rad/s"
    assert out["units"] == {"oadev": "rad/s", "mdev": "rad/s", "totdev": "rad/s"}
    np.testing.assert_allclose(out["tau"], ref["oadev"].taus)
    for k in ("oadev", "mdev", "totdev"):
        got = np.array([np.nan if v is None else v for v in out[k]])
        np.testing.assert_allclose(got[: ref[k].dev.size], ref[k].dev, rtol=1e-12)
        assert len(out[f"{k}_lo"]) == len(out["tau"])
        # the noise type behind each EDF and the rule that decided it (issue 28)
        assert out[f"{k}_alpha"][: ref[k].dev.size] == ref[k].alpha.tolist()
        assert out[f"{k}_alpha_rule"][: ref[k].dev.size] == list(ref[k].alpha_rule)
        assert set(ref[k].alpha_rule) <= set(out["alpha_rules"])
    n = out["noise_terms"]["terms"]["N"]
    assert n["resolved"] and n["unit"] == "deg/sqrt(h)"
    assert n["value_si"] == pytest.approx(1e-4, rel=0.05)
    assert out["noise_terms"]["terms"]["R"]["value"] is None


@pytest.mark.parametrize("suffix", [".npy", ".f32", ".bin", ".parquet", ".h5"])
def test_formats_give_the_same_result(tmp_path, capsys, gyro, suffix):
    y32 = gyro.astype(np.float32)
    path = tmp_path / f"g{suffix}"
    extra = []
    if suffix == ".npy":
        np.save(path, y32)
    elif suffix in (".f32", ".bin"):
        y32.astype("<f4").tofile(path)
        extra = ["--dtype", "float32"] if suffix == ".bin" else []
    else:
        write_table(path, {"gyro_x": y32.astype(float)})
        extra = ["--column", "gyro_x"]
    assert main(["allan", str(path), "--rate", "50", "--taus", "0.02,0.2,2", "--json",
                 "--no-noise-id", *extra]) == 0
    out = _json(capsys)
    ref = deviations(y32.astype(float), 50.0, ["oadev"], [0.02, 0.2, 2.0])["oadev"]
    np.testing.assert_allclose(out["oadev"], ref.dev, rtol=1e-12)
    assert out["noise_terms"] is None


def test_units_and_angle_input(tmp_path, capsys, gyro):
    deg_s = np.degrees(gyro)
    np.save(tmp_path / "r.npy", deg_s)
    assert main(["allan", str(tmp_path / "r.npy"), "--rate", "50", "--unit", "deg/s",
                 "--taus", "0.02,2", "--json", "--no-noise-id"]) == 0
    out_a = _json(capsys)
    a = out_a["oadev"]
    assert out_a["unit"] == "deg/s"
    angle = np.concatenate(([0.0], np.cumsum(gyro) / 50.0))  # rad
    np.save(tmp_path / "a.npy", angle)
    assert main(["allan", str(tmp_path / "a.npy"), "--rate", "50", "--input", "angle",
                 "--taus", "0.02,2", "--json", "--no-noise-id"]) == 0
    out_b = _json(capsys)
    b = out_b["oadev"]
    assert out_b["unit"] == "rad/s"
    # deviations in the unit the user gave (deg/s), the same record in rad/s
    np.testing.assert_allclose(np.radians(a), b, rtol=1e-9)
    assert a[0] == pytest.approx(np.degrees(1e-4 * math.sqrt(50.0)), rel=0.05)


@pytest.mark.parametrize("fmt", ["png", "svg", "pdf"])
def test_plot_written(tmp_path, capsys, gyro, fmt):
    np.save(tmp_path / "g.npy", gyro)
    fig = tmp_path / f"allan.{fmt}"
    assert main(["allan", str(tmp_path / "g.npy"), "--rate", "50", "--stats", "oadev,hdev",
                 "--plot", str(fig)]) == 0
    assert fig.stat().st_size > 1000
    text = capsys.readouterr().out
    assert "noise terms" in text and "deg/sqrt(h)" in text


def test_html_report(tmp_path, capsys, gyro):
    np.save(tmp_path / "g.npy", gyro)
    report = tmp_path / "out" / "allan.html"
    assert main(["allan", str(tmp_path / "g.npy"), "--rate", "50", "--stats", "oadev,mdev",
                 "--json", "--report", str(report)]) == 0
    out = _json(capsys)  # --json output is unchanged by --report
    html = report.read_text(encoding="utf-8")
    assert html.count("data:image/png;base64,") == 1
    assert "Noise terms" in html and "deg/sqrt(h)" in html and "50 Hz" in html
    # the deviation table carries the same numbers as the JSON
    # (rounded at the confidence interval's half-width, so compare the leading digits)
    for v in (out["oadev"][0], out["mdev"][2]):
        lead, _, exp = f"{v:.5e}".partition("e")
        assert re.search(rf"{lead[:4].replace('.', '[.]')}\d*e{exp}", html), v


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--rate", "0"], "positive sampling rate"),
        (["--rate", "-1"], "positive sampling rate"),
        (["--rate", "50", "--stats", "oadev,avar"], "unknown statistic 'avar'"),
        (["--rate", "50", "--taus", "0.03"], "not a multiple"),
        (["--rate", "50", "--taus", "fortnight"], "--taus"),
        (["--rate", "50", "--unit", "furlong/s"], "unknown --unit"),
        (["--rate", "50", "--plot", "x.gif"], "figure format"),
    ],
)
def test_bad_input_one_line_no_output(tmp_path, capsys, gyro, args, words):
    np.save(tmp_path / "g.npy", gyro)
    status = main(["allan", str(tmp_path / "g.npy"), *args])
    err = capsys.readouterr().err
    assert status != 0
    assert words in err and "Traceback" not in err
    assert not (tmp_path / "x.gif").exists()


def test_bad_data_files(tmp_path, capsys):
    np.save(tmp_path / "nan.npy", np.r_[np.ones(10), np.nan, np.ones(10)])
    assert main(["allan", str(tmp_path / "nan.npy"), "--rate", "1"]) != 0
    assert "NaN" in capsys.readouterr().err
    np.save(tmp_path / "short.npy", np.ones(1))
    assert main(["allan", str(tmp_path / "short.npy"), "--rate", "1"]) != 0
    assert "too short for oadev: it needs at least 2 rate samples" in capsys.readouterr().err
    (tmp_path / "raw.bin").write_bytes(b"\0" * 40)
    assert main(["allan", str(tmp_path / "raw.bin"), "--rate", "1"]) != 0
    assert "--dtype" in capsys.readouterr().err
    pacsv.write_csv(pa.table({"a": [1.0, 2.0], "b": [3.0, 4.0]}), tmp_path / "t.csv")
    assert main(["allan", str(tmp_path / "t.csv"), "--rate", "1", "--column", "c"]) != 0
    assert "no column 'c'" in capsys.readouterr().err


@pytest.mark.slow
def test_psins_lasergyro_deg_per_h_checks_and_units(tmp_path, capsys, realdata_dir):
    """Real RLG record in deg/h: deviations in deg/h, a failed fit reported under checks."""
    x = np.loadtxt(realdata_dir / "psins" / "lasergyro.imu", comments="%")[3:]
    np.save(tmp_path / "gz.npy", x[:, 2] * 10.0)  # 0.1 arcsec per 10 ms = 10 deg/h per count
    assert main(["allan", str(tmp_path / "gz.npy"), "--rate", "100", "--unit", "deg/h",
                 "--stats", "oadev,tdev", "--json"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert doc["kind"] == "allan" and doc["checks"][0]["verdict"] == "warning"
    out = doc["result"]
    assert out["unit"] == "deg/h" and out["units"] == {"oadev": "deg/h", "tdev": "arcsec"}
    ref = deviations(x[:, 2] * 10.0, 100.0, ["oadev"])["oadev"]  # deg/h in, deg/h out
    np.testing.assert_allclose(out["oadev"], ref.dev, rtol=1e-9)
    assert doc["messages"] and "does not fit" in doc["messages"][0]
    assert "warning:" in captured.err
    assert not any(t["resolved"] for t in out["noise_terms"]["terms"].values())
    assert out["noise_terms"]["fits"] is False


ALL_STATS = "adev,oadev,mdev,hdev,ohdev,totdev,tdev"


def test_sp1065_nbs_9_point_published_values_through_json(tmp_path, capsys):
    """Issue 28: this set ended in 'internal error (LinAlgError: Singular matrix)', exit 70,
    in the five-term fit (more active terms than averaging times)."""
    pacsv.write_csv(pa.table({"y": list(NBS9)}), tmp_path / "nbs9.csv")
    assert main(["allan", str(tmp_path / "nbs9.csv"), "--rate", "1", "--unit", "1",
                 "--stats", ALL_STATS, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    out = doc["result"]
    assert out["tau"][:2] == [1.0, 2.0]
    for stat, published in NBS9_PUBLISHED.items():
        np.testing.assert_allclose(out[stat][:2], published, rtol=1e-6, err_msg=stat)
        assert all(lo <= d <= hi for lo, d, hi in zip(out[f"{stat}_lo"][:2], out[stat][:2],
                                                      out[f"{stat}_hi"][:2], strict=True))
    assert out["noise_terms"]["terms"]["N"]["upper_bound"] > 0


def test_sp1065_1000_point_published_values_through_json(tmp_path, capsys):
    """SP 1065 Table 31 (the 1000-point NBS set, tau = 1, 10, 100 s) through the CLI."""
    np.save(tmp_path / "nbs1000.npy", nbs_1000())
    assert main(["allan", str(tmp_path / "nbs1000.npy"), "--rate", "1", "--unit", "1",
                 "--taus", "1,10,100", "--stats", ALL_STATS, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    assert out["tau"] == [1.0, 10.0, 100.0]
    for stat, published in SP1065_TABLE31.items():
        np.testing.assert_allclose(out[stat], published, rtol=1.2e-6, err_msg=stat)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6, 7, 8, 9, 12, 17, 31])
def test_short_records_give_values_bounds_or_too_short(tmp_path, capsys, n):
    """From 2 samples up: every statistic a value or a 'too short for X' line, the five-term
    fit a result or upper bounds, never an internal error."""
    y = np.random.default_rng(n).standard_normal(n)
    np.save(tmp_path / "s.npy", y)
    assert main(["allan", str(tmp_path / "s.npy"), "--rate", "1", "--stats", ALL_STATS,
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    out = doc["result"]
    for stat in ALL_STATS.split(","):
        if stat in ("hdev", "ohdev") and n < 3:
            assert stat not in out
            assert any(f"too short for {stat}" in m for m in doc["messages"])
        else:
            assert out[stat][0] > 0 and out[f"{stat}_hi"][0] > out[stat][0]
    terms = doc["result"]["noise_terms"]["terms"]
    assert all(t["upper_bound"] > 0 for t in terms.values())
    if n < 4:
        assert "too short for the five-term fit" in doc["result"]["noise_terms"]["verdict"]
