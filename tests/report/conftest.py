"""Every report kind, written once per session by the command line as a user would."""

import numpy as np
import pytest

from inertest.cli import main

#: Procedure kind -> (plan folder, truth file relative to it, noise) of the examples.
FITS = {
    "polar-tumble": ("polar_tumble", "truth.toml", 0.002),
    "local-level-tumble": ("local_level_tumble", "../polar_tumble/truth.toml", 0.002),
    "gyro-rate-table": ("gyro_rate_table", "truth.toml", 2.0),
    "gyro-triad-rotation": ("gyro_triad_rotation", "truth.toml", 30.0),
    "ferraris": ("ferraris", "truth.toml", 0.0),
    "triad-multiposition": ("triad_multiposition", "truth.toml", 2.0),
    "accelerometer-multipoint": ("accelerometer_multipoint", "truth.toml", 1e-6),
    "centrifuge-nine-position": ("centrifuge", "truth.toml", 3.3e-8),
    "servo-table": ("servo_table", "truth.toml", 0.5),
    "orientation-free": ("orientation_free", "truth.toml", 0.0),
    "systematic": ("systematic", "truth.toml", 0.0),
}


@pytest.fixture(scope="session")
def reports(tmp_path_factory):
    """Every report kind, written by the command line as a user would: {name: index.html}."""
    from pathlib import Path

    examples_dir = Path(__file__).resolve().parents[2] / "examples"
    tmp = tmp_path_factory.mktemp("reports")
    lab = examples_dir / "lab" / "equipment.toml"
    out = {}
    for kind, (folder, truth, noise) in FITS.items():
        plan = examples_dir / folder / "plan.toml"
        data = tmp / f"{folder}.csv"
        assert main(["simulate", str(plan), "--truth", str(plan.parent / truth), "-o",
                     str(data), "--noise", str(noise), "--seed", "3"]) == 0
        assert main(["fit", str(plan), str(data), "--no-store", "--equipment", str(lab),
                     "--report", str(tmp / kind)]) == 0
        out[f"fit {kind}"] = tmp / kind / "index.html"
    # history: a report whose instrument has three stored runs (a trend), judged against a
    # spec, the last also printed to PDF by the command line (fit --pdf)
    plan = examples_dir / "polar_tumble" / "plan.toml"
    spec = examples_dir / "specs" / "floated_gyro.toml"
    db = tmp / "h.db"
    for i in range(3):
        data = tmp / f"hist{i}.csv"
        main(["simulate", str(plan), "--truth", str(plan.parent / "truth.toml"), "-o",
              str(data), "--noise", "0.002", "--seed", str(10 + i)])
        assert main(["fit", str(plan), str(data), "--db", str(db), "--equipment", str(lab),
                     "--spec", str(spec), "--report", str(tmp / "history"), "--tested-at",
                     f"2026-0{i + 1}-0{i + 1}", *(["--pdf"] if i == 2 else [])]) == 0
    out["history"] = tmp / "history" / "index.html"
    assert main(["history", "FG-0417", "--db", str(db), "--spec", str(spec), "--report",
                 str(tmp / "drift" / "index.html")]) == 0
    out["history figure"] = tmp / "drift" / "index.html"
    assert main(["demo", "--examples", str(examples_dir), "--report", str(tmp / "demo")]) == 0
    out["demo"] = tmp / "demo" / "index.html"
    rng = np.random.default_rng(4)
    rate = 1e-4 * rng.standard_normal(20_000) + np.cumsum(1e-6 * rng.standard_normal(20_000))
    np.save(tmp / "g.npy", rate)
    assert main(["allan", str(tmp / "g.npy"), "--rate", "50", "--stats",
                 "adev,oadev,mdev,tdev,hdev,ohdev", "--report",
                 str(tmp / "allan" / "index.html")]) == 0
    out["allan"] = tmp / "allan" / "index.html"
    assert main(["centrifuge-study", str(examples_dir / "centrifuge" / "study.toml"),
                 "--monte-carlo", "0", "--report", str(tmp / "cs" / "index.html")]) == 0
    out["centrifuge-study"] = tmp / "cs" / "index.html"
    assert main(["modulation", "system", "--hours", "6", "--compare", "--rate-deg-s", "10",
                 "--dwell-s", "30", "--report", str(tmp / "mod" / "index.html")]) == 0
    out["modulation"] = tmp / "mod" / "index.html"
    assert main(["ins-errors", "--example", "--report", str(tmp / "ins" / "index.html")]) == 0
    out["ins-errors"] = tmp / "ins" / "index.html"
    assert main(["thermal", "simulate", "-o", str(tmp / "th.csv"), "--seed", "5"]) == 0
    assert main(["thermal", "fit", str(tmp / "th.csv"), "--serial", "G-17", "--report",
                 str(tmp / "thermal")]) == 0
    out["thermal"] = tmp / "thermal" / "index.html"
    assert main(["noise", str(examples_dir / "noise" / "lasergyro.imu.xz"), "--report",
                 str(tmp / "noise")]) == 0
    out["noise"] = tmp / "noise" / "index.html"
    tplan = examples_dir / "thermal_triad" / "plan.toml"
    assert main(["thermal", "triad-simulate", str(tplan), str(tplan.parent / "laws.toml"), "-o",
                 str(tmp / "triad.csv"), "--noise", "2", "--seed", "1"]) == 0
    assert main(["thermal", "triad", str(tplan), str(tmp / "triad.csv"), "--report",
                 str(tmp / "thermal-triad")]) == 0
    out["thermal triad"] = tmp / "thermal-triad" / "index.html"
    return out


