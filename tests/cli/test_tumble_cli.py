"""The command line, called as ``main(argv)``: simulate, fit, --json, --report, bad input."""

import json

import numpy as np
import pytest

from inertest.cli import main
from inertest.io.data_file import read_table, write_table

TRUTH = "[coefficients]\nDF = 1.2\nDI = 0.85\nDO = -0.62\nDS = 0.31\nDIO = 0.12\nDSI = 0.05\n"


@pytest.fixture
def files(tmp_path, examples_dir):
    truth = tmp_path / "truth.toml"
    truth.write_text(TRUTH)
    return examples_dir / "polar_tumble" / "plan.toml", truth, tmp_path


def test_simulate_fit_json_layout(files, capsys):
    plan, truth, tmp = files
    data = tmp / "data.parquet"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", "0.002", "--seed", "4"]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "polar-tumble" and out["schema_version"] == 2
    assert set(out["identification"]["coefficients"]) == {"DI", "DO", "DS", "DIO", "DOS", "DSI"}
    di = out["identification"]["coefficients"]["DI"]
    assert di["unit"] == "deg/h/g" and abs(di["value"] - 0.85) < 5 * di["std"]
    assert len(out["identification"]["combinations"]) == 3
    for c in out["identification"]["combinations"]:
        assert set(c) == {"name", "terms", "value", "std", "unit"}
        assert set(c["terms"]) <= {"DF", "DII", "DOO", "DSS"}
    assert set(out["result"]["harmonics"]) == {"O-Np", "O-Sp", "S-Np", "S-Sp"}
    noise = out["identification"]["noise"]
    assert noise["unit"] == "deg/h" and noise["source"] == "residuals"


def test_fit_table_and_self_contained_report(files, capsys):
    plan, truth, tmp = files
    data = tmp / "data.csv"
    main(["simulate", str(plan), "--truth", str(truth), "-o", str(data), "--noise", "0.002"])
    assert main(["fit", str(plan), str(data), "--report", str(tmp / "rep")]) == 0
    out = capsys.readouterr().out
    assert "DF + 0.99" in out and "deg/h/g^2" in out and "not determined" in out
    html = (tmp / "rep" / "index.html").read_text()
    assert "data:image/png;base64," in html
    assert "http://" not in html and "https://" not in html and "<script" not in html


def _drop_angle(d):
    d["angle"] = d.pop("angle_deg")


def _bad_mounting(d):
    d["mounting"][0] = "O-Up"


def _nan_output(d):
    d["output"][3] = np.nan


@pytest.mark.parametrize(
    "spoil, message",
    [(_drop_angle, "lacks column(s) angle_deg"), (_bad_mounting, "O-Up"),
     (_nan_output, "NaN/inf value(s) (first at data row 4)")],
)
def test_bad_data_is_a_clean_error(files, capsys, spoil, message):
    plan, truth, tmp = files
    data = tmp / "data.csv"
    main(["simulate", str(plan), "--truth", str(truth), "-o", str(data), "--noise", "0.002"])
    cols = read_table(data)
    spoil(cols)
    write_table(data, cols)
    capsys.readouterr()
    rep = tmp / "never"
    assert main(["fit", str(plan), str(data), "--report", str(rep)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not rep.exists()


def test_bad_plan_and_missing_file(tmp_path, capsys):
    plan = tmp_path / "p.toml"
    plan.write_text('[site]\nlatitude_deg = 30\n[procedure]\nkind = "spin"\n')
    truth = tmp_path / "t.toml"
    truth.write_text(TRUTH)
    out = tmp_path / "d.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(out)]) == 2
    assert 'unknown procedure kind "spin"' in capsys.readouterr().err
    assert not out.exists()
    assert main(["fit", str(plan), str(tmp_path / "none.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_left_handed_local_level_position(tmp_path, examples_dir, capsys):
    data = tmp_path / "d.csv"
    data.write_text("I_dir,O_dir,S_dir,output\nW,N,U,0.1\nU,N,W,0.2\n")
    plan = examples_dir / "local_level_tumble" / "plan.toml"
    assert main(["fit", str(plan), str(data)]) == 2
    assert "left-handed" in capsys.readouterr().err


@pytest.mark.parametrize("example", ["polar_tumble", "local_level_tumble"])
def test_fit_json_with_given_sigma_reports_it(example, tmp_path, examples_dir, capsys):
    """--json --sigma: the given noise is reported (no NaN), with the noise model and checks."""
    truth = tmp_path / "truth.toml"
    truth.write_text(TRUTH)
    plan, data = examples_dir / example / "plan.toml", tmp_path / "data.csv"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                 "--noise", "0.01", "--seed", "5"]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--sigma", "0.01", "--no-store"]) == 0
    out = json.loads(capsys.readouterr().out)
    noise = out["identification"]["noise"]
    assert noise["source"] == "given" and noise["model"] == "white"
    assert noise["sigma"] == pytest.approx(0.01 * 12.5) and noise["unit"] == "deg/h"
    (check,) = [c for c in out["checks"] if c["name"] == "noise model fit"]
    assert check["verdict"] == "consistent"


def test_an_existing_output_file_is_replaced_only_with_overwrite(examples_dir, tmp_path, capsys):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    truth = examples_dir / "polar_tumble" / "truth.toml"
    out = tmp_path / "data.csv"
    out.write_text("the user's own file\n")
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert out.read_text() == "the user's own file\n"
    assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(out), "--overwrite"]) == 0
    assert out.read_text().startswith("mounting") or "output" in out.read_text().splitlines()[0]
