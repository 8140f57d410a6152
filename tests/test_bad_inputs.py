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
import os
import random
import shutil
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from child_processes import INERTEST, processes, run_inertest
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
    _thermal_assets(d)
    assert os.environ.get("INERTEST_DB") == env
    return d


def _thermal_assets(d: Path) -> None:
    """A gyro bias recorded over 4 chamber cycles, its thermal model, a triad thermal plan."""
    from inertest.io.data_file import write_table

    t = np.arange(0.0, 4 * 12000.0, 60.0)
    temp = 10.0 - 50.0 * np.cos(2 * np.pi * t / 12000.0)
    bias = 0.5 + 0.004 * (temp - 20) + np.random.default_rng(4).normal(0, 0.01, t.size)
    write_table(d / "chamber.csv", {"cycle": t // 12000 + 1, "time_s": t,
                                    "temperature_c": temp, "bias_deg_h": bias})
    assert main(["thermal", "fit", str(d / "chamber.csv"), "--quantity", "bias", "--no-rate",
                 "--model-out", str(d / "bias_model.json")]) == 0
    shutil.copy(EXAMPLES / "thermal_triad" / "plan.toml", d / "triad.toml")


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


@case("simulate-truth-empty")
def _(d):  # every coefficient zero by accident (an independent review: exit 0, data written)
    (d / "t0.toml").write_text("")
    return ["simulate", str(d / "plan.toml"), "--truth", str(d / "t0.toml"), "-o",
            str(d / "new.csv")]


# --- data files that are not UTF-8 (an independent review: internal errors) --------------------
def _latin1_header(d: Path, src: str, name: str) -> Path:
    lines = (d / src).read_bytes().split(b"\n", 1)
    (d / name).write_bytes(lines[0].replace(b"_", b"\xe9", 1) + b"\n" + lines[1])
    return d / name


@case("fit-data-header-not-utf8")
def _(d):
    return _fit(d, "plan.toml", _latin1_header(d, "data.csv", "latin1.csv").name)


@case("allan-data-header-not-utf8")
def _(d):
    return _allan(d, _latin1_header(d, "data.csv", "latin1.csv").name, "--column", "t_s",
                  "--rate", "1")


@case("thermal-fit-data-header-not-utf8")
def _(d):
    return ["thermal", "fit", str(_latin1_header(d, "chamber.csv", "latin1.csv")),
            "--quantity", "bias"]


@case("fit-spec-not-utf8")
def _(d):
    (d / "spec.toml").write_bytes(b'[[limit]]\nquantity = "D\xffI"\n')
    return _fit(d, "plan.toml", "data.csv", "--spec", str(d / "spec.toml"), "--no-store")


@case("apply-data-text-column")
def _(d):
    text = (d / "ferraris.csv").read_text().splitlines()
    head = text[0].split(",")
    k = head.index("acc_z") if "acc_z" in head else len(head) - 1
    rows = [",".join("abc" if i == k else v for i, v in enumerate(r.split(",")))
            for r in text[1:]]
    (d / "text.csv").write_text("\n".join([text[0], *rows]) + "\n")
    return ["apply", str(d / "cal.json"), str(d / "text.csv"), "-o", str(d / "o.csv")]


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


# --- issue 34: paths inside report folders -----------------------------------------------------
def _user_folder_and_report(d: Path, listed: list[str]) -> Path:
    """``rep/`` an earlier report whose manifest lists ``listed``; ``rep/sub -> ../user``."""
    (d / "user").mkdir()
    (d / "user" / "keep.txt").write_text("the user's")
    (d / "rep").mkdir()
    (d / "rep" / "sub").symlink_to("../user")
    (d / "rep" / ".inertest-report").write_text(json.dumps(
        {"written_by": "inertest", "files": listed}))
    return d / "rep"


def _fit_report(d: Path, rep: Path) -> list[str]:
    return _fit(d, "plan.toml", "data.csv", "--no-store", "--report", str(rep))


def _thermal_report(d: Path, rep: Path) -> list[str]:
    return ["thermal", "fit", str(d / "chamber.csv"), "--quantity", "bias", "--report", str(rep)]


for _name, _listed, _command in (
        ("fit-report-manifest-behind-symlink", "sub/keep.txt", _fit_report),  # the repro
        ("fit-report-manifest-outside-folder", "../plan.toml", _fit_report),
        ("thermal-report-manifest-behind-symlink", "sub/keep.txt", _thermal_report)):
    @case(_name)
    def _(d, _listed=_listed, _command=_command):
        """The issue's repro was exit 0 and user/keep.txt gone."""
        return _command(d, _user_folder_and_report(d, [_listed]))


