"""A corpus of named bad inputs across every command: one clean line, nothing changed or stored.

Every case builds its inputs in a fresh folder, runs ``main(argv)`` and checks: a non-zero exit
status, exactly one line on stderr starting ``error:`` (no "Traceback", no "internal error"),
no file in the folder created, changed or removed (SHA-256 of every file before and after), so
also no history database. Then the failure modes that are not about the input: a full disk, a
kill -9 in the middle of ``fit --report --db``, 16 concurrent writers.
"""

from __future__ import annotations

import errno
import hashlib
import json
import multiprocessing as mp
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from inertest.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
TRUTH = "[coefficients]\nDF = 1.2\nDI = 0.85\nDO = -0.62\nDS = 0.31\nDIO = 0.12\nDSI = 0.05\n"


@pytest.fixture(scope="module")
def assets(tmp_path_factory):
    """Good inputs, made once: a polar-tumble plan and data, a Ferraris session and its fit."""
    d = tmp_path_factory.mktemp("assets")
    shutil.copy(EXAMPLES / "polar_tumble" / "plan.toml", d / "plan.toml")
    (d / "truth.toml").write_text(TRUTH)
    env = os.environ.get("INERTEST_DB")
    assert main(["simulate", str(d / "plan.toml"), "--truth", str(d / "truth.toml"),
                 "-o", str(d / "data.csv"), "--noise", "0.002", "--seed", "1"]) == 0
    shutil.copy(EXAMPLES / "ferraris" / "plan.toml", d / "ferraris.toml")
    shutil.copy(EXAMPLES / "ferraris" / "truth.toml", d / "ferraris_truth.toml")
    assert main(["simulate", str(d / "ferraris.toml"), "--truth", str(d / "ferraris_truth.toml"),
                 "-o", str(d / "ferraris.csv"), "--seed", "2"]) == 0
    out = d / "cal.json"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["fit", str(d / "ferraris.toml"), str(d / "ferraris.csv"), "--json",
                     "--no-store"]) == 0
    out.write_text(buf.getvalue())
    shutil.copy(EXAMPLES / "centrifuge" / "study.toml", d / "study.toml")
    shutil.copy(EXAMPLES / "ins_errors" / "source_scenario.toml", d / "scenario.toml")
    shutil.copy(EXAMPLES / "gyro_triad_rotation" / "plan.toml", d / "rotation.toml")
    np.save(d / "two.npy", np.random.default_rng(3).normal(size=(400, 2)))
    assert os.environ.get("INERTEST_DB") == env
    return d


CASES: dict[str, Callable[[Path], list[str]]] = {}


def case(name: str):
    def register(fn: Callable[[Path], list[str]]):
        assert name not in CASES
        CASES[name] = fn
        return fn
    return register


def _plan_with(d: Path, old: str, new: str, name: str = "p2.toml") -> Path:
    text = (d / "plan.toml").read_text()
    assert old in text, old
    (d / name).write_text(text.replace(old, new, 1))
    return d / name


def _fit(d: Path, plan: Path | str = "plan.toml", data: Path | str = "data.csv", *extra):
    return ["fit", str(d / plan), str(d / data), *extra]


# --- fit: plans ---------------------------------------------------------------------------------
@case("fit-plan-not-utf8")
def _(d):
    (d / "p.toml").write_bytes(b"[site]\nlatitude_deg = 4\xff\xfe5\n")
    return _fit(d, "p.toml")


@case("fit-plan-invalid-toml")
def _(d):
    (d / "p.toml").write_text("[site\nlatitude_deg = 45\n")
    return _fit(d, "p.toml")


@case("fit-plan-empty")
def _(d):
    (d / "p.toml").write_text("")
    return _fit(d, "p.toml")


@case("fit-plan-unknown-procedure")
def _(d):
    return _fit(d, _plan_with(d, 'kind = "polar-tumble"', 'kind = "spin-dryer"').name)


