"""A production lot of MEMS accelerometer triads as one batch: fits per second per core (issue 31).

The fleet example (``examples/fleet/make_fleet.py``): ``UNITS`` simulated triads (1000 on a
machine of 8 cores or more, 200 below), each with its own errors and its own twelve-position
test, judged against the production spec and filed into a fresh SQLite history database by
``run_batch`` on a process pool of every core. Prints the throughput in fits per second and per
second per core (the lot's wall time, pool start-up included), and the lot statistics of the
filed runs when ``inertest.quality.lot`` is there.

Run: ``python benchmarks/bench_fleet.py [UNITS]``.
"""

from __future__ import annotations

import importlib.util
import os
import sys
import tempfile
import time
from pathlib import Path

from inertest.app.batch import run_batch
from inertest.store import HistoryStore

HERE = Path(__file__).resolve().parent
EXAMPLE = HERE.parent / "examples" / "fleet"


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _make_fleet():  # the example's script, not part of the package
    spec = importlib.util.spec_from_file_location("make_fleet", EXAMPLE / "make_fleet.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.make_fleet


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    cores = _cores()
    units = int(argv[0]) if argv else (1000 if cores >= 8 else 200)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        manifest = _make_fleet()(folder / "lot", units)
        t_make = time.perf_counter() - t0
        db = folder / "history.db"
        HistoryStore(str(db), create=True).close()
        t0 = time.perf_counter()
        items = run_batch(manifest, workers=cores, store=str(db))
        t = time.perf_counter() - t0
        failed = [i.error for i in items if i.error is not None]
        if failed:
            raise SystemExit(f"fleet batch failed: {failed[0]}")
        verdicts: dict[str, int] = {}
        for i in items:
            assert i.outcome is not None and i.outcome.conformance is not None
            verdicts[i.outcome.conformance.overall] = (
                verdicts.get(i.outcome.conformance.overall, 0) + 1)
        print(f"{units} MEMS accelerometer triads (12 positions, 120 readings each), simulated "
              f"in {t_make:.1f} s; judged against examples/fleet/spec.toml and filed on "
              f"{cores} worker processes")
        print(f"  {t:.1f} s: {units / t:.1f} fits/s, {units / t / cores:.2f} fits/s per core "
              f"(pool start-up included); verdicts "
              + ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items())))
        try:
            from inertest.quality.lot import lot_statistics
        except ImportError:
            return
        store = HistoryStore(str(db))
        try:
            docs = [r.result for s in store.serials() for r in store.runs(s)]
        finally:
            store.close()
        lot = lot_statistics(docs)
        print(f"  lot statistics of {len(docs)} stored runs (`inertest lot` prints them all):")
        for q in lot.quantities:
            if not q.quantity.startswith("B_"):
                continue
            u2u = ("-" if q.unit_to_unit is None else f"{q.unit_to_unit:.3g}")
            cpk = ", ".join(f"Cpk {c.cpk:.2f}" for c in q.capability if c.cpk is not None)
            print(f"    {q.quantity} [{q.unit}]: mean {q.mean:.3g}, unit-to-unit {u2u}"
                  + (f", {cpk}" if cpk else "")
                  + f"; {len(q.stand_out)} unit(s) stand out"
                  + "".join(f" {s.serial} ({s.value:.3g})" for s in q.stand_out[:3]))


if __name__ == "__main__":
    main()