@case("fit-report-manifest-file-is-symlink")
def _(d):
    rep = _user_folder_and_report(d, ["index.html"])
    (rep / "index.html").symlink_to("../user/keep.txt")
    return _fit_report(d, rep)


# --- issue 34: files read back hold finite numbers of the right type ----------------------------
def _thermal_model_with(d: Path, value: float, name: str = "m.json") -> Path:
    doc = json.loads((d / "bias_model.json").read_text())
    doc["terms"][-1]["value"] = value
    (d / name).write_text(json.dumps(doc))
    return d / name


def _apply_thermal(d: Path, model: Path) -> list[str]:
    return ["apply", str(model), str(d / "chamber.csv"), "-o", str(d / "o.csv"),
            "--temperature-column", "temperature_c"]


@case("apply-thermal-model-nan-coefficient")
def _(d):
    """Was: an all-NaN column written and success reported."""
    return _apply_thermal(d, _thermal_model_with(d, float("nan")))


@case("apply-thermal-model-overflowing-coefficient")
def _(d):
    return _apply_thermal(d, _thermal_model_with(d, 1e308))


@case("apply-calibration-infinity")
def _(d):
    doc = json.loads((d / "cal.json").read_text())
    doc["result"]["calibration"]["gyroscope"]["offset"][1] = float("inf")
    (d / "c.json").write_text(json.dumps(doc))
    return ["apply", str(d / "c.json"), str(d / "ferraris.csv"), "-o", str(d / "o.csv")]


@case("fit-lab-file-nan")
def _(d):
    text = (EXAMPLES / "lab" / "equipment.toml").read_text()
    (d / "lab.toml").write_text(text.replace("rate_ppm = 5.0", "rate_ppm = nan"))
    return _fit(d, "plan.toml", "data.csv", "--equipment", str(d / "lab.toml"))


@case("fit-spec-file-inf")
def _(d):
    text = (EXAMPLES / "specs" / "floated_gyro.toml").read_text()
    (d / "spec.toml").write_text(text.replace("max_abs = 1.0", "max_abs = inf", 1))
    return _fit(d, "plan.toml", "data.csv", "--spec", str(d / "spec.toml"))


for _name, _file, _text, _argv in (
        ("simulate-truth-nan", "truth.toml", "[coefficients]\nDF = nan\n",
         lambda d: _sim(d, "-o", str(d / "out.csv"))),
        ("batch-manifest-sigma-nan", "m.toml",
         '[[run]]\nplan = "plan.toml"\ndata = "data.csv"\nsigma = nan\n',
         lambda d: ["batch", str(d / "m.toml")])):
    @case(_name)
    def _(d, _file=_file, _text=_text, _argv=_argv):
        (d / _file).write_text(_text)
        return _argv(d)


@case("fit-data-hdf5-complex-column")
def _(d):
    """Was: read with the imaginary part dropped (numpy's ComplexWarning the only sign)."""
    import h5py

    from inertest.io.data_file import read_table
    with h5py.File(d / "x.h5", "w") as fh:
        for k, v in read_table(d / "data.csv").items():
            if v.dtype.kind == "f":
                fh[k] = v + (1j if k == "output" else 0)
            else:
                fh.create_dataset(k, data=v.astype(object), dtype=h5py.string_dtype())
    return _fit(d, data="x.h5")


@case("fit-data-parquet-list-column")
def _(d):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from inertest.io.data_file import read_table
    cols = {k: v.tolist() for k, v in read_table(d / "data.csv").items()}
    cols["output"] = [[x] for x in cols["output"]]
    pq.write_table(pa.table(cols), d / "x.parquet")
    return _fit(d, data="x.parquet")


@case("allan-npy-complex")
def _(d):
    np.save(d / "x.npy", np.ones(400) + 1j)
    return _allan(d, "x.npy", "--rate", "1")


# --- issue 34: number options -------------------------------------------------------------------
def _history_k(d: Path, k: str) -> list[str]:
    """``history -k K`` of a database with two runs (-k nan switched the outlier flags off)."""
    for extra in ((), ("--allow-duplicate",)):
        assert main(_fit(d, "plan.toml", "data.csv", "--db", str(d / "h.db"), *extra)) == 0
    return ["history", "FG-0417", "--db", str(d / "h.db"), "-k", k]