@case("fit-plan-boolean-latitude")
def _(d):
    text = (d / "plan.toml").read_text()
    import re
    (d / "p.toml").write_text(re.sub(r"latitude_deg\s*=\s*[-0-9.]+", "latitude_deg = true", text))
    return _fit(d, "p.toml")


@case("fit-plan-latitude-out-of-range")
def _(d):
    text = (d / "plan.toml").read_text()
    import re
    (d / "p.toml").write_text(re.sub(r"latitude_deg\s*=\s*[-0-9.]+", "latitude_deg = 123", text))
    return _fit(d, "p.toml")


@case("fit-plan-unknown-table")
def _(d):
    (d / "p.toml").write_text((d / "plan.toml").read_text() + "\n[sight]\nx = 1\n")
    return _fit(d, "p.toml")


@case("fit-plan-is-directory")
def _(d):
    (d / "dir.toml").mkdir()
    return _fit(d, "dir.toml")


@case("fit-plan-missing")
def _(d):
    return _fit(d, "nope.toml")


@case("fit-serial-escape-codes")
def _(d):
    text = (d / "plan.toml").read_text()
    import re
    (d / "p.toml").write_text(re.sub(r'serial\s*=\s*"[^"]*"', r'serial = "FG\\u001b[31mRED"', text))
    return _fit(d, "p.toml")


@case("fit-serial-nul")
def _(d):
    text = (d / "plan.toml").read_text()
    import re
    (d / "p.toml").write_text(re.sub(r'serial\s*=\s*"[^"]*"', r'serial = "FG\\u0000X"', text))
    return _fit(d, "p.toml")


@case("fit-serial-too-long")
def _(d):
    text = (d / "plan.toml").read_text()
    import re
    (d / "p.toml").write_text(re.sub(r'serial\s*=\s*"[^"]*"', 'serial = "' + "S" * 300 + '"',
                                     text))
    return _fit(d, "p.toml")


# --- fit: data ----------------------------------------------------------------------------------
@case("fit-data-missing-column")
def _(d):
    lines = (d / "data.csv").read_text().splitlines()
    (d / "x.csv").write_text("\n".join(ln.rsplit(",", 1)[0] for ln in lines) + "\n")
    return _fit(d, data="x.csv")


@case("fit-data-nan")
def _(d):
    lines = (d / "data.csv").read_text().splitlines()
    lines[3] = lines[3].rsplit(",", 1)[0] + ",nan"
    (d / "x.csv").write_text("\n".join(lines) + "\n")
    return _fit(d, data="x.csv")


@case("fit-data-header-only")
def _(d):
    (d / "x.csv").write_text((d / "data.csv").read_text().splitlines()[0] + "\n")
    return _fit(d, data="x.csv")


@case("fit-data-zero-bytes")
def _(d):
    (d / "x.csv").write_bytes(b"")
    return _fit(d, data="x.csv")


@case("fit-data-duplicated-column")
def _(d):
    lines = (d / "data.csv").read_text().splitlines()
    head = lines[0].split(",")
    head[-1] = head[0]
    (d / "x.csv").write_text("\n".join([",".join(head), *lines[1:]]) + "\n")
    return _fit(d, data="x.csv")


@case("fit-data-binary-garbage")
def _(d):
    (d / "x.csv").write_bytes(bytes(random.Random(5).randrange(256) for _ in range(3000)))
    return _fit(d, data="x.csv")


@case("fit-data-unknown-suffix")
def _(d):
    shutil.copy(d / "data.csv", d / "x.txt")
    return _fit(d, data="x.txt")


@case("fit-data-corrupt-parquet")
def _(d):
    (d / "x.parquet").write_bytes(b"PAR1" + b"\0" * 100 + b"PAR1")
    return _fit(d, data="x.parquet")


@case("fit-data-corrupt-hdf5")
def _(d):
    (d / "x.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\1" * 200)
    return _fit(d, data="x.h5")


