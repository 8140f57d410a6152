"""`inertest fit` stores runs; `inertest history` reads them back; reports show the history."""

import json

import numpy as np
import pytest

from inertest.cli import main


@pytest.fixture
def campaign(tmp_path, examples_dir):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    truth = examples_dir / "polar_tumble" / "truth.toml"
    db = tmp_path / "lab.db"
    files = []
    for i, seed in enumerate((1, 2, 3)):
        data = tmp_path / f"run{i}.csv"
        assert main(["simulate", str(plan), "--truth", str(truth), "-o", str(data),
                     "--noise", "0.002", "--seed", str(seed)]) == 0
        files.append(data)
    return plan, files, db, tmp_path


def test_fit_stores_and_history_summarises(campaign, capsys):
    plan, files, db, tmp = campaign
    di = []
    for i, data in enumerate(files):
        assert main(["fit", str(plan), str(data), "--db", str(db), "--json",
                     "--tested-at", f"2026-0{i + 1}-15"]) == 0
        di.append(json.loads(capsys.readouterr().out)["identification"]["coefficients"]["DI"]["value"])
    assert main(["history", "FG-0417", "--db", str(db), "--json", "--plot",
                 str(tmp / "h.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["tested_at"][:10] for r in out["result"]["runs"]] == ["2026-01-15", "2026-02-15",
                                                          "2026-03-15"]
    q = {h["name"]: h for h in out["result"]["quantities"]}
    assert q["DI"]["values"] == di
    # repeatability weighted by the run stds (reliability weights 1/s^2)
    w = 1 / np.array(q["DI"]["stds"]) ** 2
    m = np.average(di, weights=w)
    assert q["DI"]["repeatability"] == pytest.approx(
        np.sqrt(np.sum(w * (np.array(di) - m) ** 2) / (w.sum() - (w**2).sum() / w.sum())))
    assert q["DI"]["scatter_test"]["dof"] == 2
    assert q["DI"]["unit"] == "deg/h/g" and q["DI"]["trend_per_day"] is not None
    assert (tmp / "h.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["history", "FG-0417", "--db", str(db)]) == 0
    assert "repeatability" in capsys.readouterr().out


def test_report_shows_history_from_the_second_run(campaign, capsys):
    plan, files, db, tmp = campaign
    main(["fit", str(plan), str(files[0]), "--db", str(db), "--report", str(tmp / "r1"),
          "--tested-at", "2026-01-01"])
    main(["fit", str(plan), str(files[1]), "--db", str(db), "--report", str(tmp / "r2"),
          "--tested-at", "2026-02-01"])
    first = (tmp / "r1" / "index.html").read_text()
    second = (tmp / "r2" / "index.html").read_text()
    assert "first stored run" in first
    assert "History of FG-0417" in second and second.count("data:image/png") == 2
    for html in (first, second):
        assert "polar-tumble" in html and "sha256" in html and "latitude_deg = 34.246" in html


def test_failed_fit_and_no_store_write_nothing(campaign, capsys, tmp_path):
    plan, files, db, tmp = campaign
    bad = tmp / "bad.csv"
    bad.write_text("mounting,angle_deg,output\nO-Np,0,\n")
    assert main(["fit", str(plan), str(bad), "--db", str(db), "--report", str(tmp / "r")]) == 2
    assert not db.exists() and not (tmp / "r").exists()
    assert main(["fit", str(plan), str(files[0]), "--db", str(db), "--no-store"]) == 0
    assert not db.exists()
    capsys.readouterr()
    assert main(["history", "NOPE", "--db", str(db)]) == 2
    assert 'no runs stored for serial "NOPE"' in capsys.readouterr().err


def test_unreachable_database_is_a_clean_error_and_no_report(campaign, capsys):
    plan, files, _, tmp = campaign
    url = "postgresql+psycopg://lab:pw@127.0.0.1:1/history"
    assert main(["fit", str(plan), str(files[0]), "--db", url, "--report", str(tmp / "r")]) == 2
    err = capsys.readouterr().err
    assert "cannot open the history database" in err and "pw@" not in err
    assert not (tmp / "r").exists()
