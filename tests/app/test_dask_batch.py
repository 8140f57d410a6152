"""Batches and Monte Carlo on one seam (issue 18): serial == process pool == Dask, bit for bit.

A real ``dask.distributed.LocalCluster`` (two worker processes, one thread each, loopback only)
is started once for the module and closed at its end. The references are computed here without
the batch machinery: :func:`inertest.run` on each (plan, data) pair alone, the history database
read back with the standard library's ``sqlite3``, and the centrifuge Monte Carlo redone as a
plain loop over ``SeedSequence(seed).spawn(n)``.
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import sqlite3
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import dask
import numpy as np
import pytest
import sqlalchemy as sa
from distributed import Client, LocalCluster

import inertest
from inertest.app.batch import run_batch
from inertest.cli import main
from inertest.io.data_file import write_table
from inertest.procedures.centrifuge_nine_position import fit_inputs
from inertest.results import EnvelopeResult
from inertest.studies import centrifuge_study as cs

pytestmark = pytest.mark.slow

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
N_RUNS = 4  # good (plan, data) pairs in the manifest; one more names a missing plan


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes on 127.0.0.1, no dashboard; bounded start and shutdown."""
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR) as lc:
        with Client(lc, timeout="60s") as client:
            client.wait_for_workers(2, timeout=60)
            yield lc, client


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    folder = tmp_path_factory.mktemp("batch")
    plan = EXAMPLES / "polar_tumble" / "plan.toml"
    truth = EXAMPLES / "polar_tumble" / "truth.toml"
    pairs = []
    for k in range(N_RUNS):
        data = folder / f"d{k}.csv"
        write_table(data, inertest.simulate(plan, truth, noise=0.002, rng=100 + k))
        pairs.append((plan, data))
    path = folder / "batch.toml"
    path.write_text("".join(f'[[run]]\nplan = "{p}"\ndata = "{d}"\n\n' for p, d in pairs)
                    + '[[run]]\nplan = "missing.toml"\ndata = "d0.csv"\n')
    return path, pairs


class _Transactions:
    """Statements of every committed transaction on the SQLite connections this process opens.

    Read from SQLite itself (each connection's trace callback, called for every statement the
    library runs, whoever issued it), not from SQLAlchemy's events: the filing runs on the
    driver's cursor.
    """

    def __init__(self):
        self.open: dict[int, list[str]] = {}
        self.committed: list[list[str]] = []

    def _connect(self, dbapi_connection, _record):
        key = id(dbapi_connection)
        dbapi_connection.set_trace_callback(lambda sql: self._statement(key, sql))

    def _statement(self, key, sql):
        word = sql.split("(")[0].strip().upper()
        if word.startswith("BEGIN"):
            self.open[key] = []
        elif word == "COMMIT":
            if key in self.open:
                self.committed.append(self.open.pop(key))
        elif word == "ROLLBACK":
            self.open.pop(key, None)
        elif key in self.open:
            self.open[key].append(word)

    def __enter__(self):
        sa.event.listen(sa.pool.Pool, "connect", self._connect)
        return self

    def __exit__(self, *exc):
        sa.event.remove(sa.pool.Pool, "connect", self._connect)

    def with_run_insert(self):
        return [t for t in self.committed if "INSERT INTO RUNS" in t]


def _rows(db) -> tuple[int, int]:
    with sqlite3.connect(db) as con:
        return (con.execute("SELECT COUNT(*) FROM runs").fetchone()[0],
                con.execute("SELECT COUNT(*) FROM estimates").fetchone()[0])


def _stored_values(db) -> list[tuple]:
    with sqlite3.connect(db) as con:
        return con.execute(
            "SELECT r.data_sha256, e.name, e.kind, e.value, e.std FROM estimates e "
            "JOIN runs r ON e.run_id = r.id ORDER BY r.data_sha256, e.name").fetchall()


