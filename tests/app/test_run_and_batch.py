"""The library runner: fit, report and store as one transaction; batches on any executor."""

from __future__ import annotations

import json
import shutil
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

import batch_hooks
import inertest
import inertest.app.batch as batch
import inertest.app.run as runner
from inertest.app.batch import run_batch
from inertest.app.executors import WORKER_DIED
from inertest.app.run import DuplicateRunError
from inertest.errors import InertestError, OutputPathError
from inertest.io.atomic import REPORT_MARKER
from inertest.store import HistoryStore


@pytest.fixture
def tumble(examples_dir, tmp_path) -> tuple[Path, Path]:
    plan = tmp_path / "plan.toml"
    shutil.copy(examples_dir / "polar_tumble" / "plan.toml", plan)
    data = inertest.simulate(plan, examples_dir / "polar_tumble" / "truth.toml", noise=0.002,
                             rng=1)
    path = tmp_path / "data.csv"
    from inertest.io.data_file import write_table

    write_table(path, data)
    return plan, path


def _runs(db: Path) -> int:
    if not db.exists():
        return 0
    store = HistoryStore(str(db))
    try:
        return sum(len(store.runs(s)) for s in store.serials())
    finally:
        store.close()


def test_run_fits_reports_and_stores_once(tumble, tmp_path):
    plan, data = tumble
    db = tmp_path / "h.db"
    out = inertest.run(plan, data, store=str(db), report_dir=tmp_path / "rep")
    assert out.result.kind == "polar-tumble" and out.stored_run is not None
    assert out.report == tmp_path / "rep" / "index.html" and out.report.is_file()
    assert (tmp_path / "rep" / REPORT_MARKER).is_file()
    assert _runs(db) == 1
    # The same data file again is refused and changes nothing; allowed when asked.
    with pytest.raises(DuplicateRunError, match="already filed"):
        inertest.run(plan, data, store=str(db))
    assert _runs(db) == 1
    inertest.run(plan, data, store=str(db), allow_duplicate=True, report_dir=tmp_path / "rep")
    assert _runs(db) == 2


def test_report_never_replaces_a_folder_inertest_did_not_write(tumble, tmp_path):
    plan, data = tumble
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "notes.txt").write_text("precious")
    db = tmp_path / "h.db"
    with pytest.raises(OutputPathError, match="did not write"):
        inertest.run(plan, data, store=str(db), report_dir=lab)
    assert (lab / "notes.txt").read_text() == "precious" and sorted(p.name for p in
                                                                   lab.iterdir()) == ["notes.txt"]
    assert _runs(db) == 0
    # A folder holding an input is refused too, even through a symlink.
    with pytest.raises(OutputPathError, match="would overwrite the input"):
        inertest.run(plan, data, report_dir=data.parent)
    link = tmp_path / "link"
    link.symlink_to(data)
    with pytest.raises(OutputPathError):
        inertest.run(plan, data, report_dir=link)
    for bad in (".", ""):
        with pytest.raises(OutputPathError):
            inertest.run(plan, data, report_dir=bad)


