"""Many runs of tests: a manifest, fits on an executor, each run filed as its own transaction.

:func:`run_batch` computes the fits on any ``concurrent.futures``-style executor (a process pool,
a ``dask.distributed.Client``) while this process files every run, one transaction each
(:func:`inertest.app.run.file_run`), in manifest order; the submission window keeps memory
bounded however long the manifest. The executor's plumbing (restarting a broken pool, a lost
Dask worker, timeouts) is in :mod:`inertest.app.executors`.
"""

from __future__ import annotations

import functools
import os
import tempfile
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inertest.api import fit, load_data, load_plan
from inertest.app.executors import Fits, local_pool, slots, unit_sizes, wait_for_a_worker
from inertest.app.run import (
    PathLike,
    PreparedRun,
    RunOutcome,
    data_summary,
    file_prepared,
    judge,
    lab_of,
    prepare_run,
    source_name,
    spec_of,
)
from inertest.errors import DataError, InertestError, PlanError, error_message
from inertest.io.atomic import check_outputs
from inertest.io.data_file import file_sha256
from inertest.io.plan_file import read_toml
from inertest.plan import did_you_mean
from inertest.quality.lab import (
    Equipment,
    read_laboratory,
    read_signatories,
    select_equipment,
)

if TYPE_CHECKING:
    from inertest.store import HistoryStore


@dataclass(frozen=True)
class BatchTask:
    """One (plan, data) pair of a batch, with its options.

    ``spec`` and ``equipment`` (files, as ``inertest fit --spec --equipment``) are read and
    applied where the fit runs, so the filed run carries its uncertainty budget and verdicts.
    """

    plan: Path
    data: Path
    sigma: float | None = None
    report_dir: Path | None = None
    spec: Path | None = None
    equipment: Path | None = None
    #: The input files' bytes, read by the process that submits the task (``ship_data``):
    #: the worker writes them to a temporary folder and reads them there.
    shipped: Mapping[str, bytes] | None = field(default=None, repr=False, compare=False)


_SHIPPED_ROLES = ("plan", "data", "spec", "equipment")
_UNREADABLE = "unreadable"  # a shipped task whose files could not be read: why


class _Shipped(Sequence[BatchTask]):
    """The tasks with their input files' bytes, read when each task is submitted.

    A cluster whose workers do not see this machine's files gets the files with the task; the
    bytes are read only for the tasks in the submission window, so memory stays bounded.
    """

    def __init__(self, tasks: Sequence[BatchTask]) -> None:
        self.tasks = tasks

    def __len__(self) -> int:
        return len(self.tasks)

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        t = self.tasks[k]
        files = {}
        for role in _SHIPPED_ROLES:
            path = getattr(t, role)
            if path is not None:  # a folder was refused before the batch began
                try:
                    files[role] = Path(path).read_bytes()
                except OSError as exc:  # this run fails (on the worker), not the batch
                    return replace(t, shipped={_UNREADABLE: error_message(exc).encode()})
        return replace(t, shipped=files)


@dataclass(frozen=True)
class BatchItem:
    """The outcome of one batch task: an outcome, or the one-line error that stopped it."""

    task: BatchTask
    outcome: RunOutcome | None
    error: str | None


_RUN_KEYS = ("plan", "data", "sigma", "report", "spec", "equipment")
_DEFAULT_KEYS = ("sigma", "spec", "equipment")
def read_manifest(path: PathLike) -> list[BatchTask]:
    """Read a batch manifest (TOML).

    ``[[run]]`` tables with ``plan``, ``data``, optional ``sigma``, ``report``, ``spec`` (an
    instrument specification: verdicts) and ``equipment`` (a lab equipment file: uncertainty
    budget); an optional ``[defaults]`` table gives ``sigma``, ``spec`` and ``equipment`` for
    every run that does not name its own. Paths are relative to the manifest's folder.
    """
    mpath = Path(path)
    doc = read_toml(mpath, "batch manifest")
    runs = doc.get("run")
    unknown = sorted(set(doc) - {"run", "defaults"})
    if unknown:
        raise PlanError(f"batch manifest {mpath}: unknown table(s) {', '.join(unknown)}"
                        f"{did_you_mean(unknown[0], ('run', 'defaults'))}; list the runs as "
                        "[[run]] tables (shared spec, equipment, sigma in [defaults])")
    if not isinstance(runs, list) or not runs:
        raise PlanError(f"batch manifest {mpath} lists no [[run]] tables with plan and data")
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, dict):
        raise PlanError(f"batch manifest {mpath}: defaults must be a table ([defaults])")
    _known_keys(defaults, _DEFAULT_KEYS, f"batch manifest {mpath}, [defaults]")
    tasks = []
    for k, r in enumerate(runs, start=1):
        where = f"batch manifest {mpath}, run {k}"
        if not isinstance(r, dict):
            raise PlanError(f"{where}: each run must be a [[run]] table with plan and data")
        _known_keys(r, _RUN_KEYS, where)
        if "plan" not in r or "data" not in r:
            raise PlanError(f"{where}: needs plan and data (optional sigma, report, spec, "
                            "equipment)")
        opts = {**defaults, **r}
        sigma = opts.get("sigma")
        if sigma is not None and (isinstance(sigma, bool) or not isinstance(sigma, int | float)):
            raise PlanError(f"{where}: sigma must be a number")

        def rel(key: str, opts: dict = opts, where: str = where) -> Path | None:
            v = opts.get(key)
            if v is None:
                return None
            if not isinstance(v, str) or not v:
                raise PlanError(f'{where}: {key} must be a file path (text), got {v!r}')
            return mpath.parent / v

        tasks.append(BatchTask(
            plan=rel("plan"), data=rel("data"),  # type: ignore[arg-type]
            sigma=None if sigma is None else float(sigma), report_dir=rel("report"),
            spec=rel("spec"), equipment=rel("equipment")))
    return tasks


