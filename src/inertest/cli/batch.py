"""``inertest batch MANIFEST``: many (plan, data) pairs, fitted in parallel, filed one by one."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from inertest.cli import safe_line
from inertest.cli._common import FiniteFloatRange, echo_json, print_table
from inertest.cli._verdicts import verdict_summary
from inertest.errors import InputError

if TYPE_CHECKING:  # the runner is imported by the command: --help stays fast (issue 18)
    from inertest.app.batch import BatchItem
    from inertest.app.run import RunOutcome


@click.command()
@click.argument("manifest", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Local worker processes for the fits (the database is written by this "
                   "process).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the fits on a Dask cluster instead (scheduler address, e.g. "
                   "tcp://10.0.0.5:8786; needs dask[distributed]).")
@click.option("--worker-wait", type=FiniteFloatRange(min=0, min_open=True), default=60.0,
              show_default=True, metavar="SECONDS",
              help="With --scheduler: how long to wait for a first Dask worker before giving "
                   "up, and how long the scheduler may be left without any during the batch "
                   "(the runs not done then fail; those filed are kept).")
@click.option("--ship-data", is_flag=True,
              help="Send each run's files (plan, data, spec, lab file) to the worker with the "
                   "run: for a cluster whose workers do not share this machine's paths.")
@click.option("--timeout", type=FiniteFloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS",
              help="Fail a run whose fit takes longer than this, counted from when every "
                   "earlier run is filed; its worker is stopped (default: no limit).")
@click.option("--no-store", is_flag=True, help="Do not store the runs in the history database.")
@click.option("--db", default=None, help="History database URL or SQLite path (default: "
              "$INERTEST_DB or ~/.local/share/inertest/history.db).")
@click.option("--allow-duplicate", is_flag=True,
              help="File data files that are already stored for their instrument and procedure.")
@click.option("--progress/--no-progress", default=None,
              help="Progress bar on stderr (default: when stderr is a terminal).")
@click.option("--quiet", "-q", is_flag=True, help="No progress bar (as --no-progress).")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object: the result envelope of every run, or its error.")
def batch(manifest: Path, workers: int, scheduler: str | None, worker_wait: float,
          ship_data: bool, timeout: float | None,
          no_store: bool, db: str | None, allow_duplicate: bool, progress: bool | None,
          quiet: bool, as_json: bool) -> None:
    """Fit, report and store every run listed in MANIFEST ([[run]] plan, data, sigma, report).

    A run (or the manifest's [defaults] table) may name spec (an instrument specification) and
    equipment (the lab equipment file): its budget and verdicts are filed with it, and a line
    per run gives its overall verdict and worst quantity. Each run is its own transaction: a
    run that fails stores nothing and does not stop the others, even one that kills its worker
    process (out of memory): the pool is restarted and that run reported as failed. The exit
    status is 1 when any run failed (not for a failed verdict: read "conformance" in the JSON).
    """
    from inertest.app.batch import read_manifest, run_batch

    store: bool | str = False if no_store else (db or True)
    tasks = read_manifest(manifest)
    show = False if quiet else progress
    with _progress_bar(len(tasks), show) as advance, _dask_client(scheduler) as client:
        items = run_batch(tasks, executor=client, workers=workers, store=store,
                          allow_duplicate=allow_duplicate, progress=advance, timeout=timeout,
                          worker_wait=worker_wait, ship_data=ship_data)
    failed = [i for i in items if i.error is not None]
    _warn_once(items)
    if as_json:
        echo_json({"kind": "batch", "runs": [_run_json(i) for i in items]})
    else:
        rows = []
        for i in items:
            if i.outcome is None:
                rows.append([str(i.task.data), "-", "-", f"failed: {i.error}", "-"])
            else:
                o = i.outcome
                serial = o.plan.instrument.serial if o.plan is not None else ""
                rows.append([str(i.task.data), o.result.kind, serial or "-",
                             "stored" if o.stored_run else "fitted (not stored)",
                             _overall(o)])
        print_table(f"batch {manifest}", ["data", "procedure", "serial", "outcome", "verdict"],
                    rows)
        for k, i in enumerate(items, start=1):
            if i.outcome is not None:
                click.echo(safe_line(f"run {k} ({i.task.data}): verdict "
                                     f"{verdict_summary(_conformance(i.outcome))}"))
    if failed:
        first = failed[0]
        click.echo(safe_line(f"error: {len(failed)} of {len(items)} runs failed (nothing stored "
                             f"for them); first: {first.task.data}: {first.error}"), err=True)
        raise SystemExit(1)


def _warn_once(items: list[BatchItem]) -> None:
    """Each distinct warning of the runs on stderr once, with how many runs gave it."""
    seen: dict[str, int] = {}
    for i in items:
        for w in () if i.outcome is None else i.outcome.warnings:
            seen[w] = seen.get(w, 0) + 1
    for w, n in seen.items():
        click.echo(safe_line(f"warning ({n} of {len(items)} runs): {w}"), err=True)


def _conformance(o: RunOutcome) -> dict[str, object] | None:
    return None if o.conformance is None else o.conformance.to_dict()


def _overall(o: RunOutcome) -> str:
    return "-" if o.conformance is None else o.conformance.overall


def _run_json(i: BatchItem) -> dict[str, object]:
    """One run of ``--json``: the fit result, and the budget and verdicts when judged."""
    o = i.outcome
    return {"plan": str(i.task.plan), "data": str(i.task.data),
            "spec": None if i.task.spec is None else str(i.task.spec),
            "equipment": None if i.task.equipment is None else str(i.task.equipment),
            # the envelope as `fit --json` prints it: its test block and messages included
            "result": None if o is None else o.to_dict(),
            "warnings": [] if o is None else list(o.warnings),
            "uncertainty_budget": None if o is None or o.budget is None else o.budget.to_dict(),
            "conformance": None if o is None else _conformance(o),
            "stored_run": None if o is None else o.stored_run, "error": i.error}


@contextmanager
def _progress_bar(total: int, show: bool | None) -> Iterator[Any]:
    """A rich progress bar on stderr (runs filed / total); yields the per-item callback."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

    console = Console(stderr=True)
    enabled = console.is_terminal if show is None else show
    bar = Progress("[progress.description]{task.description}", BarColumn(),
                   MofNCompleteColumn(), TimeElapsedColumn(), console=console,
                   disable=not enabled, transient=False)
    task = bar.add_task("filed", total=total)
    failed = 0

    def advance(item: BatchItem) -> None:
        nonlocal failed
        failed += item.error is not None
        bar.update(task, advance=1,
                   description=f"filed ({failed} failed)" if failed else "filed")

    with bar:
        yield advance


@contextmanager
def _dask_client(address: str | None) -> Iterator[Any]:
    """A ``dask.distributed.Client`` connected to ``address`` (None: no client)."""
    if address is None:
        yield None
        return
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler needs Dask: pip install 'dask[distributed]', or use "
                         "--workers N for local processes") from None
    _check_scheduler_address(address)
    try:
        client = Client(address)  # timeout: distributed.comm.timeouts.connect
    except ValueError as exc:  # an address distributed's own parser refuses
        raise InputError(f"--scheduler {address!r} is not a scheduler address ({exc}); "
                         f"{_ADDRESS_FIX}") from None
    except (OSError, TimeoutError) as exc:
        raise InputError(f"cannot reach the Dask scheduler at {address} ({exc}); check the "
                         "address, or use --workers N for local processes") from None
    # Dask logs a lost scheduler or worker with its tracebacks on stderr; the batch says
    # what became of each run in its own words (one line each).
    # (Dask's logging configuration gives some of its loggers their own levels: each is set.)
    dask_logs = [logging.getLogger(name) for name in list(logging.root.manager.loggerDict)
                 if name == "distributed" or name.startswith("distributed.")]
    levels = [log.level for log in dask_logs]
    for log in dask_logs:
        log.setLevel(logging.CRITICAL)
    try:
        yield client
    finally:
        client.close()
        for log, level in zip(dask_logs, levels, strict=True):
            log.setLevel(level)


_ADDRESS_FIX = "give it as tcp://HOST:PORT, e.g. tcp://10.0.0.5:8786"


def _check_scheduler_address(address: str) -> None:
    """Refuse, before connecting, a ``--scheduler`` that is no ``SCHEME://HOST:PORT`` address."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import backends

    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location)
    except ValueError as exc:
        raise InputError(f"--scheduler {address!r} is not a scheduler address ({exc}); "
                         f"{_ADDRESS_FIX}") from None
    if scheme not in backends or scheme == "inproc":
        known = ", ".join(f"{b}://" for b in backends if b != "inproc")
        raise InputError(f"--scheduler {address!r}: unknown protocol {scheme!r} (known: {known}); "
                         f"{_ADDRESS_FIX}")
    if not host or any(c.isspace() for c in address) or not 0 < int(port) < 65536:
        raise InputError(f"--scheduler {address!r} needs a host name and a port from 1 to "
                         f"65535; {_ADDRESS_FIX}")
