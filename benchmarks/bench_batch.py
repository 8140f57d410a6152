"""Batch of polar-tumble fits on 1, 2 and all cores, and on a Dask LocalCluster (issue 18).

Workload: ``FITS`` (default 40) polar-tumble data files of the example plan (64 positions,
``SAMPLES`` readings each, default 500 -> 32 000 rows, different noise seeds), one manifest, run
by :func:`inertest.run_batch` with every run filed in a fresh SQLite history database (one
transaction per run, written by this process). Timed as a user sees it:

* serial (``workers=1``), the baseline;
* a process pool of 1, 2 and all cores (:func:`inertest.app.executors.local_pool`, what
  ``run_batch(workers=N)`` starts), start-up and shutdown included;
* a ``dask.distributed.LocalCluster`` with one single-threaded worker process per core
  (cluster start-up timed separately, then one batch on a warm cluster).

Every parallel result is checked bit for bit against the serial one. Prints times and the
speed-up ratios (serial time / time). Pool and Dask workers run BLAS single-threaded, so a
serial run with BLAS limited to one thread is shown as well: on a small shared machine part of
the gain is only the end of BLAS oversubscription. The database is written by the driver
alone, so filing is the serial part of the batch (Amdahl): its share is printed too.

Run: ``python benchmarks/bench_batch.py [FITS [SAMPLES]]``.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

from threadpoolctl import threadpool_limits

import inertest
from inertest.app.batch import compute, read_manifest, run_batch
from inertest.app.executors import local_pool
from inertest.app.run import file_run
from inertest.io.data_file import write_table
from inertest.io.plan_file import read_toml
from inertest.store import HistoryStore

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "polar_tumble"


def _workload(folder: Path, fits: int, samples: int) -> Path:
    plan_text = (EXAMPLES / "plan.toml").read_text(encoding="utf-8")
    doc = read_toml(EXAMPLES / "plan.toml", "plan")
    old = doc["procedure"].get("samples_per_position")
    plan = folder / "plan.toml"
    if old is None:
        plan_text = plan_text.replace("[procedure]\n",
                                      f"[procedure]\nsamples_per_position = {samples}\n", 1)
    else:
        plan_text = plan_text.replace(f"samples_per_position = {old}",
                                      f"samples_per_position = {samples}", 1)
    plan.write_text(plan_text, encoding="utf-8")
    runs = []
    for k in range(fits):
        data = folder / f"tumble{k:03d}.csv"
        write_table(data, inertest.simulate(plan, EXAMPLES / "truth.toml", noise=0.002, rng=k))
        runs.append(f'[[run]]\nplan = "plan.toml"\ndata = "{data.name}"\n')
    manifest = folder / "batch.toml"
    manifest.write_text("\n".join(runs), encoding="utf-8")
    return manifest


def _timed(manifest: Path, db: Path, **kw) -> tuple[float, list[str]]:
    t0 = time.perf_counter()
    items = run_batch(manifest, store=str(db), **kw)
    dt = time.perf_counter() - t0
    bad = [i.error for i in items if i.error is not None]
    if bad:
        raise SystemExit(f"batch failed: {bad[0]}")
    return dt, [json.dumps(i.outcome.result.to_dict(), allow_nan=True) for i in items]


def _filing_only(manifest: Path, db: Path) -> float:
    """Time of the driver's part alone: report-free filing of already computed results."""
    computed = [compute(t) for t in read_manifest(manifest)]
    store = HistoryStore(str(db))
    when = datetime.now(UTC)
    t0 = time.perf_counter()
    try:
        for result, plan, text, digest, msgs, summary, *_ in computed:  # (lab, budget...)
            file_run(result, plan, plan_text=text, data_sha256=digest, data_summary=summary,
                     tested_at=when, store=store, warnings_=msgs)
    finally:
        store.close()
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    fits = int(argv[0]) if argv else 40
    samples = int(argv[1]) if len(argv) > 1 else 500
    cores = os.cpu_count() or 1
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        manifest = _workload(folder, fits, samples)
        rows = samples * 64
        print(f"{fits} polar-tumble fits of {rows} rows each, filed into SQLite; {cores} cores")

        compute(read_manifest(manifest)[0])  # imports and first-call costs, not timed
        t_serial, ref = _timed(manifest, folder / "serial.db")
        t_filing = _filing_only(manifest, folder / "filing.db")
        with threadpool_limits(1):
            t_one, got = _timed(manifest, folder / "serial1.db")
        assert got == ref, "single-threaded BLAS differs from serial"
        print("  speed-up = serial time / time (first: default BLAS; second: BLAS 1 thread)")

        def line(label: str, t: float, note: str = "") -> None:
            print(f"  {label:<28s}{t:7.2f} s  {t_serial / t:5.2f}x  {t_one / t:5.2f}x  {note}")

        line("serial (workers=1)", t_serial,
             f"filing by the driver {t_filing:.2f} s = {100 * t_filing / t_serial:.0f} %")
        line("serial, BLAS 1 thread", t_one, "what each pool or Dask worker runs")
        for w in sorted({1, 2, cores}):
            t0 = time.perf_counter()
            with local_pool(w) as pool:  # what run_batch(workers=w) starts for w > 1
                _, got = _timed(manifest, folder / f"pool{w}.db", executor=pool)
            t = time.perf_counter() - t0
            assert got == ref, f"workers={w} differs from serial"
            line(f"process pool, workers={w}", t, "pool start-up included; identical")

        try:
            from distributed import Client, LocalCluster
        except ImportError:
            print("  dask.distributed not installed: pip install 'dask[distributed]'")
            return
        t0 = time.perf_counter()
        with LocalCluster(n_workers=cores, processes=True, threads_per_worker=1,
                          host="127.0.0.1", dashboard_address=None,
                          silence_logs=logging.ERROR) as lc, Client(lc) as client:
            client.wait_for_workers(cores, timeout=120)
            t_start = time.perf_counter() - t0
            t, got = _timed(manifest, folder / "dask.db", executor=client)
            assert got == ref, "Dask differs from serial"
        line(f"Dask LocalCluster, {cores} procs", t,
             f"cluster start-up {t_start:.1f} s not included; identical")


if __name__ == "__main__":
    main()