for _name, _argv in {  # 1e300 overflowed in the fit
    "history-k-nan": lambda d: _history_k(d, "nan"),
    "history-k-inf": lambda d: _history_k(d, "inf"),
    "fit-sigma-inf": lambda d: _fit(d, "plan.toml", "data.csv", "--sigma", "inf"),
    "fit-sigma-1e300": lambda d: _fit(d, "plan.toml", "data.csv", "--sigma", "1e300"),
    "modulation-stator-hz-nan": lambda d: ["modulation", "component", "--stator-hz", "1,nan"],
}.items():
    case(_name)(_argv)


@case("batch-timeout-nan")
def _(d):
    (d / "m.toml").write_text('[[run]]\nplan = "plan.toml"\ndata = "data.csv"\n')
    return ["batch", str(d / "m.toml"), "--timeout", "nan"]


# --- issue 34: inputs that reached the internal-error handler -----------------------------------
@case("plan-check-sigma-1e300")
def _(d):
    (d / "noise.toml").write_text("sigma = 1e300\n")
    return ["plan-check", str(d / "plan.toml"), "--spec",
            str(EXAMPLES / "specs" / "floated_gyro.toml"), "--noise", str(d / "noise.toml")]


@case("thermal-triad-header-only")
def _(d):
    (d / "x.csv").write_text("step,temperature_c,branch,position,output_x,output_y,output_z\n")
    return ["thermal", "triad", str(d / "triad.toml"), str(d / "x.csv")]


@case("noise-constant-channel")
def _(d):
    from inertest.io.data_file import write_table
    rng = np.random.default_rng(5)
    write_table(d / "imu.csv", {"time": np.arange(2000) / 100.0, "gx": np.zeros(2000),
                                "gy": rng.normal(size=2000), "gz": rng.normal(size=2000)})
    return ["noise", str(d / "imu.csv")]


@case("allan-constant")
def _(d):
    np.save(d / "x.npy", np.full(4000, 3.0))
    return _allan(d, "x.npy", "--rate", "100")