@case("fit-data-hdf5-external-link")
def _(d):
    import h5py
    with h5py.File(d / "other.h5", "w") as fh:
        fh["output"] = np.ones(10)
    with h5py.File(d / "x.h5", "w") as fh:
        fh["output"] = h5py.ExternalLink(str(d / "other.h5"), "/output")
    return _fit(d, data="x.h5")


@case("fit-data-is-directory")
def _(d):
    (d / "dir.csv").mkdir()
    return _fit(d, data="dir.csv")


@case("fit-data-text-in-number-column")
def _(d):
    lines = (d / "data.csv").read_text().splitlines()
    lines[2] = lines[2].rsplit(",", 1)[0] + ",twelve"
    (d / "x.csv").write_text("\n".join(lines) + "\n")
    return _fit(d, data="x.csv")


@case("fit-ferraris-rate-10x-too-low")
def _(d):
    text = (d / "ferraris.toml").read_text().replace("sample_rate_hz = 200.0",
                                                    "sample_rate_hz = 20.0")
    (d / "f20.toml").write_text(text)
    return _fit(d, "f20.toml", "ferraris.csv")


# --- fit: options and outputs -------------------------------------------------------------------
@case("fit-report-is-data")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--report", str(d / "data.csv"))


@case("fit-report-is-plan")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--report", str(d / "plan.toml"))


@case("fit-report-holds-inputs")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--report", str(d))


@case("fit-report-foreign-folder")
def _(d):
    (d / "mine").mkdir()
    (d / "mine" / "thesis.tex").write_text("years of work")
    return _fit(d, "plan.toml", "data.csv", "--report", str(d / "mine"))


@case("fit-report-symlink-to-data")
def _(d):
    (d / "link.csv").symlink_to(d / "data.csv")
    return _fit(d, "plan.toml", "data.csv", "--report", str(d / "link.csv"))


@case("fit-pdf-without-report")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--pdf")


@case("fit-db-unreachable-with-password")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--db",
                "postgresql+psycopg://lab:hunter2@127.0.0.1:1/h")


@case("fit-db-not-a-url")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--db", "nosuchdriver://x/y")


@case("fit-db-folder-missing")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--db", str(d / "no" / "such" / "h.db"))


@case("fit-db-damaged-file")
def _(d):
    (d / "h.db").write_bytes(b"SQLite format 3\0" + b"\x13" * 4000)
    return _fit(d, "plan.toml", "data.csv", "--db", str(d / "h.db"))


@case("fit-sigma-negative")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--sigma", "-1")


@case("fit-sigma-nan")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--sigma", "nan")


@case("fit-tested-at-malformed")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--tested-at", "yesterday")


@case("fit-unknown-option")
def _(d):
    return _fit(d, "plan.toml", "data.csv", "--jsno")


# --- simulate -----------------------------------------------------------------------------------
def _sim(d: Path, *extra: str) -> list[str]:
    return ["simulate", str(d / "plan.toml"), "--truth", str(d / "truth.toml"), *extra]


@case("simulate-output-is-plan")
def _(d):
    return _sim(d, "-o", str(d / "plan.toml"))


@case("simulate-output-is-truth")
def _(d):
    return _sim(d, "-o", str(d / "truth.toml"))


@case("simulate-truth-not-utf8")
def _(d):
    (d / "truth.toml").write_bytes(b"[coefficients]\nDF = 1.0 # \xe9\xff\n")
    return _sim(d, "-o", str(d / "out.csv"))


@case("simulate-truth-not-a-number")
def _(d):
    (d / "truth.toml").write_text('[coefficients]\nDF = "one"\n')
    return _sim(d, "-o", str(d / "out.csv"))


@case("simulate-truth-unknown-coefficient")
def _(d):
    (d / "truth.toml").write_text("[coefficients]\nDX = 1.0\n")
    return _sim(d, "-o", str(d / "out.csv"))


@case("simulate-output-unknown-suffix")
def _(d):
    return _sim(d, "-o", str(d / "out.xlsx"))


