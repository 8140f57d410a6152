"""``inertest thermal simulate`` / ``fit``: JSON, figure, report, bad input."""

import json

from inertest.cli import main


def test_simulate_fit_json_plot_report(tmp_path, capsys):
    data = tmp_path / "cycles.parquet"
    assert main(["thermal", "simulate", "-o", str(data), "--cycles", "3", "--seed", "1"]) == 0
    capsys.readouterr()
    png, rep = tmp_path / "t.png", tmp_path / "rep"
    assert main(["thermal", "fit", str(data), "--json", "--plot", str(png),
                 "--report", str(rep)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["kind"] == "thermal-compensation" and doc["checks"][0]["verdict"] == "ok"
    d = doc["result"]
    assert d["quantity"] == "scale_factor" and d["validation_cycles"] == [3]
    assert d["neural_network"]["validation_rms"]["unit"] == "ppm"
    assert d["polynomial"]["validation_rms"]["value"] < d["before"]["validation_rms"]["value"] / 10
    assert png.read_bytes()[:4] == b"\x89PNG"
    html = (rep / "index.html").read_text()
    assert "data:image/png;base64" in html and "(T - T_ref)" in html and "ppm/degC" in html
    assert main(["thermal", "fit", str(data), "--quantity", "bias", "--no-rate"]) == 0
    out = capsys.readouterr().out
    assert "uncompensated" in out and "deg/h" in out


def test_hdf5_and_bad_input(tmp_path, capsys):
    data = tmp_path / "c.h5"
    assert main(["thermal", "simulate", "-o", str(data), "--cycles", "2"]) == 0
    capsys.readouterr()
    png = tmp_path / "t.png"
    assert main(["thermal", "fit", str(data), "--plot", str(png)]) != 0
    err = capsys.readouterr().err
    assert "2 temperature cycle(s) found" in err and "record at least 3" in err
    assert "Traceback" not in err and not png.exists()
    csv = tmp_path / "x.csv"
    csv.write_text("cycle,time_s,temperature_c\n1,0,20\n")
    assert main(["thermal", "fit", str(csv)]) != 0
    assert "lacks column(s) scale_factor" in capsys.readouterr().err
