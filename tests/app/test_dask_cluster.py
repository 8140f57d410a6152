"""A batch on a real Dask cluster: ``dask scheduler`` and ``dask worker`` processes (issue 34).

Not a LocalCluster that the test waits for: the scheduler and the workers are separate
processes started here on 127.0.0.1, as on a lab's cluster, and the batch goes through
``inertest batch --scheduler ADDRESS`` and ``run_batch(executor=Client(...))``. The batch is run
several times (a result that finished just after the driver's wait timed out came back as None
and crashed the filing in 7 tries of 9), and once with a worker killed in the middle of it:
nothing is lost, every run is filed exactly once.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

import inertest
from inertest.app.batch import run_batch
from inertest.app.executors import Fits, RunStoppedError
from inertest.cli import main
from inertest.io.data_file import write_table

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DASK = Path(sys.executable).with_name("dask")
N_RUNS = 24


def _start(args: list[str], log: Path, cwd: Path | None = None) -> subprocess.Popen:
    with log.open("wb") as out:  # the child keeps its own copy of the file descriptor
        return subprocess.Popen([str(DASK), *args], stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True, cwd=cwd)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    folder = tmp_path_factory.mktemp("dask")
    sfile = folder / "scheduler.json"
    proc = _start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                   "--dashboard-address", "127.0.0.1:0", "--scheduler-file", str(sfile)],
                  folder / "scheduler.log")
    for _ in range(600):
        if sfile.exists() and sfile.stat().st_size:
            break
        time.sleep(0.1)
    else:
        _stop(proc)
        pytest.fail("dask scheduler did not start: " + (folder / "scheduler.log").read_text())
    address = json.loads(sfile.read_text())["address"]
    try:
        yield address, folder
    finally:
        _stop(proc)


def _worker(address: str, folder: Path, name: str) -> subprocess.Popen:
    # Each worker runs in a folder of its own: a relative path of the driver's means nothing
    # there (as on another machine), which the shipped-data test relies on.
    home = folder / f"{name}-cwd"
    home.mkdir(exist_ok=True)
    return _start(["worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                   "--dashboard-address", "127.0.0.1:0", "--name", name],
                  folder / f"{name}.log", cwd=home)


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    plan = EXAMPLES / "polar_tumble" / "plan.toml"
    truth = EXAMPLES / "polar_tumble" / "truth.toml"
    lines = []
    for k in range(N_RUNS):  # 24 runs on 2 workers: units of 3 fits (one future each)
        data = folder / f"d{k}.csv"
        write_table(data, inertest.simulate(plan, truth, noise=0.002, rng=200 + k))
        lines.append(f'[[run]]\nplan = "{plan}"\ndata = "{data}"\n')
    path = folder / "batch.toml"
    path.write_text("\n".join(lines))
    return path


def _filed(db: Path) -> list[str]:
    with sqlite3.connect(db) as con:
        return sorted(r[0] for r in con.execute("SELECT data_sha256 FROM runs"))


@pytest.mark.slow
def test_batch_on_scheduler_and_worker_processes_files_every_run_once(scheduler, manifest,
                                                                      tmp_path, capsys):
    address, folder = scheduler
    workers = [_worker(address, folder, f"w{i}") for i in range(2)]
    try:
        for attempt in range(3):
            db = tmp_path / f"h{attempt}.db"
            assert main(["batch", str(manifest), "--scheduler", address, "--db", str(db),
                         "--no-progress", "--json"]) == 0, capsys.readouterr().err
            doc = json.loads(capsys.readouterr().out)
            assert [r["error"] for r in doc["runs"]] == [None] * N_RUNS
            shas = _filed(db)
            assert len(shas) == N_RUNS and len(set(shas)) == N_RUNS
    finally:
        for w in workers:
            _stop(w)


@pytest.mark.slow
def test_a_worker_killed_mid_batch_loses_nothing(scheduler, manifest, tmp_path):
    from distributed import Client

    address, folder = scheduler
    workers = [_worker(address, folder, f"k{i}") for i in range(2)]
    killed = []

    def progress(item):
        if not killed and item.outcome is not None:
            killed.append(workers[0].pid)
            _stop(workers[0])  # the worker process (and its nanny) dies under the batch

    try:
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=60)
            items = run_batch(manifest, executor=client, store=str(tmp_path / "h.db"),
                              progress=progress, max_pending=N_RUNS)
        assert killed
        failed = [i.error for i in items if i.error is not None]
        assert not failed, failed  # the lost runs ran again on the other worker
        shas = _filed(tmp_path / "h.db")
        assert len(shas) == N_RUNS and len(set(shas)) == N_RUNS
    finally:
        for w in workers:
            _stop(w)


@pytest.mark.slow
def test_workers_that_do_not_share_the_paths_get_the_files_shipped(scheduler, manifest,
                                                                   tmp_path, monkeypatch,
                                                                   capsys):
    """Relative paths from the driver's folder: the workers (in folders of their own, as on
    other machines) cannot open them; with --ship-data the files go with the runs, and the
    results name the user's paths."""
    address, folder = scheduler
    monkeypatch.chdir(manifest.parent)
    local = Path("local.toml")
    local.write_text(manifest.read_text().replace(str(manifest.parent) + "/", ""))
    assert str(manifest.parent) not in local.read_text()
    workers = [_worker(address, folder, f"s{i}") for i in range(2)]
    try:
        code = main(["batch", str(local), "--scheduler", address, "--no-store",
                     "--no-progress", "--json"])
        doc = json.loads(capsys.readouterr().out)
        assert code == 1 and all("does not exist" in (r["error"] or "") for r in doc["runs"])
        assert all(r["result"] is None for r in doc["runs"])  # nothing computed there
        db = tmp_path / "h.db"
        assert main(["batch", str(local), "--scheduler", address, "--db", str(db),
                     "--ship-data", "--no-progress", "--json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert [r["error"] for r in doc["runs"]] == [None] * N_RUNS
        assert len(set(_filed(db))) == N_RUNS
        ref = main(["batch", str(manifest), "--no-store", "--no-progress", "--json"])
        want = json.loads(capsys.readouterr().out)
        assert ref == 0 and [r["result"]["identification"] for r in doc["runs"]] == [
            r["result"]["identification"] for r in want["runs"]]
    finally:
        for w in workers:
            _stop(w)


def _no_workers_left(address: str) -> None:
    """Wait until the scheduler has dropped the workers an earlier test killed."""
    from distributed import Client

    with Client(address, timeout="60s") as client:
        for _ in range(300):
            if not client.nthreads():
                return
            time.sleep(0.1)
    pytest.fail("the scheduler still lists the killed workers after 30 s")


@pytest.mark.slow
def test_every_worker_lost_mid_batch_ends_it_and_keeps_what_was_filed(scheduler, manifest,
                                                                      tmp_path):
    """The one worker killed after the first run is filed: the batch does not wait for ever
    on futures no worker will run (it did); after --worker-wait seconds without a worker the
    runs not done fail, saying so, and the runs filed stay filed."""
    from distributed import Client

    address, folder = scheduler
    workers = [_worker(address, folder, "last")]

    def progress(item):
        if item.outcome is not None:
            _stop(workers[0])

    try:
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(1, timeout=60)
            t0 = time.monotonic()
            items = run_batch(manifest, executor=client, store=str(tmp_path / "h.db"),
                              progress=progress, worker_wait=2.0)
            took = time.monotonic() - t0
    finally:
        _stop(workers[0])
    errors = [i.error for i in items]
    done = [e for e in errors if e is None]
    assert done and len(done) < N_RUNS, errors
    assert all(e is None or "no Dask worker on the scheduler" in str(e) for e in errors)
    assert len(_filed(tmp_path / "h.db")) == len(done)
    assert took < 60, took


@pytest.mark.slow
def test_a_frozen_worker_with_a_timeout_fails_its_runs_and_the_batch_ends(scheduler, manifest,
                                                                          tmp_path):
    """A worker stopped (SIGSTOP: a hung host) holds its results and its fits: with a timeout
    the batch hung in 6 tries of 9 (fetching a finished result from it has no end); now its
    runs fail by the timeout or are computed again on the other worker, and it ends."""
    from distributed import Client

    address, folder = scheduler
    _no_workers_left(address)
    workers = [_worker(address, folder, f"f{i}") for i in range(2)]
    frozen = []

    def progress(item):
        if not frozen and item.outcome is not None:
            frozen.append(workers[0].pid)
            os.killpg(workers[0].pid, signal.SIGSTOP)

    try:
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=60)
            t0 = time.monotonic()
            items = run_batch(manifest, executor=client, store=str(tmp_path / "h.db"),
                              progress=progress, timeout=5.0, worker_wait=3.0)
            took = time.monotonic() - t0
    finally:
        for w in workers:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(w.pid, signal.SIGCONT)
            _stop(w)
    assert frozen
    errors = [str(i.error) for i in items if i.error is not None]
    assert all("timeout" in e or "no result came back" in e for e in errors), errors
    assert len(_filed(tmp_path / "h.db")) == N_RUNS - len(errors)
    assert took < 300, took


@pytest.mark.slow
def test_finished_results_whose_only_worker_died_do_not_hang_the_driver(scheduler):
    """Dask's gather waits for ever for results whose worker died when no other can compute
    them again; the driver's gather is bounded, and the runs end with the no-worker message."""
    from distributed import Client

    address, folder = scheduler
    _no_workers_left(address)
    worker = _worker(address, folder, "holder")
    try:
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(1, timeout=60)
            fits = Fits(list(range(-4, 0)), client, own=False, timeout=None, fn=abs, chunk=2,
                        worker_wait=1.0)
            fits.submit_up_to(4)
            for _ in range(1200):  # both units finished on the worker, not yet fetched
                if all(f.status == "finished" for f in fits.pending.values()):
                    break
                time.sleep(0.05)
            assert [f.status for f in fits.pending.values()] == ["finished"] * 2
            _stop(worker)
            t0 = time.monotonic()
            with pytest.raises(RunStoppedError, match="no Dask worker on the scheduler"):
                fits.collect(0)
            assert time.monotonic() - t0 < 60
    finally:
        _stop(worker)


@pytest.mark.slow
def test_no_worker_is_a_clean_message(scheduler, manifest, tmp_path, capsys):
    address, _ = scheduler
    _no_workers_left(address)
    assert main(["batch", str(manifest), "--scheduler", address, "--no-store",
                 "--no-progress", "--worker-wait", "2"]) == 2
    err = capsys.readouterr().err
    assert "no Dask worker" in err and "dask worker" in err and "Traceback" not in err


class _LateFuture:
    """A Dask future's behaviour in the race: finished, but ``result(timeout)`` times out.

    The task is done on its worker while the driver's 0.5 s wait expires gathering the result
    over the network; ``exception()`` is then None. ``empty`` futures come back empty (a result
    lost with its worker) the first time they are submitted.
    """

    def __init__(self, value, *, late: bool, empty: bool = False) -> None:
        self.value, self.late, self.empty = value, late, empty

    def result(self, timeout=None):
        if self.late and timeout is not None:
            self.late = False
            raise TimeoutError
        return None if self.empty else self.value

    def done(self):
        return True

    def cancelled(self):
        return False

    def exception(self, timeout=None):
        return None

    def cancel(self):
        return False


class _Executor:
    def __init__(self, empty_first: set[int]) -> None:
        self.calls: list[int] = []
        self.empty_first = empty_first

    def submit(self, fn, *args):  # run_unit(fn, [task]): one fit a unit here
        task = args[-1][0]
        self.calls.append(task)
        empty = task in self.empty_first and self.calls.count(task) == 1
        return _LateFuture(fn(*args), late=task % 2 == 0, empty=empty)


def test_a_result_that_arrives_after_the_wait_timed_out_is_collected_not_none():
    ex = _Executor(empty_first={3})
    fits = Fits(list(range(6)), ex, own=False, timeout=None, fn=lambda t: (t, t * t))
    fits.submit_up_to(6)
    assert [fits.collect(k) for k in range(6)] == [(k, k * k) for k in range(6)]
    assert ex.calls.count(3) == 2  # the empty result was run again, once


def test_a_result_lost_twice_fails_that_run_alone():
    ex = _Executor(empty_first=set())
    ex.submit = lambda fn, f, tasks: (ex.calls.append(tasks[0]),
                                      _LateFuture(fn(f, tasks), late=False,
                                                  empty=tasks[0] == 1))[1]
    fits = Fits([0, 1, 2], ex, own=False, timeout=None, fn=lambda t: (t,))
    fits.submit_up_to(3)
    assert fits.collect(0) == (0,)
    with pytest.raises(RunStoppedError, match="no result came back"):
        fits.collect(1)
    assert fits.collect(2) == (2,) and ex.calls.count(1) == 2
