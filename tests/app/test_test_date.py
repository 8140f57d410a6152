"""One test date per run (issue 29): the record, report, equipment status and history use it.

The test date is the plan's ``[test] date`` (with its time when given), or ``--tested-at``,
which overrides it and says so; "filed at" is when the run was stored, and exists only when it
was. References: the dates written in the plans and options themselves, and the lab file's
calibration due dates.
"""

from __future__ import annotations

import html
import json
import re
import shutil
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

import inertest
from inertest.cli import main
from inertest.io.data_file import write_table
from inertest.store import HistoryStore


def _plan(examples_dir: Path, folder: Path, test_table: str) -> Path:
    """The polar-tumble example with its [test] table replaced by ``test_table``."""
    text = (examples_dir / "polar_tumble" / "plan.toml").read_text()
    head = text[:text.index("[test]")]
    rest = text[text.index("[procedure]"):]
    plan = folder / "plan.toml"
    plan.write_text(f"{head}{test_table}\n\n{rest}")
    return plan


def _data(examples_dir: Path, plan: Path, path: Path, seed: int) -> Path:
    data = inertest.simulate(plan, examples_dir / "polar_tumble" / "truth.toml", noise=0.002,
                             rng=seed)
    write_table(path, data)
    return path


def _lab(folder: Path, due: str) -> Path:
    lab = folder / "lab.toml"
    lab.write_text(f'''[[equipment]]
id = "RT-02"
name = "Two-axis rate table"
calibrated = 2025-01-01
calibration_due = {due}
[signatories]
reviewed_by = "B. Reviewer"
approved_by = "C. Quality-Manager"
''')
    return lab


def test_plan_date_dates_record_report_equipment_and_history(examples_dir, tmp_path):
    """Filed today, tested on the plan's date: the stored run carries both; the equipment is
    judged on the test date (due 2026-06-01: valid on 2026-03-02, although overdue today)."""
    plan = _plan(examples_dir, tmp_path, '[test]\noperator = "A. Engineer"\n'
                 'date = 2026-03-02T09:30:00+02:00\nequipment = ["RT-02"]')
    data = _data(examples_dir, plan, tmp_path / "d.csv", 1)
    before = datetime.now(UTC)
    out = inertest.run(plan, data, store=str(tmp_path / "h.db"), report_dir=tmp_path / "r",
                       equipment=_lab(tmp_path, "2026-06-01"))
    test = out.to_dict()["test"]
    assert out.tested_at == datetime(2026, 3, 2, 7, 30, tzinfo=UTC)  # +02:00 in UTC
    assert test["date"] == "2026-03-02" and test["tested_at"] == "2026-03-02T07:30:00+00:00"
    assert test["date_source"] == "plan"
    filed = datetime.fromisoformat(test["filed_at"])
    assert before - timedelta(seconds=1) <= filed <= datetime.now(UTC)
    assert out.filed_at is not None and abs(out.filed_at - filed) < timedelta(seconds=1)
    assert test["equipment"][0]["calibration_overdue"] is False
    assert not any("overdue" in w.lower() or "was due" in w for w in out.warnings)
    store = HistoryStore(str(tmp_path / "h.db"))
    try:
        (run,) = store.runs("FG-0417")
    finally:
        store.close()
    assert run.tested_at == out.tested_at
    assert run.filed_at is not None and abs(run.filed_at - filed) < timedelta(seconds=1)
    assert run.result["test"]["filed_at"] == test["filed_at"]
    text = html.unescape(re.sub(r"<[^>]+>", "", (tmp_path / "r" / "index.html").read_text()))
    assert "Tested 2026-03-02 07:30 UTC" in text
    assert "2026-03-02 07:30 UTC (from the plan's [test] date)" in text
    assert "filed at (UTC)" in text
    cert = json.loads((tmp_path / "r" / "certificate.json").read_text())
    assert cert["test"]["date"] == "2026-03-02" and cert["test"]["filed_at"] == test["filed_at"]
    assert cert["approval"] == {"performed_by": "A. Engineer", "performed_on": "2026-03-02",
                                "reviewed_by": "B. Reviewer", "reviewed_on": None,
                                "approved_by": "C. Quality-Manager", "approved_on": None}
    assert cert["report"]["id"] == out.stored_run