# --- issue 30: recordings (ROS bags, MCAP, ULog) ------------------------------------------------
def _bag(d: Path, name: str, kind: str = "ros1", n: int = 400, *, rate_hz: float = 200.0,
         stamps=None, extra: bool = True) -> Path:
    from recording_factory import T0_NS, _store, write_imu_bag

    rng = np.random.default_rng(9)
    ns = (T0_NS + (np.arange(n) * (1e9 / rate_hz)).astype(np.int64) if stamps is None
          else stamps)
    more = ()
    if extra:
        ts = _store(kind)
        t = ts.types
        hdr = (t["std_msgs/msg/Header"](seq=0, stamp=t["builtin_interfaces/msg/Time"](
            sec=1, nanosec=0), frame_id="m") if kind == "ros1" else t["std_msgs/msg/Header"](
            stamp=t["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="m"))
        v = t["geometry_msgs/msg/Vector3Stamped"](
            header=hdr, vector=t["geometry_msgs/msg/Vector3"](x=1.0, y=2.0, z=3.0))
        more = (("/mag", "geometry_msgs/msg/Vector3Stamped", [(int(ns[0]) + 1, v)]),)
    return write_imu_bag(d / name, kind, ns, rng.normal(0, 0.01, (len(ns), 3)),
                         rng.normal(0, 0.05, (len(ns), 3)), extra=more)


@case("noise-bag-truncated")
def _(d):
    bag = _bag(d, "cut.bag")
    data = bag.read_bytes()
    bag.write_bytes(data[: len(data) // 2])
    return ["noise", str(bag)]


@case("noise-mcap-truncated")
def _(d):
    mcap = next(_bag(d, "cut_mcap", "mcap").glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) * 2 // 3])
    return ["noise", str(mcap), "--topic", "/imu"]


@case("noise-bag-empty-file")
def _(d):
    (d / "empty.bag").write_bytes(b"")
    return ["noise", str(d / "empty.bag")]


@case("noise-bag-no-messages")
def _(d):
    return ["noise", str(_bag(d, "none_sqlite", "sqlite3", n=0, stamps=np.empty(0, np.int64),
                              extra=False))]


@case("noise-bag-wrong-topic")
def _(d):
    return ["noise", str(_bag(d, "imu.bag")), "--topic", "/imu0"]


@case("noise-bag-wrong-type")
def _(d):
    return ["noise", str(_bag(d, "imu_mcap", "mcap")), "--topic", "/mag"]


@case("noise-bag-mixed-rate")
def _(d):
    from recording_factory import T0_NS

    first = T0_NS + np.arange(600, dtype=np.int64) * 5_000_000  # 200 Hz for 3 s
    then = first[-1] + np.arange(1, 601, dtype=np.int64) * 10_000_000  # then 100 Hz
    return ["noise", str(_bag(d, "mixed.bag", stamps=np.r_[first, then]))]


@case("noise-bag-two-imu-topics-at-two-rates")
def _(d):
    from recording_factory import T0_NS, _store, imu_message, write_imu_bag

    ts = _store("ros1")
    slow = [(T0_NS + k * 10_000_000, imu_message(ts, T0_NS + k * 10_000_000, [0, 0, 0],
                                                 [0, 0, 9.8], ros1=True)) for k in range(100)]
    ns = T0_NS + np.arange(200, dtype=np.int64) * 5_000_000
    bag = write_imu_bag(d / "two.bag", "ros1", ns, np.zeros((200, 3)), np.ones((200, 3)),
                        extra=(("/imu_slow", "sensor_msgs/msg/Imu", slow),))
    return ["noise", str(bag)]


@case("noise-ulog-wrong-topic")
def _(d):
    real = EXAMPLES.parents[1] / "shared" / "realdata" / "px4" / "sample.ulg"
    if not real.exists():
        pytest.skip("../shared/realdata not present")
    return ["noise", str(real), "--topic", "sensor_accel"]


for _name, _address in (("no-port", "gar bage"), ("broken-ipv6", "tcp://[::1:x"),
                        ("unknown-protocol", "http://h:8786"), ("port-range", "tcp://h:99999")):
    @case(f"batch-scheduler-{_name}")
    def _(d, _address=_address):
        """Was: internal error (ValueError from distributed's address parser)."""
        (d / "m.toml").write_text('[[run]]\nplan = "plan.toml"\ndata = "data.csv"\n')
        return ["batch", str(d / "m.toml"), "--no-store", "--scheduler", _address]


@case("fit-ferraris-time-running-backwards")
def _(d):
    """Was: reported as a wrong sample rate (the only forward steps were segment restarts)."""
    from inertest.io.data_file import read_table, write_table
    t = read_table(d / "ferraris.csv")
    for part in np.unique(t["part"]):
        sel = t["part"] == part
        t["t_s"][sel] = t["t_s"][sel][::-1]
    write_table(d / "x.csv", t)
    return _fit(d, "ferraris.toml", "x.csv")


# --- issue 34: size caps before parsing ---------------------------------------------------------
def _laughs(levels: int = 9) -> str:
    lines = ["gyroscope_noise_density: 1.0e-4", "a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


@case("noise-compare-yaml-alias-bomb")
def _(d):
    """Was: out-of-memory; 700 bytes expanding to 3.9e8 values."""
    (d / "imu.yaml").write_text(_laughs())
    return ["noise", str(EXAMPLES / "noise" / "lasergyro.imu.xz"), "--compare",
            str(d / "imu.yaml")]


@case("noise-compare-yaml-too-large")
def _(d):
    (d / "imu.yaml").write_text("gyroscope_noise_density: 1.0e-4\n" + "#\n" * 600_000)
    return ["noise", str(EXAMPLES / "noise" / "lasergyro.imu.xz"), "--compare",
            str(d / "imu.yaml")]


# --- campaign, lot: an acceptance series and the lot statistics (issue 32) ----------------------
def _campaign(d: Path, *, campaign: str = "", test: str = "", verifies: str = '["tc"]',
              data: str = "thermal/steps.csv", serial: str = "U-1") -> list[str]:
    """A one-test campaign (a bias temperature test) in d/camp; returns ``campaign MANIFEST``."""
    from inertest.io.data_file import write_table

    c = d / "camp"
    (c / "thermal").mkdir(parents=True, exist_ok=True)
    (c / "thermal" / "plan.toml").write_text(
        '[site]\nlatitude_deg = 34.25\n[instrument]\nkind = "rate-gyro"\nserial = "U-1"\n'
        'output_unit = "deg/h"\n[procedure]\nkind = "temperature-sensitivity"\n'
        'noise_model = "white"\n')
    T = np.repeat([-20.0, 0.0, 20.0, 40.0], 10)
    write_table(c / "thermal" / "steps.csv", {"temperature_c": T, "output": 8.5 + 0.004 * T})
    (c / "spec.toml").write_text(
        '[spec]\nname = "s"\n[[limit]]\nid = "tc"\nquantity = "temperature_sensitivity"\n'
        'max_abs = 0.01\nunit = "deg/h/degC"\nclause = "IEEE Std 952-1997"\n')
    (c / "campaign.toml").write_text(
        f'[campaign]\nserial = "{serial}"\nspec = "spec.toml"\n{campaign}\n[[test]]\n'
        f'name = "thermal"\nplan = "thermal/plan.toml"\ndata = "{data}"\n'
        f"verifies = {verifies}\nsigma = 0.01\n{test}\n")
    return ["campaign", str(c / "campaign.toml"), "--no-store"]


@case("campaign-manifest-missing")
def _(d):
    return ["campaign", str(d / "nope.toml")]


@case("campaign-manifest-invalid-toml")
def _(d):
    (d / "c.toml").write_text("[campaign\nserial = 1\n")
    return ["campaign", str(d / "c.toml")]


@case("campaign-unknown-clause")
def _(d):
    return _campaign(d, verifies='["tcc"]')


@case("campaign-unknown-key")
def _(d):
    return _campaign(d, campaign='serail = "U-1"')


@case("campaign-missing-data-file")
def _(d):
    return _campaign(d, data="thermal/nope.csv")


@case("campaign-serial-is-not-the-plans")
def _(d):
    return _campaign(d, serial="U-2")


@case("campaign-no-tests")
def _(d):
    argv = _campaign(d)
    (d / "camp" / "campaign.toml").write_text('[campaign]\nserial = "U-1"\nspec = "spec.toml"\n')
    return argv


@case("campaign-data-with-nan")
def _(d):
    argv = _campaign(d)
    p = d / "camp" / "thermal" / "steps.csv"
    lines = p.read_text().splitlines()
    lines[3] = lines[3].rsplit(",", 1)[0] + ",nan"
    p.write_text("\n".join(lines) + "\n")
    return [*argv[:2], "--db", str(d / "h.db")]


@case("campaign-report-into-its-inputs")
def _(d):
    argv = _campaign(d)
    return [*argv, "--report", str(d / "camp")]


@case("plan-check-campaign-without-truth")
def _(d):
    return ["plan-check", _campaign(d)[1]]


@case("lot-empty-database")
def _(d):
    return ["lot", "--db", str(d / "empty.db")]


@case("lot-unknown-unit-type")
def _(d):
    return ["lot", "--db", str(d / "empty.db"), "--type", "FOG-Q"]


#: Issue 34: what the one line of a case must say (the problem, the fix), so that no case passes
#: on an error other than its own (the old ones were one clean line too, but misleading or about
#: something else).
# --- issue 33: the systematic calibration of a strapdown IMU ----------------------------------
_SYSTEMATIC = """[site]
latitude_deg = 34.0

[instrument]
kind = "imu"
serial = "SYS-1"
output_unit = "rad/s"

[procedure]
kind = "systematic"
sample_rate_hz = 10.0
turns = ["+y", "+x", "+y", "+z"]
noise_model = "white"
first_dwell_s = FIRST
dwell_s = 15.0
turn_s = 5.0
"""


def _systematic(d: Path, first: float = 20.0, **drop) -> None:
    """A small systematic sequence simulated into d/sys.csv (plan d/sys.toml)."""
    (d / "sys.toml").write_text(_SYSTEMATIC.replace("FIRST", f"{first:g}"))
    (d / "sys_truth.toml").write_text("gyro_arw_deg_rt_h = 0.002\nacc_vrw_ug_rt_hz = 20.0\n")
    assert main(["simulate", str(d / "sys.toml"), "--truth", str(d / "sys_truth.toml"),
                 "-o", str(d / "sys.csv"), "--seed", "1"]) == 0
    (d / "sys.toml").write_text(_SYSTEMATIC.replace("FIRST", "20"))


@case("fit-systematic-first-dwell-too-short")
def _(d):
    _systematic(d, first=4.0)
    return _fit(d, "sys.toml", "sys.csv", "--no-store")


@case("fit-systematic-sequence-disagrees-with-the-data")
def _(d):
    _systematic(d)
    (d / "sys2.toml").write_text((d / "sys.toml").read_text().replace(
        '"+y", "+x", "+y", "+z"', '"+y", "-z", "+y", "+z"'))
    return _fit(d, "sys2.toml", "sys.csv", "--no-store")


@case("fit-systematic-gap")
def _(d):
    from inertest.io.data_file import read_table, write_table

    _systematic(d)
    t = read_table(d / "sys.csv")
    keep = np.ones(t["t_s"].size, dtype=bool)
    keep[500:530] = False
    write_table(d / "sys.csv", {k: v[keep] for k, v in t.items()})
    return _fit(d, "sys.toml", "sys.csv", "--no-store")


@case("fit-systematic-saturated-gyro")
def _(d):
    _systematic(d)
    (d / "sys2.toml").write_text((d / "sys.toml").read_text().replace(
        'noise_model = "white"', 'noise_model = "white"\ngyro_range_deg_s = 25.0'))
    return _fit(d, "sys2.toml", "sys.csv", "--no-store")


EXPECT = {
    "campaign-unknown-clause": 'clause \'tcc\', which spec file',
    "campaign-missing-data-file": "thermal/nope.csv does not exist",
    "campaign-serial-is-not-the-plans": "names the unit 'U-1', the campaign's unit is 'U-2'",
    "campaign-data-with-nan": "test 'thermal':",
    "plan-check-campaign-without-truth": "give truth =",
    "lot-unknown-unit-type": "no campaign of unit type 'FOG-Q'",
    "fit-systematic-first-dwell-too-short": "rests 4 s before the first turn",
    "fit-systematic-sequence-disagrees-with-the-data": "fix the plan's turns",
    "fit-systematic-gap": "gap(s) in time",
    "fit-systematic-saturated-gyro": "reaches its range 25 deg/s",
    "noise-bag-truncated": "is truncated or was not closed",
    "noise-mcap-truncated": "it may be truncated or still being written",
    "noise-bag-empty-file": "is empty (0 bytes)",
    "noise-bag-no-messages": "holds no messages (topics found: /imu (sensor_msgs/msg/Imu, 0 "
                             "messages)); the recording is empty",
    "noise-bag-wrong-topic": "no topic '/imu0'; topics found: /imu (sensor_msgs/msg/Imu, 400 "
                             "messages), /mag (geometry_msgs/msg/Vector3Stamped, 1 messages)",
    "noise-bag-wrong-type": "topic /mag of",
    "noise-bag-mixed-rate": "changes its rate: about 200 Hz at the start, about 100 Hz from t =",
    "noise-bag-two-imu-topics-at-two-rates": "has 2 IMU topics at different rates (message "
                                             "counts differ): /imu (sensor_msgs/msg/Imu, 200 "
                                             "messages), /imu_slow",
    "noise-ulog-wrong-topic": "no topic 'sensor_accel'; topics found: actuator_controls_0",
    "fit-report-manifest-behind-symlink": "lists sub/keep.txt, which lies behind the symbolic",
    "fit-report-manifest-outside-folder": "lists '../plan.toml', which is not a path inside",
    "thermal-report-manifest-behind-symlink": "behind the symbolic link",
    "fit-report-manifest-file-is-symlink": "lists index.html, which lies behind the symbolic",
    "apply-thermal-model-nan-coefficient": "terms[1].value is nan, not a finite number; write "
                                           "the model again",
    "apply-thermal-model-overflowing-coefficient": "gives a non-finite bias_deg_h",
    "apply-calibration-infinity": "gyroscope.offset[1] is inf, not a finite number",
    "fit-lab-file-nan": "equipment[0].type_b.rate_ppm is nan, not a finite number",
    "fit-spec-file-inf": "limit[0].max_abs is inf, not a finite number",
    "simulate-truth-nan": "coefficients.DF is nan, not a finite number",
    "batch-manifest-sigma-nan": "run[0].sigma is nan, not a finite number",
    "fit-data-hdf5-complex-column": "column 'output' holds complex numbers",
    "fit-data-parquet-list-column": "column 'output' holds list<",
    "allan-npy-complex": "holds complex numbers",
    "history-k-nan": "'nan' is not a finite number",
    "history-k-inf": "'inf' is not a finite number",
    "fit-sigma-inf": "'inf' is not a finite number",
    "fit-sigma-1e300": "too large to compute with",
    "modulation-stator-hz-nan": "expected finite numbers",
    "batch-timeout-nan": "'nan' is not a finite number",
    "plan-check-sigma-1e300": "sigma = 1e+300 is too large to compute with",
    "thermal-triad-header-only": "has no rows",
    "noise-constant-channel": "channel gx of imu.csv is constant",
    "allan-constant": "x.npy is constant",
    "batch-scheduler-no-port": "give it as tcp://HOST:PORT",
    "batch-scheduler-broken-ipv6": "give it as tcp://HOST:PORT",
    "batch-scheduler-unknown-protocol": "unknown protocol 'http'",
    "batch-scheduler-port-range": "a port from 1 to 65535",
    "fit-ferraris-time-running-backwards": "time column 't_s' runs backwards",
    "noise-compare-yaml-alias-bomb": "larger than 100000 values once its aliases",
    "noise-compare-yaml-too-large": "larger than 1024 KiB",
    "simulate-truth-empty": "gives no coefficient",
    "fit-data-header-not-utf8": "is not UTF-8 text",
    "allan-data-header-not-utf8": "is not UTF-8 text",
    "thermal-fit-data-header-not-utf8": "is not UTF-8 text",
    "fit-spec-not-utf8": "is not UTF-8 text",
    "apply-data-text-column": "is not numeric",
}


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
    assert set(EXPECT) <= set(CASES)


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
    assert EXPECT.get(name, "") in lines[0], f"{name}: {lines[0]}"
    assert "\x1b" not in err and "\0" not in err
    assert "hunter2" not in err
    assert _digest(work) == before, f"{name} changed files in its folder"
    assert not (tmp_path / "cache" / "inertest").exists()  # no crash log


# --- what is not about the input ----------------------------------------------------------------
@pytest.mark.parametrize("command", ["simulate", "fit-report", "allan-report", "apply", "batch"])
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
        "batch": ["batch", str(work / "m.toml"), "--db", str(db)],
    }[command]
    # issue 34: batch printed a bare "[Errno 28]"; the same line as fit now
    (work / "m.toml").write_text('[[run]]\nplan = "plan.toml"\ndata = "data.csv"\n'
                                 'report = "rep"\n')
    before = _digest(work)
    real_replace = os.replace

    def full(src, dst, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(dst))

    monkeypatch.setattr(os, "replace", full)
    status = main(argv)
    monkeypatch.setattr(os, "replace", real_replace)
    err = capsys.readouterr().err
    assert status != 0 and "disk full at" in err and "Traceback" not in err
    assert "Errno" not in err and "inertest-tmp" not in err
    assert len([ln for ln in err.splitlines() if ln.strip()]) == 1
    assert _digest(work) == before


@pytest.mark.parametrize("command", ["allan-plot", "fit-report", "apply"])
def test_an_unwritable_output_names_the_users_path(command, assets, tmp_path, monkeypatch,
                                                   capsys):
    """Issue 34: the message named the hidden temporary (``.x.png.inertest-tmp-...``)."""
    import tempfile

    work = tmp_path / "work"
    shutil.copytree(assets, work)
    argv, shown = {
        "allan-plot": (_allan(work, "two.npy", "--column", "0", "--rate", "1", "--plot",
                              str(work / "x.png"), "--no-noise-id"), "x.png"),
        "fit-report": (_fit(work, "plan.toml", "data.csv", "--no-store", "--report",
                            str(work / "rep")), "rep"),
        "apply": (["apply", str(work / "cal.json"), str(work / "ferraris.csv"), "-o",
                   str(work / "o.csv")], "o.csv"),
    }[command]
    before = _digest(work)
    real = {"mkstemp": tempfile.mkstemp, "mkdtemp": tempfile.mkdtemp}

    def refuse(name):
        def create(*a, **k):
            if ".inertest-tmp-" not in k.get("prefix", ""):
                return real[name](*a, **k)
            raise PermissionError(13, "Permission denied",
                                  os.path.join(k["dir"], k["prefix"] + "x1y2z3"))
        return create

    monkeypatch.setattr(tempfile, "mkstemp", refuse("mkstemp"))
    monkeypatch.setattr(tempfile, "mkdtemp", refuse("mkdtemp"))
    status = main(argv)
    monkeypatch.undo()
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert status == 2 and len(lines) == 1, err
    assert lines[0] == (f"error: cannot write in or read {work / shown}: permission denied; "
                        "choose another output folder or fix its permissions")
    assert _digest(work) == before


def test_a_history_database_on_read_only_storage_is_read_not_written(assets, tmp_path,
                                                                     monkeypatch, capsys):
    """Issue 34: history could not read it (SQLite's WAL needs a -shm file beside it)."""
    from inertest.store import history as store_history

    work = tmp_path / "work"
    shutil.copytree(assets, work)
    db = work / "archive" / "h.db"
    db.parent.mkdir()
    assert main(_fit(work, "plan.toml", "data.csv", "--db", str(db))) == 0
    capsys.readouterr()
    before = _digest(work)
    db.chmod(0o444)
    db.parent.chmod(0o555)
    monkeypatch.setattr(store_history, "_writable", lambda path: False)  # also for root
    try:
        assert main(["history", "FG-0417", "--db", str(db), "--json"]) == 0
        assert len(json.loads(capsys.readouterr().out)["result"]["runs"]) == 1
        assert main(_fit(work, "plan.toml", "data.csv", "--db", str(db),
                         "--allow-duplicate")) == 2
        err = capsys.readouterr().err.strip()
        assert err.endswith("is on read-only storage; store the run elsewhere with --db, or "
                            "use --no-store") and err.count("\n") == 0
    finally:
        db.parent.chmod(0o755)
        db.chmod(0o644)
    assert _digest(work) == before  # no -shm, no -wal, no row


def test_a_compression_bomb_is_refused_before_it_is_parsed(tmp_path, monkeypatch, capsys):
    """Issue 34: a small .xz of gigabytes of text ended at out-of-memory after 100 s; here the
    cap is lowered to 1 MiB so that the test stays small."""
    import lzma

    from inertest.io import imu_recording

    monkeypatch.setattr(imu_recording, "MAX_DECOMPRESSED_BYTES", 1 << 20)
    bomb = tmp_path / "bomb.imu.xz"
    bomb.write_bytes(lzma.compress(b"% psins\n0 0 0 0 0 0\n34 108 380 0 10 9.8\n"
                                   b"0.1 0.1 0.1 125 125 125\n" + b"1 2 3 4 5 6\n" * 200_000))
    before = _digest(tmp_path)
    assert main(["noise", str(bomb)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {bomb} is larger than 1 MiB when decompressed")
    assert err.count("\n") == 1 and _digest(tmp_path) == before


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


HOSTILE_LABEL = r"cost $\frac{1}{0$ run"


@pytest.mark.parametrize("command", ["study-label", "scenario-name", "data-file-name"])
def test_dollar_signs_in_labels_are_drawn_not_parsed(command, assets, tmp_path):
    """Issue 34: a ``$...$`` in a study label or scenario name was an internal error (matplotlib
    mathtext); the fix of the round before turned math off where the crash was seen, and missed
    these. Every figure text is escaped by one helper now: the commands succeed."""
    import re

    work = tmp_path / "work"
    shutil.copytree(assets, work)
    if command == "study-label":  # the example study, cut to one machine error and short
        text = (work / "study.toml").read_text()
        text = text[:[m.start() for m in re.finditer(r"^\[errors\.", text, flags=re.M)][1]]
        text = text.replace("revolutions = 100", "revolutions = 4").replace("runs = 200",
                                                                            "runs = 20")
        line = f"label = '{HOSTILE_LABEL}'"  # a TOML literal string: no escapes
        (work / "s.toml").write_text(re.sub(r'^label = ".*"$', lambda m: line, text, count=1,
                                            flags=re.M))
        argv = ["centrifuge-study", str(work / "s.toml"), "--report", str(work / "s.html")]
    elif command == "scenario-name":
        text = (work / "scenario.toml").read_text()
        line = f"name = '{HOSTILE_LABEL}'"  # a TOML literal string: no escapes
        (work / "s.toml").write_text(re.sub(r'^name = ".*"$', lambda m: line, text, count=1,
                                            flags=re.M))
        argv = ["ins-errors", "--scenario", str(work / "s.toml"), "--plot", str(work / "e.png")]
    else:
        shutil.copy(work / "data.csv", work / f"{HOSTILE_LABEL}.csv")
        argv = _fit(work, "plan.toml", f"{HOSTILE_LABEL}.csv", "--no-store", "--report",
                    str(work / "rep"))
    # A fresh process, as a user runs it: in this one matplotlib's settings are what earlier
    # tests left.
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "error",
           "XDG_CACHE_HOME": str(tmp_path / "cache")}
    done = run_inertest(argv, cwd=work, env=env)
    assert done.returncode == 0 and "internal error" not in done.stderr, done.stderr
    if command != "data-file-name":  # the label really is in the file given
        assert f"'{HOSTILE_LABEL}'" in (work / "s.toml").read_text()


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
        proc = subprocess.Popen([*INERTEST, "fit", "plan.toml", "data.csv", *argv_tail],
                                cwd=work, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(0.5, 4.0))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        runs, report = _state(work)
        assert runs <= 1
        outcomes.append((runs, report))
        # the next run cleans the killed one's hidden temporaries and completes
        done = run_inertest(["fit", "plan.toml", "data.csv", *argv_tail, "--allow-duplicate"],
                            cwd=work, env=env)
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
        from postgres_reset import reset_postgres
        reset_postgres(url)

    with processes(_writer, [(url, k * 100, 1) for k in range(16)], wait_s=180) as procs:
        pass
    assert [p.exitcode for p in procs] == [0] * 16
    store = HistoryStore(url)
    runs = store.runs("FG-1")
    store.close()
    assert len(runs) == 16 and len({r.run_uuid for r in runs}) == 16
    assert json.dumps(runs[0].result)
