"""A batch of polar-tumble fits over 1, 2, 4, 8 and 16 workers: process pool and Dask (issue 31).

Workload: ``FITS`` (320 by default) polar-tumble data files of the example plan (64 positions,
``SAMPLES`` readings each, default 500 -> 32 000 rows, different noise seeds) in one manifest,
run by :func:`inertest.run_batch`, once without a store and once filed into an empty SQLite
history database (one transaction per run, written by this process). Times:

* serial (``workers=1``, BLAS on one thread: what each worker runs), the baseline, stored and
  not;
* a process pool (:func:`inertest.app.executors.local_pool`, what ``run_batch(workers=N)``
  starts) and a Dask cluster (a ``dask scheduler`` process and ``dask worker`` processes of
  one thread each, on 127.0.0.1) of 1, 2, 4, 8 and 16 workers, each already started and warm
  (as a production line keeps them; the start-up is printed apart).

For each: the speed-up over serial, and the driver's CPU time per fit (this process, every
thread: submitting, receiving, filing), the serial part of the batch (Amdahl). Every result is
checked bit for bit against the serial one. Targets (issue 31, on a 16-core machine): at least
12x serial at 16 workers for 320 fits, pool and Dask, stored and not; the driver under 1 ms a
fit. On a machine with fewer cores than workers the table stops at the cores it has and says
so: the targets are then not judged.

Then the same batch machinery at 16 workers on any machine ("replayed fits"): each fit is
replaced by a sleep as long as that fit took serially here, returning that fit's real result
(its envelope, record and JSON), so the pool, the Dask cluster, the units, the transfers and
the filing all work as in a real batch while the workers need no cores. Its speed-up is what
the machinery leaves of the ideal 16x (the scheduling, the tail, the driver), apart from
what the hardware takes (cores' clock under load, memory bandwidth); its driver time per fit
is the real one at 16 workers. It judges nothing: the targets are for real fits on 16 cores.

Run: ``python benchmarks/bench_batch.py [FITS [SAMPLES [MAX_WORKERS [REPLAY_WORKERS]]]]``.
"""

from __future__ import annotations

import functools
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_limits

import inertest
import inertest.app.batch
from inertest.app.batch import BatchOptions, BatchTask, compute, read_manifest, run_batch
from inertest.app.executors import local_pool
from inertest.io.data_file import write_table
from inertest.io.plan_file import read_toml
from inertest.store import HistoryStore

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "polar_tumble"
WORKERS = (1, 2, 4, 8, 16)
TARGET_SPEEDUP = 12.0  # at 16 workers
TARGET_DRIVER_MS = 1.0


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _one_file(args: tuple[str, str, int]) -> None:
    plan, data, seed = args
    write_table(data, inertest.simulate(plan, EXAMPLES / "truth.toml", noise=0.002, rng=seed))


def _workload(folder: Path, fits: int, samples: int, pool: Any = None) -> Path:
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
    jobs = [(str(plan), str(folder / f"tumble{k:03d}.csv"), k) for k in range(fits)]
    list(map(_one_file, jobs) if pool is None else pool.map(_one_file, jobs))
    manifest = folder / "batch.toml"
    manifest.write_text("\n".join(f'[[run]]\nplan = "plan.toml"\ndata = "{Path(d).name}"\n'
                                  for _, d, _ in jobs), encoding="utf-8")
    return manifest


def _replay_file(task: BatchTask, stored: bool) -> Path:
    return Path(f"{task.data}.{'stored' if stored else 'plain'}.pickle")


def _record_fits(tasks: list[BatchTask], stored: bool) -> None:
    """Fit each task here (BLAS on one thread); keep its result and how long it took."""
    for t in tasks:
        t0 = time.perf_counter()
        prepared = compute(t, BatchOptions(store=stored))
        _replay_file(t, stored).write_bytes(pickle.dumps((time.perf_counter() - t0, prepared)))


def _replayed_fit(task: BatchTask, options: BatchOptions) -> Any:
    """A fit replaced by a sleep as long as it took, returning its real result (no cores used)."""
    seconds, prepared = pickle.loads(_replay_file(task, options.store).read_bytes())
    time.sleep(seconds)
    return prepared


@contextmanager
def _replaying() -> Iterator[None]:
    """Batches of this block run :func:`_replayed_fit` instead of the fit (where they run)."""
    real = inertest.app.batch.compute
    inertest.app.batch.compute = _replayed_fit  # type: ignore[assignment]
    try:
        yield
    finally:
        inertest.app.batch.compute = real  # type: ignore[assignment]


