"""``inertest noise`` through ``main(argv)``: the real PSINS recording (shipped xz-compressed in
examples/noise) against allantools, Kalibr yaml, comparison, gaps, CSV/Parquet/HDF5 tables,
compressed PSINS text, JSON, outputs never overwritten."""

from __future__ import annotations

import gzip
import hashlib
import json
import lzma
import math
import re
from pathlib import Path

import allantools
import h5py
import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest
import yaml
from scipy.stats import chi2

from inertest.cli import main

PSINS = Path(__file__).parents[2] / "examples" / "noise" / "lasergyro.imu.xz"
#: SHA-256 of data/lasergyro.imu at PSINS commit c1706f1 (as in ../shared/realdata/psins).
PSINS_SHA256 = "5de921e75f690c91ce6b7d3e811e547e050c4f1d000f648f537a59521206ba4d"


#: Kalibr's continuous-time units and the IEEE 952 SI units of the same quantity:
#: 1/sqrt(Hz) = sqrt(s), so rad/s^2/sqrt(Hz) = rad/s/sqrt(s) and rad/s/sqrt(Hz) = rad/sqrt(s).
SAME_UNIT = {"rad/s/sqrt(Hz)": "rad/sqrt(s)", "rad/s^2/sqrt(Hz)": "rad/s/sqrt(s)",
             "m/s^2/sqrt(Hz)": "m/s/sqrt(s)", "m/s^3/sqrt(Hz)": "m/s^2/sqrt(s)"}


def _psins_text() -> str:
    return lzma.decompress(PSINS.read_bytes()).decode("ascii")


def test_shipped_psins_file_is_the_source_file_byte_for_byte():
    assert hashlib.sha256(lzma.decompress(PSINS.read_bytes())).hexdigest() == PSINS_SHA256
    assert (PSINS.parent / "LICENSE").is_file()
    assert PSINS.stat().st_size < 800_000


def _psins_rates_by_hand() -> tuple[np.ndarray, float]:
    """The PSINS increments as rates, without inertest: LSB 0.1 arcsec, 125 ug*s (PSINS ug =
    1e-6 x 9.7803267714 m/s^2), interval 10 ms, from the file's three parameter lines."""
    rows = [ln for ln in _psins_text().splitlines()
            if ln.strip() and not ln.startswith("%")]
    params = np.array([[float(v) for v in r.split()] for r in rows[:3]])
    dt = params[1, 4] * 1e-3
    inc = np.loadtxt(rows[3:])
    lsb = np.r_[params[2, :3] * math.pi / 180 / 3600, params[2, 3:] * 1e-6 * 9.7803267714]
    return inc * lsb / dt, 1.0 / dt