def test_tested_at_overrides_the_plan_date_and_says_so(examples_dir, tmp_path):
    """--tested-at after the due date: the equipment is overdue on it, not on the plan's date."""
    plan = _plan(examples_dir, tmp_path, '[test]\ndate = 2026-03-02\nequipment = ["RT-02"]')
    data = _data(examples_dir, plan, tmp_path / "d.csv", 2)
    out = inertest.run(plan, data, tested_at=datetime(2026, 7, 1, 12, 0),
                       equipment=_lab(tmp_path, "2026-06-01"))
    test = out.to_dict()["test"]
    assert test["date"] == "2026-07-01" and test["date_source"] == "--tested-at"
    assert out.tested_at == datetime(2026, 7, 1, 12, 0, tzinfo=UTC)
    assert any("--tested-at 2026-07-01 12:00 UTC overrides the plan's [test] date 2026-03-02"
               in w for w in out.warnings)
    assert test["equipment"][0]["calibration_overdue"] is True
    assert any("was due 2026-06-01, before the test date 2026-07-01" in w for w in out.warnings)


def test_not_stored_has_no_filing_time(examples_dir, tmp_path, capsys):
    plan = _plan(examples_dir, tmp_path, '[test]\noperator = "A. Engineer"\ndate = 2026-03-02')
    data = _data(examples_dir, plan, tmp_path / "d.csv", 3)
    assert main(["fit", str(plan), str(data), "--no-store", "--json"]) == 0
    test = json.loads(capsys.readouterr().out)["test"]
    assert "filed_at" not in test and test["date"] == "2026-03-02"
    assert test["tested_at"] is None  # a date without a time of day
    assert main(["fit", str(plan), str(data), "--no-store"]) == 0
    out = capsys.readouterr().out
    assert "filed at" not in out
    assert re.search(r"test date\s+│\s+2026-03-02 \(from the plan's \[test\] date\)", out)


def test_refiling_old_data_puts_it_at_its_test_date(examples_dir, tmp_path, capsys):
    """Filed in the order March, January, February: the history runs by test date."""
    db = tmp_path / "h.db"
    for k, date in enumerate(("2026-03-01", "2026-01-01", "2026-02-01")):
        folder = tmp_path / f"p{k}"
        folder.mkdir()
        plan = _plan(examples_dir, folder, f"[test]\ndate = {date}")
        data = _data(examples_dir, plan, folder / "d.csv", 10 + k)
        assert main(["fit", str(plan), str(data), "--db", str(db)]) == 0
    capsys.readouterr()
    assert main(["history", "FG-0417", "--db", str(db), "--json"]) == 0
    runs = json.loads(capsys.readouterr().out)["result"]["runs"]
    assert [r["tested_at"][:10] for r in runs] == ["2026-01-01", "2026-02-01", "2026-03-01"]
    # filed in the other order: March first
    filed = [datetime.fromisoformat(r["filed_at"]) for r in runs]
    assert filed[2] <= filed[0] and filed[2] <= filed[1]
    assert main(["history", "FG-0417", "--db", str(db)]) == 0
    assert "2026-01-01 to 2026-03-01, test dates" in capsys.readouterr().out


def test_without_any_date_the_analysis_time_is_the_test_date(examples_dir, tmp_path):
    plan = _plan(examples_dir, tmp_path, '[test]\noperator = "A. Engineer"')
    data = _data(examples_dir, plan, tmp_path / "d.csv", 4)
    before = datetime.now(UTC)
    out = inertest.run(plan, data)
    test = out.to_dict()["test"]
    assert test["date_source"] == "analysis"
    assert before - timedelta(seconds=1) <= out.tested_at <= datetime.now(UTC)


@pytest.mark.parametrize("bad", ['date = "soon"', "date = 12", "review_date = 09:30:00"])
def test_a_test_date_that_is_no_date_is_refused(examples_dir, tmp_path, bad):
    from inertest.errors import PlanError

    plan = _plan(examples_dir, tmp_path, f"[test]\n{bad}")
    with pytest.raises(PlanError, match="must be a date such as"):
        inertest.load_plan(plan)


def test_batch_runs_are_dated_by_their_plans(examples_dir, tmp_path):
    from inertest.app.batch import run_batch

    pairs = []
    for k, date in enumerate(("2026-02-01", "2026-01-01")):
        folder = tmp_path / f"b{k}"
        folder.mkdir()
        plan = _plan(examples_dir, folder, f"[test]\ndate = {date}")
        pairs.append((plan, _data(examples_dir, plan, folder / "d.csv", 20 + k)))
    items = run_batch(pairs, store=str(tmp_path / "h.db"))
    assert [i.outcome.tested_at.date().isoformat() for i in items] == ["2026-02-01",
                                                                       "2026-01-01"]
    shutil.rmtree(tmp_path / "b0")