@case("simulate-output-parent-is-file")
def _(d):
    return _sim(d, "-o", str(d / "data.csv" / "out.csv"))


# --- allan --------------------------------------------------------------------------------------
def _allan(d: Path, data: str, *extra: str) -> list[str]:
    return ["allan", str(d / data), *extra]


@case("allan-report-is-data")
def _(d):
    return _allan(d, "data.csv", "--column", "output", "--rate", "1", "--report",
                  str(d / "data.csv"))


@case("allan-plot-is-data")
def _(d):
    return _allan(d, "two.npy", "--column", "0", "--rate", "1", "--plot", str(d / "two.npy"))


@case("allan-plot-equals-report")
def _(d):
    return _allan(d, "two.npy", "--column", "0", "--rate", "1", "--plot", str(d / "a.svg"),
                  "--report", str(d / "a.svg"))


@case("allan-plot-unknown-suffix")
def _(d):
    return _allan(d, "two.npy", "--column", "0", "--rate", "1", "--plot", str(d / "a.gif"))


@case("allan-rate-1e-300")
def _(d):
    return _allan(d, "two.npy", "--column", "0", "--rate", "1e-300")


@case("allan-rate-nan")
def _(d):
    return _allan(d, "two.npy", "--column", "0", "--rate", "nan")


@case("allan-npy-column-out-of-range")
def _(d):
    return _allan(d, "two.npy", "--column", "7", "--rate", "1")


@case("allan-npy-column-negative")
def _(d):
    return _allan(d, "two.npy", "--column", "-1", "--rate", "1")


@case("allan-csv-duplicated-column")
def _(d):
    (d / "x.csv").write_text("a,a\n1,2\n3,4\n5,6\n")
    return _allan(d, "x.csv", "--column", "a", "--rate", "1")


@case("allan-raw-without-dtype")
def _(d):
    (d / "x.bin").write_bytes(b"\0" * 64)
    return _allan(d, "x.bin", "--rate", "1")


@case("allan-npy-pickled-objects")
def _(d):
    np.save(d / "x.npy", np.array([{"a": 1}, None], dtype=object), allow_pickle=True)
    return _allan(d, "x.npy", "--rate", "1")


@case("allan-all-nan")
def _(d):
    np.save(d / "x.npy", np.full(100, np.nan))
    return _allan(d, "x.npy", "--rate", "1")


@case("allan-unknown-statistic")
def _(d):
    return _allan(d, "two.npy", "--column", "0", "--rate", "1", "--stats", "avar")


# --- apply --------------------------------------------------------------------------------------
@case("apply-output-is-data")
def _(d):
    return ["apply", str(d / "cal.json"), str(d / "ferraris.csv"), "-o", str(d / "ferraris.csv")]


@case("apply-output-is-calibration")
def _(d):
    return ["apply", str(d / "cal.json"), str(d / "ferraris.csv"), "-o", str(d / "cal.json")]


@case("apply-calibration-not-json")
def _(d):
    (d / "c.json").write_text("{calibration: yes")
    return ["apply", str(d / "c.json"), str(d / "ferraris.csv"), "-o", str(d / "o.csv")]


@case("apply-calibration-not-utf8")
def _(d):
    (d / "c.json").write_bytes(b'{"a": "\xff\xfe"}')
    return ["apply", str(d / "c.json"), str(d / "ferraris.csv"), "-o", str(d / "o.csv")]


@case("apply-missing-columns")
def _(d):
    return ["apply", str(d / "cal.json"), str(d / "data.csv"), "-o", str(d / "o.csv")]


# --- centrifuge-study ---------------------------------------------------------------------------
@case("study-report-is-plan")
def _(d):
    return ["centrifuge-study", str(d / "study.toml"), "--report", str(d / "study.toml")]


@case("study-empty-file")
def _(d):
    (d / "s.toml").write_text("")
    return ["centrifuge-study", str(d / "s.toml")]


@case("study-not-utf8")
def _(d):
    (d / "s.toml").write_bytes(b"[site]\nname = '\xff'\n")
    return ["centrifuge-study", str(d / "s.toml")]