@pytest.mark.slow
def test_psins_six_channels_yaml_agrees_with_the_allantools_curve(tmp_path, capsys):
    out = tmp_path / "imu.yaml"
    assert main(["noise", str(PSINS), "--kalibr", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    res = doc["result"]
    assert len(res["channels"]) == 6 and res["rate_hz"] == 100.0
    y = yaml.safe_load(out.read_text())
    assert y["update_rate"] == 100
    rates, fs = _psins_rates_by_hand()
    taus = np.array(res["channels"]["gyro_x"]["oadev"]["tau"])
    # allantools' overlapping Allan deviation of the same rates at the same taus.
    n_lines, k_lines = {}, {}
    for j, name in enumerate(res["channels"]):
        t, dev, _, _ = allantools.oadev(rates[:, j], rate=fs, data_type="freq", taus=taus)
        ours = res["channels"][name]["oadev"]["dev"]
        np.testing.assert_allclose(ours, dev, rtol=1e-9)
        # One-sided chi-squared upper limits of the allantools curve, jointly 95 % over the n
        # taus (Bonferroni, EDF as reported), and the -1/2 (ARW) and +1/2 (RRW) lines tangent
        # to them from below: at tau = 1 s and tau = 3 s their deviations bound N and K.
        edf = np.maximum(res["channels"][name]["oadev"]["edf"], 1.0)
        hi = dev * np.sqrt(edf / chi2.ppf(0.05 / t.size, edf))
        n_lines[name] = float(np.min(hi * np.sqrt(t)))
        k_lines[name] = float(np.min(hi * np.sqrt(3.0 / t)))
        kal = res["channels"][name]["kalibr"]
        # The five-term model does not describe this vehicle record: bounds, not fits.
        assert kal["noise_density"]["status"] == "bound"
        assert kal["noise_density"]["value"] == pytest.approx(n_lines[name], rel=1e-9)
        assert kal["random_walk"]["value"] == pytest.approx(k_lines[name], rel=1e-9)
    gyro, acc = list(res["channels"])[:3], list(res["channels"])[3:]
    assert y["gyroscope_noise_density"] == pytest.approx(max(n_lines[c] for c in gyro), rel=1e-9)
    assert y["gyroscope_random_walk"] == pytest.approx(max(k_lines[c] for c in gyro), rel=1e-9)
    assert y["accelerometer_noise_density"] == pytest.approx(max(n_lines[c] for c in acc),
                                                             rel=1e-9)
    assert y["accelerometer_random_walk"] == pytest.approx(max(k_lines[c] for c in acc),
                                                           rel=1e-9)
    text = out.read_text()
    assert text.count("UPPER BOUND, not a measurement") == 4
    # Issue 19: the five-term block (allan JSON) and the Kalibr export give one bound per
    # channel and term; Kalibr's rad/s^2/sqrt(Hz) (m/s^3/sqrt(Hz)) is IEEE 952's rad/s/sqrt(s)
    # (m/s^2/sqrt(s)), and rad/s/sqrt(Hz) is rad/sqrt(s): the SI numbers compare directly.
    for name, c in res["channels"].items():
        block = c["noise_terms"]
        assert block["fits"] is False
        assert block["verdict"].startswith("the five-term model does not fit: chi2/dof = ")
        assert "no term is reported as resolved" in block["verdict"]
        for term, param in (("N", "noise_density"), ("K", "random_walk")):
            five, kal = block["terms"][term], c["kalibr"][param]
            assert five["value"] is None and five["value_si"] is None
            assert kal["value"] == five["upper_bound_si"] == kal["bound_95"], (name, term)
            assert kal["tau_s"] == five["bound_tau_s"]
            assert SAME_UNIT[kal["unit"]] == five["unit_si"]
            assert kal["bound_definition"] == five["bound_definition"]
            assert "jointly 95 %" in kal["bound_definition"]
    # The allan command's five-term block: the same bounds for the same record.
    for j, name in ((0, "gyro_x"), (2, "gyro_z")):
        col = tmp_path / f"{name}.npy"
        np.save(col, rates[:, j])
        assert main(["allan", str(col), "--rate", "100", "--json"]) == 0
        terms = json.loads(capsys.readouterr().out)["result"]["noise_terms"]["terms"]
        for term, param in (("N", "noise_density"), ("K", "random_walk")):
            assert terms[term]["upper_bound_si"] == pytest.approx(
                res["channels"][name]["kalibr"][param]["bound_95"], rel=1e-9)


def _write_csv(path, n=20_000, rate=100.0, gap_at=None, seed=0, density=1e-3):
    g = np.random.default_rng(seed)
    t_ns = np.arange(n, dtype=np.int64) * int(round(1e9 / rate))
    if gap_at is not None:
        t_ns[gap_at:] += 250_000_000
    cols = {"timestamp": pa.array(t_ns + 1_600_000_000_000_000_000)}
    for a in "xyz":
        cols[f"gyro_{a}"] = density / math.sqrt(1 / rate) * g.standard_normal(n)
    pacsv.write_csv(pa.table(cols), path)
    return path


def test_gap_refused_then_longest_segment(tmp_path, capsys):
    data = _write_csv(tmp_path / "imu.csv", gap_at=15_000)
    out = tmp_path / "imu.yaml"
    assert main(["noise", str(data), "--kalibr", str(out)]) == 2
    err = capsys.readouterr().err
    assert "gap(s) in the time stamps, the first at t = 149.99 s: 0.26 s instead of 0.01 s" in err
    assert "--gaps longest" in err and "Traceback" not in err
    assert not out.exists()
    assert main(["noise", str(data), "--gaps", "longest", "--kalibr", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["result"]
    assert res["timing"]["segment"] == [0, 15_000]
    assert res["timing"]["gaps"][0]["index"] == 15_000
    back = yaml.safe_load(out.read_text())
    assert back["gyroscope_noise_density"] == pytest.approx(1e-3, rel=0.05)
    assert "accelerometer_noise_density" not in back


def test_compare_report_and_no_overwrite(tmp_path, capsys):
    data = _write_csv(tmp_path / "imu.csv", seed=3)
    claim = tmp_path / "datasheet.yaml"
    claim.write_text("gyroscope_noise_density: 1.0e-3\ngyroscope_random_walk: 1.0e-9\n")
    report = tmp_path / "rep"
    assert main(["noise", str(data), "--compare", str(claim), "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "meets the claim" in out and "consistent with" in out
    html = (report / "index.html").read_text()
    assert "Claimed values against the record" in html and "gyro_z: Allan deviation" in html
    claim.write_text("gyroscope_noise_density: 3.0e-3\n")  # 3x worse than the record
    assert main(["noise", str(data), "--compare", str(claim), "--json"]) == 0
    comp = json.loads(capsys.readouterr().out)["result"]["comparison"]
    assert [c["verdict"] for c in comp] == ["meets the claim"] * 3
    assert "inconsistent with" in {c["consistency"] for c in comp}
    claim.write_text("gyroscope_noise_density: 3.0e-4\n")  # 3x better than the record
    assert main(["noise", str(data), "--compare", str(claim), "--json"]) == 0
    comp = json.loads(capsys.readouterr().out)["result"]["comparison"]
    assert [c["verdict"] for c in comp] == ["exceeds the claim"] * 3
    existing = tmp_path / "imu.yaml"
    existing.write_text("mine\n")
    assert main(["noise", str(data), "--kalibr", str(existing)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert existing.read_text() == "mine\n"


def test_unresolved_refuse_writes_nothing(tmp_path, capsys):
    data = _write_csv(tmp_path / "imu.csv", n=5_000)
    out = tmp_path / "imu.yaml"
    assert main(["noise", str(data), "--kalibr", str(out), "--unresolved", "refuse"]) == 2
    err = capsys.readouterr().err
    assert "does not resolve gyro_x K" in err and "--unresolved bound" in err
    assert not out.exists()


def test_no_stamps_needs_a_rate(tmp_path, capsys):
    p = tmp_path / "imu.csv"
    pacsv.write_csv(pa.table({f"g{a}": np.zeros(500) for a in "xyz"}), p)
    assert main(["noise", str(p)]) == 2
    assert "give the sample rate with --rate" in capsys.readouterr().err


def test_report_folder_of_someone_else_refused_before_any_work(tmp_path, capsys):
    data = _write_csv(tmp_path / "imu.csv", n=2_000)
    folder = tmp_path / "notes"
    folder.mkdir()
    (folder / "mine.txt").write_text("x")
    out = tmp_path / "imu.yaml"
    assert main(["noise", str(data), "--report", str(folder), "--kalibr", str(out)]) == 2
    assert "did not write" in capsys.readouterr().err
    assert not out.exists() and sorted(p.name for p in folder.iterdir()) == ["mine.txt"]


def _psins_excerpt(n: int) -> str:
    """The shipped recording's header and first ``n`` samples."""
    lines = _psins_text().splitlines(keepends=True)
    head = [i for i, ln in enumerate(lines) if not ln.startswith("%")][3]  # 3 parameter lines
    return "".join(lines[:head + n])


def _result_without_notes(doc: dict) -> dict:
    res = doc["result"]
    return {k: v for k, v in res.items() if k != "messages"}


def test_gz_and_xz_psins_read_like_the_plain_file(tmp_path, capsys):
    text = _psins_excerpt(6000)
    plain = tmp_path / "excerpt.imu"
    plain.write_text(text)
    (tmp_path / "excerpt.imu.gz").write_bytes(gzip.compress(text.encode()))
    (tmp_path / "excerpt.imu.xz").write_bytes(lzma.compress(text.encode()))
    docs = {}
    for name in ("excerpt.imu", "excerpt.imu.gz", "excerpt.imu.xz"):
        assert main(["noise", str(tmp_path / name), "--json"]) == 0
        docs[name] = json.loads(capsys.readouterr().out)
    ref = _result_without_notes(docs["excerpt.imu"])
    assert len(ref["channels"]) == 6 and ref["rate_hz"] == 100.0
    for name in ("excerpt.imu.gz", "excerpt.imu.xz"):
        assert _result_without_notes(docs[name]) == ref
        assert any("decompression" in m for m in docs[name]["messages"])


def test_broken_or_compressed_table_refused_in_one_line(tmp_path, capsys):
    bad = tmp_path / "cut.imu.xz"
    bad.write_bytes(lzma.compress(_psins_excerpt(500).encode())[:300])  # a cut download
    assert main(["noise", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "cut.imu.xz is not a readable .xz file" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    table = tmp_path / "imu.csv.gz"
    table.write_bytes(gzip.compress(b"t,gyro_x\n0,1\n"))
    for extra in ([], ["--format", "csv"]):
        assert main(["noise", str(table), *extra]) == 2
        err = capsys.readouterr().err
        assert "decompress it" in err and "Traceback" not in err


def _kalibr_columns(n: int, rate: float, seed: int) -> dict[str, np.ndarray]:
    """Kalibr's discrete model per axis: white N/sqrt(dt) plus a random-walk bias K sqrt(dt);
    gyro in deg/s, accelerometer in g (g0), time in s."""
    g = np.random.default_rng(seed)
    dt = 1.0 / rate
    cols = {"time": np.arange(n) * dt}
    for prefix, density, walk, unit in (("gyro", 2e-3, 2e-5, 180 / math.pi),
                                        ("acc", 4e-3, 1e-4, 1 / 9.80665)):
        for a in "xyz":
            y = (density / math.sqrt(dt) * g.standard_normal(n)
                 + np.cumsum(walk * math.sqrt(dt) * g.standard_normal(n)))
            cols[f"{prefix}_{a}"] = y * unit
    return cols


def test_parquet_and_hdf5_tables_read_like_csv_and_psd_white_level(tmp_path, capsys):
    rate, n = 100.0, 60_000
    cols = _kalibr_columns(n, rate, seed=19)
    pacsv.write_csv(pa.table(cols), tmp_path / "imu.csv")
    pq.write_table(pa.table(cols), tmp_path / "imu.parquet")
    with h5py.File(tmp_path / "imu.h5", "w") as fh:
        for k, v in cols.items():
            fh.create_dataset(k, data=v)
    docs = {}
    for name in ("imu.csv", "imu.parquet", "imu.h5"):
        assert main(["noise", str(tmp_path / name), "--gyro-unit", "deg/s", "--accel-unit", "g",
                     "--json"]) == 0
        docs[name] = json.loads(capsys.readouterr().out)["result"]
    csv = docs["imu.csv"]
    assert list(csv["channels"]) == ["gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]
    for name in ("imu.parquet", "imu.h5"):
        for ch, c in docs[name]["channels"].items():
            # CSV text round-trips floats exactly (shortest repr), so all three agree closely.
            np.testing.assert_allclose(c["oadev"]["dev"], csv["channels"][ch]["oadev"]["dev"],
                                       rtol=1e-12)
    for ch, c in docs["imu.h5"]["channels"].items():
        si = cols[ch] * (math.pi / 180 if ch.startswith("gyro") else 9.80665)
        _, dev, _, _ = allantools.oadev(si, rate=rate, data_type="freq",
                                        taus=np.array(c["oadev"]["tau"]))
        np.testing.assert_allclose(c["oadev"]["dev"], dev, rtol=1e-9)
        density = 2e-3 if ch.startswith("gyro") else 4e-3
        fit = c["kalibr"]["noise_density"]
        assert fit["status"] == "fitted"
        assert abs(fit["value"] - density) <= 3 * fit["std"]
        # PSD white level on the flat part (f > 1 Hz; the random walk's 2 K^2/(2 pi f)^2 is
        # < 1e-4 of it there): one-sided S1 = 2 N^2 (IEEE 952 Annex C two-sided S = N^2).
        f = np.array(c["psd"]["freq_hz"])
        p = np.array(c["psd"]["value"])
        flat = p[f > 1.0]
        assert math.sqrt(float(np.mean(flat)) / 2) == pytest.approx(density, rel=0.02)
        assert math.sqrt(float(np.mean(flat)) / 2) == pytest.approx(fit["value"], rel=0.05)


def test_review19_header_only_csv_and_truncated_psins_refused_in_one_line(tmp_path, capsys):
    """Review 19: a header-only CSV gave exit 70 (IndexError); a truncated PSINS row passed
    numpy's hint "use `usecols`". Both are now one-line errors saying what is wrong."""
    hdr = tmp_path / "header_only.csv"
    hdr.write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n")
    assert main(["noise", str(hdr)]) == 2
    err = capsys.readouterr().err
    assert "has no data rows" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    trunc = tmp_path / "trunc.imu"
    trunc.write_text(_psins_excerpt(200) + "1 2 3 4 5\n")
    assert main(["noise", str(trunc)]) == 2
    err = capsys.readouterr().err
    assert re.search(r"sample row \d+ has 5 numbers where the rows before it have 6", err)
    assert "the file is truncated" in err and "usecols" not in err
    assert len(err.strip().splitlines()) == 1


def test_jitter_is_not_a_gap_and_a_unit_mistake_is_named(tmp_path, capsys):
    """Issue 28: stamps jittered by +-0.3 of the interval gave 818 'gaps'; stamps in seconds
    read with --time-unit ns gave a 1e11 Hz record without a word. ``--time-unit us`` reads
    microsecond stamps (PX4)."""
    g = np.random.default_rng(28)
    n = 60_000
    t = (np.arange(n) + g.uniform(-0.3, 0.3, n)) * 0.01
    cols = {"t": t, **{f"gyro_{a}": 1e-2 * g.standard_normal(n) for a in "xyz"}}
    pacsv.write_csv(pa.table(cols), tmp_path / "jitter.csv")
    assert main(["noise", str(tmp_path / "jitter.csv"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["result"]["timing"]["gaps"] == []
    assert doc["result"]["timing"]["segment"] == [0, n]
    assert any(m.startswith("time-stamp jitter 0.0024") for m in doc["messages"]), doc["messages"]
    cols["t"] = np.arange(n) * 0.01  # seconds
    pacsv.write_csv(pa.table(cols), tmp_path / "seconds.csv")
    assert main(["noise", str(tmp_path / "seconds.csv"), "--time-unit", "ns"]) == 0
    err = capsys.readouterr().err
    assert "the time stamps give 1e+11 Hz" in err and "give --time-unit s" in err
    cols["t"] = np.arange(n, dtype=np.int64) * 4000  # microseconds, 250 Hz
    pacsv.write_csv(pa.table(cols), tmp_path / "us.csv")
    assert main(["noise", str(tmp_path / "us.csv"), "--json"]) == 0  # auto: read as ns
    assert "give --time-unit us" in capsys.readouterr().out
    assert main(["noise", str(tmp_path / "us.csv"), "--time-unit", "us", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["result"]["rate_hz"] == pytest.approx(250.0)
    assert not any("outside the 1 Hz" in m for m in doc["messages"])