def test_batch_serial_pool_and_dask_are_bit_identical_and_filed_by_the_driver(
        manifest, cluster, tmp_path):
    path, pairs = manifest
    _, client = cluster
    reference = [inertest.run(p, d) for p, d in pairs]  # each alone, no batch machinery
    want = [json.dumps(r.result.to_dict(), allow_nan=True) for r in reference]
    n_estimates = sum(len(r.result.to_dict()["identification"]["coefficients"])
                      + len(r.result.to_dict()["identification"]["combinations"])
                      for r in reference)
    stored = {}
    for name, kw in (("serial", {}), ("pool", {"workers": 2}), ("dask", {"executor": client})):
        db = tmp_path / f"{name}.db"
        filed = []
        with _Transactions() as tx:
            items = run_batch(path, store=str(db), progress=filed.append, full_results=True,
                              **kw)
        assert [i.error is None for i in items] == [True] * N_RUNS + [False], name
        assert "missing.toml" in items[-1].error
        assert filed == items  # the progress callback saw every item, in task order
        got = [json.dumps(i.outcome.result.to_dict(), allow_nan=True) for i in items[:-1]]
        assert got == want, name
        for i, r in zip(items, reference, strict=False):
            assert (i.outcome.result.residual_output.tobytes()
                    == r.result.residual_output.tobytes()), name
        # every run written by this process, one transaction each, nothing else stored
        runs_tx = tx.with_run_insert()
        assert len(runs_tx) == N_RUNS, name
        assert all(t.count("INSERT INTO RUNS") == 1 for t in runs_tx), name
        assert _rows(db) == (N_RUNS, n_estimates), name
        stored[name] = _stored_values(db)
    assert stored["serial"] == stored["pool"] == stored["dask"]
    # By default a run without a report comes back as its envelope alone: the same numbers.
    for kw in ({}, {"workers": 2}, {"executor": client}):
        items = run_batch(path, **kw)
        assert all(isinstance(i.outcome.result, EnvelopeResult) for i in items[:-1])
        assert [json.dumps(i.outcome.result.to_dict(), allow_nan=True)
                for i in items[:-1]] == want


def test_batch_cli_on_a_dask_scheduler_with_a_progress_bar(manifest, cluster, tmp_path, capsys):
    path, _ = manifest
    lc, _ = cluster
    db = tmp_path / "cli.db"
    serial = run_batch(path)
    status = main(["batch", str(path), "--scheduler", lc.scheduler_address, "--db", str(db),
                   "--json", "--progress"])
    out, err = capsys.readouterr()
    assert status == 1  # the run naming a missing plan failed; the others are filed
    doc = json.loads(out)
    assert [r["error"] is None for r in doc["runs"]] == [True] * N_RUNS + [False]
    def same(d):  # the envelope less its test block (filing times differ run to run)
        return json.dumps({k: v for k, v in d.items() if k != "test"})

    assert [same(r["result"]) for r in doc["runs"][:-1]] == [
        same(i.outcome.to_dict()) for i in serial[:-1]]
    assert f"{N_RUNS + 1}/{N_RUNS + 1}" in err and "1 failed" in err
    assert _rows(db)[0] == N_RUNS


def test_batch_cli_unreachable_scheduler_is_one_line(manifest, tmp_path, capsys):
    path, _ = manifest
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        status = main(["batch", str(path), "--scheduler", "tcp://127.0.0.1:9", "--no-store"])
    err = capsys.readouterr().err
    assert status != 0
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and "scheduler" in lines[0]


def test_centrifuge_monte_carlo_serial_pool_and_dask_equal_a_plain_seedsequence_loop(cluster):
    _, client = cluster
    plan = cs.StudyPlan(revolutions=2, seed=7)
    runs = cs.simulate_runs(plan)
    n, sigma = 5, plan.noise_sigma_rad_s
    # Reference: the specification written out, one repetition per spawned seed.
    clean = cs.gyro_output(runs, plan.truth)
    est = []
    for child in np.random.SeedSequence(7).spawn(n):
        noisy = clean + np.random.default_rng(child).normal(0.0, sigma, clean.size)
        lin, _ = fit_inputs(runs.position, runs.omega, runs.t, noisy, runs.f_true,
                            runs.omega_true, sigma_rad_s=sigma)
        est.append(np.asarray(lin.x, dtype=float))
    want = np.std(est, axis=0, ddof=1)
    serial = cs.monte_carlo_std(plan, fit_inputs, runs, n, plan.seed)
    # fork server: this process runs the Dask client's threads
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("forkserver")) as pool:
        pooled = cs.monte_carlo_std(plan, fit_inputs, runs, n, plan.seed, executor=pool)
    dask = cs.monte_carlo_std(plan, fit_inputs, runs, n, plan.seed, executor=client, chunks=2)
    for got in (serial, pooled, dask):
        assert got.tobytes() == want.tobytes()