def _known_keys(table: Mapping[str, Any], known: Sequence[str], where: str) -> None:
    extra = sorted(set(table) - set(known))
    if extra:
        raise PlanError(f"{where}: unknown key(s) {', '.join(extra)}"
                        f"{did_you_mean(extra[0], known)}; known: {', '.join(known)}")


def _check_judging_files(todo: Sequence[BatchTask]) -> None:
    """Read every spec and lab file the tasks name once, before any fit.

    A bad one stops the batch with nothing stored; the workers read them again where they run.
    """
    for spec in sorted({t.spec for t in todo if t.spec is not None}):
        spec_of(spec)
    for lab in sorted({t.equipment for t in todo if t.equipment is not None}):
        lab_of(lab)


@dataclass(frozen=True)
class BatchOptions:
    """What every task of a batch shares, sent to the workers with each task.

    ``store``: the runs will be stored (the worker makes each run's record); ``tested_at``:
    ``--tested-at``; ``full_results``: send every full result back (per-sample arrays
    included), not only the envelope; a run with a report always sends its full result.
    """

    store: bool = False
    tested_at: datetime | None = None
    full_results: bool = False


def _file_key(path: Path) -> tuple[str, int, int]:
    st = path.stat()
    return (os.fspath(path), st.st_mtime_ns, st.st_size)


def _cached(table: dict[Any, Any], key: Any, make: Callable[[], Any]) -> Any:
    """``make()`` once per key in this worker (a batch reads one plan for hundreds of runs)."""
    if key not in table:
        if len(table) >= 64:
            table.clear()
        table[key] = make()
    return table[key]


#: Most fits sent to a worker as one unit (one future).
_MAX_CHUNK = 16
_PLANS: dict[Any, Any] = {}
_LABS: dict[Any, Any] = {}
_SPECS: dict[Any, Any] = {}


def compute(task: BatchTask, options: BatchOptions = BatchOptions()) -> PreparedRun:
    """Worker side of a batch task: read, fit, judge and prepare the filing (no database).

    Plans, lab and spec files are read once per worker while unchanged on disk (path,
    modification time and size). What comes back is the run ready to file: its envelope,
    test block and record (already JSON text), and the full result only when the run draws a
    report or ``options.full_results`` asks for it. A task that brings its files' bytes
    (``shipped``) is read from a temporary copy; the results and messages name the original
    paths.
    """
    if task.shipped is None:
        return _compute(task, task, options)
    if _UNREADABLE in task.shipped:
        raise DataError(f"could not read the run's files to send them: "
                        f"{task.shipped[_UNREADABLE].decode()}")
    with tempfile.TemporaryDirectory(prefix="inertest-shipped-") as tmp:
        local: dict[str, Any] = {}
        for role, content in task.shipped.items():
            original = Path(getattr(task, role))
            local[role] = Path(tmp) / role / original.name
            local[role].parent.mkdir()
            local[role].write_bytes(content)
        try:
            return _compute(replace(task, shipped=None, **local), task, options)
        except (InertestError, OSError) as exc:  # name the user's files, not the copies
            text = str(exc)
            for role, path in local.items():
                text = text.replace(str(path), str(getattr(task, role)))
            if text == str(exc):
                raise
            raise InertestError(text) from None