@case("study-missing")
def _(d):
    return ["centrifuge-study", str(d / "nope.toml")]


# --- ins-errors ---------------------------------------------------------------------------------
@case("ins-errors-scenario-not-utf8")
def _(d):
    (d / "s.toml").write_bytes(b"[site]\nlatitude_deg = 39 # \xff\n")
    return ["ins-errors", "--scenario", str(d / "s.toml")]


@case("ins-errors-plot-is-scenario")
def _(d):
    return ["ins-errors", "--scenario", str(d / "scenario.toml"), "--plot",
            str(d / "scenario.toml")]


@case("ins-errors-plot-unknown-suffix")
def _(d):
    return ["ins-errors", "--latitude", "39", "--plot", str(d / "f.bmp")]


@case("ins-errors-latitude-90")
def _(d):
    return ["ins-errors", "--latitude", "90"]


# --- modulation ---------------------------------------------------------------------------------
@case("modulation-sample-hz-0")
def _(d):
    return ["modulation", "component", "--sample-hz", "0"]


@case("modulation-component-plot-suffix")
def _(d):
    return ["modulation", "component", "--duration-s", "2", "--plot", str(d / "m.gif")]


@case("modulation-system-plot-suffix")
def _(d):
    return ["modulation", "system", "--hours", "1", "--plot", str(d / "m.tiff")]


@case("modulation-system-plot-equals-report")
def _(d):
    return ["modulation", "system", "--hours", "1", "--plot", str(d / "m.svg"), "--report",
            str(d / "m.svg")]


@case("modulation-hours-0")
def _(d):
    return ["modulation", "system", "--hours", "0"]


# --- history ------------------------------------------------------------------------------------
@case("history-plot-suffix")
def _(d):
    return ["history", "FG-1", "--db", str(d / "h.db"), "--plot", str(d / "h.gif")]


@case("history-no-database")
def _(d):
    return ["history", "FG-1", "--db", str(d / "h.db")]


@case("history-serial-escape-codes")
def _(d):
    return ["history", "FG\x1b[2J", "--db", str(d / "h.db")]


@case("history-serial-too-long")
def _(d):
    return ["history", "S" * 500, "--db", str(d / "h.db")]


@case("history-damaged-database")
def _(d):
    (d / "h.db").write_bytes(b"SQLite format 3\0" + bytes(range(256)) * 20)
    return ["history", "FG-1", "--db", str(d / "h.db")]


@case("history-not-a-database")
def _(d):
    (d / "h.db").write_text("just some notes\n")
    return ["history", "FG-1", "--db", str(d / "h.db")]


# --- thermal, navigation, batch -----------------------------------------------------------------
@case("thermal-fit-plot-is-data")
def _(d):
    return ["thermal", "fit", str(d / "data.csv"), "--plot", str(d / "data.csv")]


@case("thermal-fit-report-holds-data")
def _(d):
    return ["thermal", "fit", str(d / "data.csv"), "--report", str(d)]


@case("nav-simulate-output-is-plan")
def _(d):
    return ["nav-simulate", str(d / "rotation.toml"), "--truth", str(d / "truth.toml"), "-o",
            str(d / "rotation.toml")]


@case("nav-calibrate-report-holds-inputs")
def _(d):
    return ["nav-calibrate", str(d / "rotation.toml"), str(d / "data.csv"), "--initial",
            str(d / "cal.json"), "--report", str(d)]


@case("batch-manifest-not-utf8")
def _(d):
    (d / "m.toml").write_bytes(b"[[run]]\nplan = '\xff'\n")
    return ["batch", str(d / "m.toml")]


@case("batch-manifest-no-runs")
def _(d):
    (d / "m.toml").write_text("")
    return ["batch", str(d / "m.toml")]


@case("batch-report-is-data")
def _(d):
    (d / "m.toml").write_text('[[run]]\nplan = "plan.toml"\ndata = "data.csv"\n'
                              'report = "data.csv"\n')
    return ["batch", str(d / "m.toml")]


