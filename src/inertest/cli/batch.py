"""``inertest batch MANIFEST``: many (plan, data) pairs, fitted in parallel, filed one by one."""

from __future__ import annotations

import os
from pathlib import Path

import click

from inertest.cli._common import echo_json, print_table
from inertest.runner import run_batch


@click.command()
@click.argument("manifest", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Worker processes for the fits (the database is written by this process).")
@click.option("--no-store", is_flag=True, help="Do not store the runs in the history database.")
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
@click.option("--allow-duplicate", is_flag=True,
              help="File data files that are already stored for their instrument and procedure.")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object: the result envelope of every run, or its error.")
def batch(manifest: Path, workers: int, no_store: bool, db: str | None, allow_duplicate: bool,
          as_json: bool) -> None:
    """Fit, report and store every run listed in MANIFEST ([[run]] plan, data, sigma, report).

    Each run is its own transaction: a run that fails stores nothing and does not stop the
    others. The exit status is 1 when any run failed.
    """
    store: bool | str = False if no_store else (db or True)
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(workers, os.cpu_count() or 1)) as pool:
            items = run_batch(manifest, executor=pool, store=store,
                              allow_duplicate=allow_duplicate)
    else:
        items = run_batch(manifest, store=store, allow_duplicate=allow_duplicate)
    failed = [i for i in items if i.error is not None]
    if as_json:
        echo_json({"kind": "batch", "runs": [
            {"plan": str(i.task.plan), "data": str(i.task.data),
             "result": None if i.outcome is None else i.outcome.result.to_dict(),
             "stored_run": None if i.outcome is None else i.outcome.stored_run,
             "error": i.error} for i in items]})
    else:
        rows = []
        for i in items:
            if i.outcome is None:
                rows.append([str(i.task.data), "-", "-", f"failed: {i.error}"])
            else:
                o = i.outcome
                rows.append([str(i.task.data), o.result.kind, o.plan.instrument.serial or "-",
                             "stored" if o.stored_run else "fitted (not stored)"])
        print_table(f"batch {manifest}", ["data", "procedure", "serial", "outcome"], rows)
    if failed:
        raise SystemExit(1)