def _warm(tasks: list[BatchTask], executor: Any, db: Path) -> None:
    """Every worker's imports and caches, for both kinds of batch (as a production line's)."""
    run_batch(tasks, executor=executor)
    run_batch(tasks, executor=executor, store=str(db))


def _timed(manifest: Path, db: Path | None, **kw: Any) -> tuple[float, float, list[str]]:
    """Wall time, driver CPU time (this process, all threads) and the results as JSON.

    The database is made before the clock starts: a production line files into one that
    exists (its creation, about 0.15 s of migrations, is not a per-fit cost).
    """
    if db is not None:
        HistoryStore(str(db), create=True).close()
    t0, c0 = time.perf_counter(), time.process_time()
    items = run_batch(manifest, store=False if db is None else str(db), **kw)
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    bad = [i.error for i in items if i.error is not None]
    if bad:
        raise SystemExit(f"batch failed: {bad[0]}")
    return dt, dc, [json.dumps(i.outcome.result.to_dict(), allow_nan=True) for i in items]


@contextmanager
def _dask(n: int) -> Iterator[Any]:
    """A Dask cluster as on a lab's machines: ``dask scheduler`` and ``dask worker`` processes.

    The scheduler runs in its own process, so the driver's CPU time is the client's alone
    (a LocalCluster would run the scheduler inside this process).
    """
    from distributed import Client

    cmd = [sys.executable, "-m", "dask"]  # `dask scheduler`, `dask worker`, wherever installed
    with tempfile.TemporaryDirectory() as tmp:
        sfile = Path(tmp) / "scheduler.json"
        quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
        procs = [subprocess.Popen([*cmd, "scheduler", "--host", "127.0.0.1", "--port", "0",
                                   "--no-dashboard", "--scheduler-file", str(sfile)], **quiet)]
        try:
            for _ in range(600):
                if sfile.exists() and sfile.stat().st_size:
                    break
                time.sleep(0.1)
            address = json.loads(sfile.read_text())["address"]
            procs.append(subprocess.Popen([*cmd, "worker", address, "--nworkers", str(n),
                                           "--nthreads", "1", "--no-dashboard",
                                           "--memory-limit", "0"], **quiet))
            with Client(address, timeout="60s") as client:
                client.wait_for_workers(n, timeout=120)
                yield client
        finally:
            for p in reversed(procs):
                p.terminate()
            for p in procs:
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    fits = int(argv[0]) if argv else 320
    samples = int(argv[1]) if len(argv) > 1 else 500
    cores = _cores()
    most = int(argv[2]) if len(argv) > 2 else max(WORKERS)
    replay_workers = int(argv[3]) if len(argv) > 3 else max(WORKERS)
    workers = [w for w in WORKERS if w <= min(cores, most)]
    judged = cores >= max(WORKERS) and most >= max(WORKERS)
    try:
        import distributed  # noqa: F401
        have_dask = True
    except ImportError:
        have_dask = False
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        with local_pool(min(cores, 16)) as pool:
            manifest = _workload(folder, fits, samples, pool)
        print(f"{fits} polar-tumble fits of {samples * 64} rows each; {cores} cores "
              f"({os.uname().machine}); results checked bit for bit against serial")
        if not judged:
            print(f"  this machine has {cores} cores: the table stops at {workers[-1]} workers "
                  f"and the targets ({TARGET_SPEEDUP:g}x at 16 workers, driver < "
                  f"{TARGET_DRIVER_MS:g} ms a fit) are not judged here: run it on 16 cores")

        compute(read_manifest(manifest)[0])  # imports and first-call costs, not timed
        with threadpool_limits(1):
            t_ser, c_ser, ref = _timed(manifest, None)
            t_ser_db, c_ser_db, got = _timed(manifest, folder / "serial.db")
        assert got == ref, "stored serial differs"
        base = {False: t_ser, True: t_ser_db}
        print(f"  serial, BLAS 1 thread: {t_ser:.2f} s ({1e3 * t_ser / fits:.1f} ms a fit), "
              f"stored {t_ser_db:.2f} s", flush=True)

        rows: list[list[str]] = []
        ratios: dict[tuple[str, int, bool], float] = {}
        driver: dict[tuple[str, int, bool], float] = {}

        tasks = read_manifest(manifest)

        def measure(kind: str, w: int, executor: Any) -> None:
            _warm(tasks[:4 * w], executor, folder / f"warm-{kind}{w}.db")
            for stored in (False, True):
                db = folder / f"{kind}{w}.db" if stored else None
                t, c, got = _timed(manifest, db, executor=executor)
                assert got == ref, f"{kind} with {w} workers differs from serial"
                ratios[kind, w, stored] = base[stored] / t
                driver[kind, w, stored] = 1e3 * c / fits
                # a line as each is measured: a run cut short still shows what it measured
                print(f"  .. {kind}, {w} workers, {'stored' if stored else 'no store'}: "
                      f"{t:.2f} s, {ratios[kind, w, stored]:.2f}x, driver "
                      f"{driver[kind, w, stored]:.2f} ms a fit", flush=True)

        starts: dict[str, list[float]] = {"pool": [], "dask": []}
        kinds: list[tuple[str, Callable[[int], Any]]] = [("pool", local_pool)]
        if have_dask:
            kinds.append(("dask", _dask))
        for kind, make in kinds:
            for w in workers:
                t0 = time.perf_counter()
                with make(w) as executor:
                    starts[kind].append(time.perf_counter() - t0)
                    measure(kind, w, executor)
        for w in workers:
            row = [f"{w:>7d}"]
            for kind, _ in kinds:
                for stored in (False, True):
                    row.append(f"{ratios[kind, w, stored]:6.2f}x {driver[kind, w, stored]:5.2f}")
            rows.append(row)
        head = "".join(f"  {k} {'stored' if s else 'no store':<8s} (x, ms)"
                       for k, _ in kinds for s in (False, True))
        print("  speed-up over serial and driver CPU per fit [ms], warm workers:")
        print(f"  workers{head}")
        for row in rows:
            print("  " + "   ".join(row))
        for kind, _ in kinds:
            print(f"  {kind} start-up (not in the times): "
                  + ", ".join(f"{w}: {s:.1f} s" for w, s in zip(workers, starts[kind],
                                                                 strict=True)))
        if not have_dask:
            print("  dask.distributed not installed: pip install 'dask[distributed]'")
        _machinery(manifest, folder, fits, ref, have_dask, replay_workers)
        if judged:
            for kind, _ in kinds:
                for stored in (False, True):
                    r, d = ratios[kind, 16, stored], driver[kind, 16, stored]
                    label = f"{kind}, {'stored' if stored else 'no store'}"
                    print(f"  {'PASS' if r >= TARGET_SPEEDUP else 'MISS'} {label}: {r:.1f}x "
                          f"at 16 workers (target >= {TARGET_SPEEDUP:g}x)")
                    print(f"  {'PASS' if d < TARGET_DRIVER_MS else 'MISS'} {label}: driver "
                          f"{d:.2f} ms a fit (target < {TARGET_DRIVER_MS:g} ms)")