def _digest(folder: Path) -> dict[str, str]:
    out = {}
    for p in sorted(folder.rglob("*")):
        rel = str(p.relative_to(folder))
        if p.is_symlink():
            out[rel] = "link:" + os.readlink(p)
        elif p.is_file():
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
        elif p.is_dir():
            out[rel] = "dir"
    return out


def test_corpus_is_large():
    assert len(CASES) >= 60


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_is_one_clean_line(name, assets, tmp_path, monkeypatch, capsys):
    work = tmp_path / "work"
    shutil.copytree(assets, work)
    monkeypatch.setenv("INERTEST_DB", str(work / "history.db"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.chdir(work)
    argv = CASES[name](work)
    before = _digest(work)
    capsys.readouterr()
    status = main(argv)
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert status != 0, f"{name}: exit 0; stderr {err!r}"
    assert "Traceback" not in err and "internal error" not in err, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "\x1b" not in err and "\0" not in err
    assert "hunter2" not in err
    assert _digest(work) == before, f"{name} changed files in its folder"
    assert not (tmp_path / "cache" / "inertest").exists()  # no crash log


# --- what is not about the input ----------------------------------------------------------------
@pytest.mark.parametrize("command", ["simulate", "fit-report", "allan-report", "apply"])
def test_disk_full_is_one_line_and_leaves_nothing(command, assets, tmp_path, monkeypatch,
                                                  capsys):
    work = tmp_path / "work"
    shutil.copytree(assets, work)
    db = work / "h.db"
    argv = {
        "simulate": _sim(work, "-o", str(work / "new.csv")),
        "fit-report": _fit(work, "plan.toml", "data.csv", "--report", str(work / "rep"),
                           "--db", str(db)),
        "allan-report": _allan(work, "two.npy", "--column", "0", "--rate", "1", "--report",
                               str(work / "a.html"), "--no-noise-id"),
        "apply": ["apply", str(work / "cal.json"), str(work / "ferraris.csv"), "-o",
                  str(work / "o.csv")],
    }[command]
    before = _digest(work)
    real_replace = os.replace

    def full(src, dst, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(dst))

    monkeypatch.setattr(os, "replace", full)
    status = main(argv)
    monkeypatch.setattr(os, "replace", real_replace)
    err = capsys.readouterr().err
    assert status != 0 and "disk full at" in err and "Traceback" not in err
    assert len([ln for ln in err.splitlines() if ln.strip()]) == 1
    assert _digest(work) == before


def test_unexpected_error_is_one_line_and_a_log(tmp_path, monkeypatch, capsys):
    import inertest.cli.allan as allan_cli

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    np.save(tmp_path / "x.npy", np.ones(100))

    def boom(*a, **k):
        raise RuntimeError("postgresql://u:topsecret@db/x exploded")

    monkeypatch.setattr(allan_cli, "deviations", boom)
    assert main(["allan", str(tmp_path / "x.npy"), "--rate", "1"]) == 70
    err = capsys.readouterr().err
    assert "Traceback" not in err and "topsecret" not in err and len(err.splitlines()) == 1
    log = Path(err.split("details in ")[1].split(". Please")[0])
    text = log.read_text()
    assert log.is_relative_to(tmp_path / "cache") and "Traceback" in text
    assert "RuntimeError" in text and "topsecret" not in text


def test_dollar_signs_in_names_are_plain_text(tmp_path, capsys):
    data = tmp_path / "gyro $\\frac{1}{0$ run.npy"
    np.save(data, np.random.default_rng(1).normal(size=2000))
    assert main(["allan", str(data), "--rate", "10", "--plot", str(tmp_path / "a$x$.png"),
                 "--report", str(tmp_path / "r.html")]) == 0
    assert (tmp_path / "a$x$.png").stat().st_size > 0


def test_failed_store_leaves_no_database_file(assets, tmp_path, capsys):
    work = tmp_path / "work"
    shutil.copytree(assets, work)
    db = work / "new.db"
    text = (work / "plan.toml").read_text()
    import re
    (work / "p.toml").write_text(re.sub(r'serial\s*=\s*"[^"]*"', r'serial = "\\u0007"', text))
    assert main(_fit(work, "p.toml", "data.csv", "--db", str(db))) == 2
    assert not db.exists()
    assert main(["history", "FG-1", "--db", str(db)]) == 2
    assert not db.exists()


# --- kill -9 in the middle of fit --report --db -------------------------------------------------
def _state(work: Path) -> tuple[int, bool]:
    import sqlite3

    db = work / "h.db"
    runs = 0
    if db.exists():
        con = sqlite3.connect(db)
        try:
            runs = con.execute("SELECT count(*) FROM runs").fetchone()[0]
        except sqlite3.OperationalError:
            runs = 0  # created but not migrated yet
        finally:
            con.close()
    rep = work / "rep"
    complete = rep.is_dir() and (rep / "index.html").is_file() and (
        rep / ".inertest-report").is_file()
    if rep.exists():
        assert complete, f"half-written report: {sorted(p.name for p in rep.iterdir())}"
    return runs, complete


@pytest.mark.slow
def test_kill_9_leaves_nothing_or_a_complete_run_and_report(assets, tmp_path):
    rng = random.Random(16)
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "ignore"}
    argv_tail = ["--report", "rep", "--db", "h.db"]
    outcomes = []
    for k in range(2):
        work = tmp_path / f"w{k}"
        work.mkdir()
        for f in ("plan.toml", "data.csv"):
            shutil.copy(assets / f, work / f)
        proc = subprocess.Popen(
            [sys.executable, "-c", "import sys; from inertest.cli import main; "
             "sys.exit(main(sys.argv[1:]))", "fit", "plan.toml", "data.csv", *argv_tail],
            cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(0.5, 4.0))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        runs, report = _state(work)
        assert runs <= 1
        outcomes.append((runs, report))
        # the next run cleans the killed one's hidden temporaries and completes
        done = subprocess.run(
            [sys.executable, "-c", "import sys; from inertest.cli import main; "
             "sys.exit(main(sys.argv[1:]))", "fit", "plan.toml", "data.csv", *argv_tail,
             "--allow-duplicate"], cwd=work, env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert _state(work) == (runs + 1, True)
        assert [p.name for p in work.iterdir() if p.name.startswith(".rep.")] == []
    # a report without its run (or the reverse) only in the instant between commit and rename
    assert sum(r == 1 and not rep for r, rep in outcomes) <= 1


# --- 16 concurrent writers ----------------------------------------------------------------------
def _writer(url: str, start: int, n: int) -> None:
    from tests.store.test_history_store import record

    from inertest.store import HistoryStore

    store = HistoryStore(url)
    for i in range(n):
        store.add(record(days=start + i))
    store.close()


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_16_concurrent_writers_lose_nothing(backend, tmp_path):
    from inertest.store import HistoryStore

    if backend == "sqlite":
        url = "sqlite:///" + str(tmp_path / "h.db")  # created by the first writer
    else:
        url = os.environ.get("INERTEST_TEST_PG_URL", "")
        if not url:
            pytest.skip("no PostgreSQL server: set INERTEST_TEST_PG_URL")
        import sqlalchemy as sa
        engine = sa.create_engine(url)
        with engine.begin() as conn:
            conn.execute(sa.text("DROP TABLE IF EXISTS estimates, runs, alembic_version CASCADE"))
        engine.dispose()
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=_writer, args=(url, k * 100, 1)) for k in range(16)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(180)
    assert [p.exitcode for p in procs] == [0] * 16
    store = HistoryStore(url)
    runs = store.runs("FG-1")
    store.close()
    assert len(runs) == 16 and len({r.run_uuid for r in runs}) == 16
    assert json.dumps(runs[0].result)