def _compute(task: BatchTask, named: BatchTask, options: BatchOptions) -> PreparedRun:
    """:func:`compute` reading ``task``'s files and naming ``named``'s."""
    p, plan_text = _cached(_PLANS, _file_key(task.plan), lambda: (
        load_plan(task.plan), task.plan.read_text(encoding="utf-8")))
    lab = None if task.equipment is None else _cached(
        _LABS, _file_key(task.equipment), lambda: lab_of(task.equipment)[0])
    lab_source = lab_of(None)[1] if named.equipment is None else f"lab file {named.equipment}"
    signatories = None if task.equipment is None else _cached(
        _LABS, ("signatories", *_file_key(task.equipment)),
        lambda: read_signatories(task.equipment))  # type: ignore[arg-type]
    laboratory = None if task.equipment is None else _cached(
        _LABS, ("laboratory", *_file_key(task.equipment)),
        lambda: read_laboratory(task.equipment))  # type: ignore[arg-type]
    used: tuple[Equipment, ...] = ()
    if lab is not None and p.test is not None:
        used = select_equipment(lab, p.test.equipment, plan_source=source_name("plan", named.plan),
                                lab_source=lab_source)
    spec_doc = None if task.spec is None else _cached(
        _SPECS, _file_key(task.spec), lambda: spec_of(task.spec))
    d = load_data(task.data)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fit(p, d, sigma=task.sigma)
    budget, conformance = (judge(p, result, used, spec_doc)
                           if lab is not None or spec_doc is not None else (None, None))
    digest = file_sha256(task.data)
    prepared = prepare_run(
        result, p, plan_text=plan_text, data_sha256=digest,
        data_summary=data_summary(named.data, d, digest), tested_at=options.tested_at,
        for_store=options.store, warnings_=tuple(str(w.message) for w in caught), lab=lab,
        lab_source=lab_source, plan_source=source_name("plan", named.plan), budget=budget,
        conformance=conformance, signatories=signatories, laboratory=laboratory)
    if task.report_dir is not None or options.full_results:
        return prepared
    return prepared.compact()


def run_batch(
    tasks: PathLike | Iterable[BatchTask | tuple[PathLike, PathLike]],
    *,
    executor: Any = None,
    workers: int = 1,
    store: bool | str | HistoryStore = False,
    allow_duplicate: bool = False,
    tested_at: datetime | None = None,
    progress: Callable[[BatchItem], None] | None = None,
    max_pending: int | None = None,
    timeout: float | None = None,
    worker_wait: float = 60.0,
    full_results: bool = False,
    ship_data: bool = False,
) -> list[BatchItem]:
    """Run many tests: fits on ``executor``, then each filed here as its own transaction.

    Parameters
    ----------
    tasks : path of a manifest, or iterable of BatchTask or (plan, data) pairs
        What to run (:func:`read_manifest` for the manifest layout).
    executor : optional
        Anything with ``submit(fn, *args)`` returning futures with ``result()``:
        :class:`concurrent.futures.ProcessPoolExecutor`, ``dask.distributed.Client``. The fits
        (read plan and data, identify) run there; the returned results are filed here.
    workers : int
        Used when no ``executor`` is given: 1 runs the fits here, one after the other; more
        starts a local process pool of ``min(workers, cpu count)`` processes for this batch.
    store, allow_duplicate, tested_at
        As in :func:`run`; the database is written only by this process, one transaction per
        run, in task order.
    progress : callable, optional
        Called with each :class:`BatchItem` as soon as it is filed (for a progress bar).
    max_pending : int, optional
        Fits submitted ahead of the one being filed (memory stays bounded by this many results
        however long the manifest); default the fits of the first units sent, two per worker
        slot (a unit is several fits while many are left, one at the end), at least 4.
    timeout : float, optional
        Longest a fit may take [s], counted from when every earlier run is filed (the run is
        then at the head of the queue); a run over it fails and its worker is stopped (a
        process pool is restarted; on Dask the future is cancelled). Default: no limit. With
        a timeout and no ``executor`` the fits run in a pool even for ``workers=1``.
    worker_wait : float
        With a Dask client: the longest wait for a first worker before submitting [s]; an
        error naming the scheduler and the ``dask worker`` command when none joins. Also the
        longest the scheduler may be left without a worker during the batch (every worker
        lost): the runs not yet done then fail, saying so; those filed are kept.
    full_results : bool
        Each outcome's ``result`` is the procedure's full result (per-sample arrays
        included). By default a run without a report comes back as its envelope alone
        (:class:`inertest.results.EnvelopeResult`: ``kind``, ``coefficients``,
        ``combinations``, ``to_dict()``), which is what lets a batch scale with workers:
        the per-sample arrays of a long record are megabytes to send to this process.
    ship_data : bool
        Send each task's files (plan, data, spec, lab file) with it, read here when it is
        submitted: for a cluster whose workers do not share this machine's paths. By default
        the workers open the paths themselves.

    Returns
    -------
    list of BatchItem
        In task order; a task that failed carries its one-line error and stored nothing.

    Notes
    -----
    A run that fails does not stop the others, even when it takes its worker down. When a
    process pool breaks (a worker killed or out of memory), the pool is restarted with the
    same settings and the runs that were in flight are run again one at a time: one that
    kills its worker alone fails with "worker process died (killed or out of memory)" and is
    not tried again; the others are filed. After three restarts in a row with no fit finished
    the pool is given up and the runs not yet done fail. A Dask worker lost under a run
    (``KilledWorker``, after Dask's own retries) or a cancelled future fails that run only.
    While it waits, the driver checks the pool every 0.5 s, so a pool that broke without
    telling its futures is noticed rather than waited on forever.

    The results do not depend on where the fits ran: the same manifest gives bit-identical
    results serially, on a process pool and on a Dask cluster (``tests/test_dask_batch.py``).
    """
    if isinstance(tasks, str | os.PathLike):
        todo = read_manifest(tasks)
    else:
        todo = [t if isinstance(t, BatchTask) else BatchTask(Path(t[0]), Path(t[1]))
                for t in tasks]
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise PlanError(f"workers must be a whole number >= 1, got {workers!r}")
    if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, int | float)
                                or not timeout > 0):
        raise PlanError(f"timeout must be a number of seconds > 0, got {timeout!r}")
    if max_pending is not None and (isinstance(max_pending, bool)
                                    or not isinstance(max_pending, int) or max_pending < 1):
        raise PlanError(f"max_pending must be a whole number >= 1, got {max_pending!r}")
    for t in todo:
        if t.report_dir is not None:
            check_outputs([t.report_dir], [x for x in (t.plan, t.data, t.spec, t.equipment)
                                           if x is not None])
    _check_judging_files(todo)
    if ship_data:  # a folder cannot be shipped: say so before any run is filed
        for t in todo:
            for role in _SHIPPED_ROLES:
                path = getattr(t, role)
                if path is not None and Path(path).is_dir():
                    raise DataError(f"{role} {path} is a folder: --ship-data sends files; give "
                                    "the workers a shared path instead")
    wait_for_a_worker(executor, worker_wait)
    own = executor is None and (timeout is not None or (workers > 1 and len(todo) > 1))
    options = BatchOptions(store=store is not False and store is not None, tested_at=tested_at,
                           full_results=full_results)
    return _file_all(todo, local_pool(min(workers, len(todo))) if own else executor,
                     ship_data=ship_data,
                     store=store, allow_duplicate=allow_duplicate, options=options,
                     progress=progress, max_pending=max_pending, timeout=timeout, own=own,
                     worker_wait=worker_wait)