def _machinery(manifest: Path, folder: Path, fits: int, ref: list[str], have_dask: bool,
               workers: int = 16) -> None:
    """The batch machinery at ``workers`` workers with replayed fits (see the module notes)."""
    tasks = read_manifest(manifest)
    with threadpool_limits(1):
        for stored in (False, True):
            _record_fits(tasks, stored)
    print(f"  replayed fits (each a sleep as long as its fit took here, returning its real "
          f"result): the batch machinery at {workers} workers, whatever the cores")
    with _replaying():
        base = {}
        for stored in (False, True):
            t, _, got = _timed(manifest, folder / "replay-serial.db" if stored else None)
            assert got == ref, "replayed serial differs"
            base[stored] = t
        kinds: list[tuple[str, Callable[[int], Any]]] = [
            ("pool", functools.partial(local_pool, at_most_cores=False))]
        if have_dask:
            kinds.append(("dask", _dask))
        for kind, make in kinds:
            with make(workers) as executor:
                _warm(tasks[:4 * workers], executor, folder / f"warm-replay-{kind}.db")
                for stored in (False, True):
                    db = folder / f"replay-{kind}.db" if stored else None
                    t, c, got = _timed(manifest, db, executor=executor)
                    assert got == ref, f"replayed {kind} differs from serial"
                    print(f"  .. {kind}, {workers} workers, "
                          f"{'stored' if stored else 'no store'}: {t:.2f} s, "
                          f"{base[stored] / t:.2f}x serial (ideal {workers}x), "
                          f"driver {1e3 * c / fits:.2f} ms a fit", flush=True)


if __name__ == "__main__":
    main()