def test_failed_store_leaves_no_report_and_failed_report_no_run(tumble, tmp_path, monkeypatch):
    plan, data = tumble
    db = tmp_path / "h.db"

    def broken_add(self, record, **_):
        raise InertestError("disk full (simulated)")

    monkeypatch.setattr(HistoryStore, "add", broken_add)
    with pytest.raises(InertestError, match="disk full"):
        inertest.run(plan, data, store=str(db), report_dir=tmp_path / "rep")
    assert not (tmp_path / "rep").exists()
    assert not any(p.name.startswith(".rep") for p in tmp_path.iterdir())
    monkeypatch.undo()


    def broken_report(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(runner, "_report_html", broken_report)
    with pytest.raises(OSError):
        inertest.run(plan, data, store=str(db), report_dir=tmp_path / "rep")
    assert _runs(db) == 0 and not (tmp_path / "rep").exists()


def test_run_without_a_serial_stores_nothing(tumble, tmp_path):
    plan, data = tumble
    text = plan.read_text()
    plan.write_text("\n".join(line for line in text.splitlines()
                              if not line.strip().startswith("serial")))
    with pytest.raises(InertestError, match="serial"):
        inertest.run(plan, data, store=str(tmp_path / "h.db"), report_dir=tmp_path / "rep")
    assert not (tmp_path / "rep").exists()


@pytest.mark.slow
def test_batch_on_processes_equals_serial(examples_dir, tmp_path):
    pairs = []
    for k in range(3):
        plan = examples_dir / "polar_tumble" / "plan.toml"
        data = tmp_path / f"d{k}.csv"
        from inertest.io.data_file import write_table

        write_table(data, inertest.simulate(plan, examples_dir / "polar_tumble" / "truth.toml",
                                            noise=0.002, rng=k))
        pairs.append((plan, data))
    manifest = tmp_path / "batch.toml"
    manifest.write_text("".join(f'[[run]]\nplan = "{p}"\ndata = "{d}"\n\n' for p, d in pairs)
                        + '[[run]]\nplan = "missing.toml"\ndata = "d0.csv"\n')
    serial = run_batch(manifest, store=str(tmp_path / "a.db"))
    with ProcessPoolExecutor(max_workers=2) as pool:
        parallel = run_batch(manifest, executor=pool, store=str(tmp_path / "b.db"))
    assert [i.error is None for i in serial] == [True, True, True, False]
    assert "missing.toml" in serial[3].error
    for a, b in zip(serial[:3], parallel[:3], strict=True):
        da, db_ = a.outcome.result.to_dict(), b.outcome.result.to_dict()
        assert json.dumps(da["identification"]) == json.dumps(db_["identification"])
    assert _runs(tmp_path / "a.db") == 3 and _runs(tmp_path / "b.db") == 3


def test_import_inertest_loads_no_heavy_dependency():
    """Start-up stays fast: plotting, databases, scikit-learn and numba load on demand."""
    import subprocess
    import sys

    code = ("import sys, inertest, inertest.cli; import inertest.cli.procedure; "
            "heavy = [m for m in ('matplotlib', 'sqlalchemy', 'sklearn', 'numba', 'pyarrow', "
            "'h5py', 'sympy') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ""


def test_noise_model_argument_overrides_the_plan(tumble, examples_dir, capsys):
    """README: ``fit(plan, data, noise_model=...)`` (issue 15 review: it raised TypeError)."""
    from inertest.cli import main
    from inertest.errors import PlanError

    plan, data = tumble
    assert inertest.fit(plan, data).identification.noise_model != "flicker"
    assert inertest.fit(plan, data, noise_model="flicker").identification.noise_model == "flicker"
    out = inertest.run(plan, data, noise_model="white")
    assert out.to_dict()["identification"]["noise"]["model"] == "white"
    with pytest.raises(PlanError, match="noise_model must be one of"):
        inertest.fit(plan, data, noise_model="pink")
    assert main(["fit", str(plan), str(data), "--no-store", "--json",
                 "--noise-model", "position-offsets"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["identification"]["noise"]["model"] == "position-offsets"
    servo = inertest.load_plan(examples_dir / "servo_table" / "plan.toml")
    with pytest.raises(PlanError, match="no choice of noise model"):
        inertest.fit(servo, {}, noise_model="white")


# --- a run that takes its worker down (issue 18 review) ---------------------------------------


def _hooked_pool(workers: int) -> ProcessPoolExecutor:
    """A fork-server pool whose workers kill themselves on serial DIE, hang on HANG."""
    import multiprocessing

    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("forkserver"),
                               initializer=batch_hooks.deadly_fit)


def _manifest(tmp_path: Path, plan: Path, data: Path, serials: list[str]) -> Path:
    """One run per serial, each with its own plan (the serial is the test hook's trigger)."""
    text = plan.read_text(encoding="utf-8")
    assert 'serial = "' in text
    lines = []
    for k, serial in enumerate(serials):
        p = tmp_path / f"plan{k}.toml"
        p.write_text("\n".join(f'serial = "{serial}"' if ln.strip().startswith("serial")
                               else ln for ln in text.splitlines()) + "\n", encoding="utf-8")
        lines.append(f'[[run]]\nplan = "{p}"\ndata = "{data}"\nreport = "{tmp_path / f"r{k}"}"\n')
    path = tmp_path / "batch.toml"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


@pytest.mark.slow
def test_a_run_that_kills_its_worker_fails_alone_and_the_others_are_filed(tumble, tmp_path):
    plan, data = tumble
    manifest = _manifest(tmp_path, plan, data, ["A1", "DIE", "A3", "A4", "A5"])
    db = tmp_path / "h.db"
    pool = _hooked_pool(2)
    try:
        items = run_batch(manifest, executor=pool, store=str(db), allow_duplicate=True)
    finally:
        pool.shutdown(wait=True)
    assert [i.error for i in items] == [None, WORKER_DIED, None, None, None]
    assert _runs(db) == 4
    assert not (tmp_path / "r1").exists()  # nothing of the dead run written
    assert all((tmp_path / f"r{k}" / "index.html").is_file() for k in (0, 2, 3, 4))


@pytest.mark.slow
def test_batch_cli_survives_a_killed_worker_with_one_error_line(tumble, tmp_path, capsys,
                                                                monkeypatch):
    from inertest.cli import main

    plan, data = tumble
    monkeypatch.setattr(batch, "local_pool", _hooked_pool)
    manifest = _manifest(tmp_path, plan, data, ["DIE", "B2", "B3"])
    db = tmp_path / "h.db"
    status = main(["batch", str(manifest), "--workers", "2", "--db", str(db),
                   "--allow-duplicate", "--no-progress"])
    err = capsys.readouterr().err
    assert status == 1
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("warning")]
    assert len(lines) == 1 and lines[0].startswith("error: 1 of 3 runs failed")
    assert "worker process died" in lines[0] and "Traceback" not in err
    assert _runs(db) == 2


@pytest.mark.slow
def test_a_run_over_the_timeout_is_stopped_and_fails_alone(tumble, tmp_path):
    plan, data = tumble
    manifest = _manifest(tmp_path, plan, data, ["C1", "C2", "HANG"])
    db = tmp_path / "h.db"
    pool = _hooked_pool(1)
    pool.submit(int).result()  # started: the timeout counts fits, not the pool's start-up
    try:
        items = run_batch(manifest, executor=pool, store=str(db), allow_duplicate=True,
                          timeout=5.0)
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    assert [i.error is None for i in items] == [True, True, False]
    assert "longer than the 5 s timeout" in items[2].error
    assert _runs(db) == 2


def test_a_dask_worker_lost_under_a_run_fails_that_run_only(tumble, tmp_path):
    from concurrent.futures import Future

    distributed = pytest.importorskip("distributed")
    plan, data = tumble
    manifest = _manifest(tmp_path, plan, data, ["D1", "DIE", "D3"])

    class LosesSerialDie:
        """Computes here; the DIE run's future fails as a lost Dask worker's would."""

        def submit(self, fn, *args):  # run_unit(compute, [task]): one fit a unit here
            fut = Future()
            if 'serial = "DIE"' in args[-1][0].plan.read_text(encoding="utf-8"):
                fut.set_exception(distributed.KilledWorker("fit-1", None, 3))
            else:
                fut.set_result(fn(*args))
            return fut

    items = run_batch(manifest, executor=LosesSerialDie(), store=str(tmp_path / "h.db"),
                      allow_duplicate=True)
    assert [i.error is None for i in items] == [True, False, True]
    assert items[1].error.startswith(WORKER_DIED)
    assert _runs(tmp_path / "h.db") == 2


def test_timeout_must_be_positive(tumble):
    with pytest.raises(InertestError, match="timeout"):
        run_batch([tumble], timeout=0)


def test_shipped_files_give_the_same_results_and_name_the_users_files(tumble, tmp_path):
    """ship_data: the files travel with the runs; results, data summary and errors name the
    user's paths, never the worker's temporary copies."""
    plan, data = tumble
    bad = tmp_path / "bad.toml"
    bad.write_text("[site\n", encoding="utf-8")
    tasks = [(plan, data), (bad, data)]
    plain = run_batch(tasks, full_results=True)
    shipped = run_batch(tasks, ship_data=True, full_results=True)
    assert shipped[0].outcome.result.to_dict() == plain[0].outcome.result.to_dict()
    assert shipped[0].outcome.data_sha256 == plain[0].outcome.data_sha256
    assert str(bad) in shipped[1].error and "inertest-shipped" not in shipped[1].error
    assert shipped[1].error == plain[1].error
    folder = tmp_path / "rosbag2"
    folder.mkdir()
    with pytest.raises(InertestError, match="is a folder"):
        run_batch([(plan, folder)], ship_data=True)