def _file_all(todo: Sequence[BatchTask], executor: Any, *, store: bool | str | HistoryStore,
              allow_duplicate: bool, options: BatchOptions,
              progress: Callable[[BatchItem], None] | None, max_pending: int | None,
              timeout: float | None = None, own: bool = False,
              ship_data: bool = False, worker_wait: float = 60.0) -> list[BatchItem]:
    """Submit the fits through a sliding window and file each result in task order."""
    from inertest.store import HistoryStore

    n = slots(executor)
    # Units of several fits while there are many per worker, single fits at the end (guided
    # self-scheduling): a future costs this process about 1 ms on a process pool (its
    # management thread, pipes and wake-ups) and more on Dask (its client's event loop), a
    # fit 30-60 ms on its worker. With fits replayed on 16 pool workers (benchmarks/
    # bench_batch.py), the 57 units of 320 fits take the same time as 146 units of a quarter
    # the size, and 0.22 instead of 0.37 ms of this process a fit.
    sizes = ([1] * len(todo) if executor is None else unit_sizes(
        len(todo), n, factor=1.0, most=_MAX_CHUNK))
    window = max_pending or max(4, sum(sizes[:2 * n]))
    fits = Fits(_Shipped(todo) if ship_data else todo, executor, own=own, timeout=timeout,
                fn=functools.partial(compute, options=options), chunk=sizes,
                worker_wait=worker_wait)
    own_db = store is True or isinstance(store, str)
    db: Any = None
    out: list[BatchItem] = []
    finished = False
    try:
        db = HistoryStore(None if store is True else str(store)) if own_db else store
        for k, t in enumerate(todo):
            fits.submit_up_to(k + window)
            try:
                prepared = fits.collect(k)
                outcome = file_prepared(
                    prepared, store=db if db else False, report_dir=t.report_dir,
                    allow_duplicate=allow_duplicate,
                    inputs=[x for x in (t.plan, t.data, t.spec, t.equipment) if x is not None])
                item = BatchItem(t, outcome, None)
            except (InertestError, OSError) as exc:
                item = BatchItem(t, None, error_message(exc))
            out.append(item)
            if progress is not None:
                progress(item)
        finished = True
    finally:
        fits.close(abort=not finished)
        if own_db and db:
            db.close()
    return out
