"""Run a test end to end as one transaction: fit, report, store (``inertest fit``, ``batch``).

:func:`run` does what ``inertest fit`` does, from Python: identify the coefficients, render the
report into a temporary folder, check the history database for the same data filed twice, store
the run, and only then move the report into place. A failure at any step leaves nothing behind:
no stored run, no report, no half-written folder. :func:`run_batch` does it for many (plan, data)
pairs, computing on any ``concurrent.futures``-style executor (a process pool, a
``dask.distributed.Client``) while this process files every run, one transaction each.

Example
-------
>>> import inertest
>>> out = inertest.run("plan.toml", "data.csv", store="history.db", report_dir="report")
...                                                                   # doctest: +SKIP
>>> out.result.coefficients["DI"], out.stored_run, out.report               # doctest: +SKIP
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import os
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inertest.api import fit, load_data, load_plan
from inertest.errors import InertestError, PlanError, error_message
from inertest.io.atomic import check_outputs, target_directory
from inertest.io.data_file import file_sha256
from inertest.io.plan_file import read_toml
from inertest.lab import (
    Equipment,
    identity_block,
    overdue_messages,
    read_equipment,
    select_equipment,
    unchecked_equipment_message,
)
from inertest.plan import Plan, did_you_mean
from inertest.results import with_blocks

if TYPE_CHECKING:
    from inertest.budget import UncertaintyBudget
    from inertest.conformance import Conformance, Spec
    from inertest.store import HistoryStore

PathLike = str | os.PathLike[str]


class DuplicateRunError(InertestError):
    """The same data file is already filed for this instrument and procedure."""


@dataclass(frozen=True)
class RunOutcome:
    """What :func:`run` did.

    Attributes
    ----------
    result : procedure result
        With ``kind``, ``identification`` and ``to_dict()`` (the result envelope).
    plan : Plan
    data_sha256 : str
        SHA-256 of the data file (or of the columns, for in-memory data).
    tested_at : datetime
        When the test was run (UTC).
    stored_run : str or None
        UUID of the stored run; None when not stored.
    database : str or None
        The database it was stored in (password masked).
    report : Path or None
        The report's ``index.html``.
    warnings : tuple of str
        Warnings raised while fitting, and the filing's own (also shown by the command line).
    notices : tuple of str
        The filing's own warnings, also in the envelope's ``messages``: overdue equipment
        calibrations, equipment named without a lab file.
    test : dict or None
        The envelope's ``test`` block (:func:`inertest.lab.identity_block`): operator, date,
        equipment with calibration status, environment, software version, data SHA-256.
    budget : UncertaintyBudget or None
        Type A and Type B per quantity (:func:`inertest.budget.uncertainty_budget`), when a lab
        file or a specification was given.
    conformance : Conformance or None
        Verdicts against the specification (:func:`inertest.conformance.verdicts`).
    """

    result: Any
    plan: Plan
    data_sha256: str
    tested_at: datetime
    stored_run: str | None = None
    database: str | None = None
    report: Path | None = None
    warnings: tuple[str, ...] = field(default=())
    test: dict[str, Any] | None = None
    budget: UncertaintyBudget | None = None
    conformance: Conformance | None = None
    notices: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict[str, object]:
        """The result envelope with its ``test``, budget and conformance blocks (``--json``)."""
        return _with_notices(with_blocks(
            self.result.to_dict(), test=self.test,
            uncertainty_budget=None if self.budget is None else self.budget.to_dict(),
            conformance=None if self.conformance is None else self.conformance.to_dict()),
            self.notices)


def _with_notices(doc: dict[str, object], notices: Sequence[str]) -> dict[str, object]:
    """``doc`` with ``notices`` appended to its ``messages`` (each once)."""
    if not notices:
        return doc
    found = doc.get("messages")
    messages = [str(m) for m in found] if isinstance(found, list) else []
    doc["messages"] = messages + [m for m in notices if m not in messages]
    return doc


def run(
    plan: Plan | PathLike,
    data: Mapping[str, Any] | PathLike,
    *,
    sigma: float | None = None,
    store: bool | str | HistoryStore = False,
    report_dir: PathLike | None = None,
    pdf: bool = False,
    tested_at: datetime | None = None,
    allow_duplicate: bool = False,
    equipment: PathLike | Mapping[str, Equipment] | None = None,
    spec: PathLike | Spec | None = None,
    noise_model: str | None = None,
) -> RunOutcome:
    """Fit, report and store one test as a single transaction (``inertest fit``).

    Parameters
    ----------
    plan : Plan or path
        The test plan (TOML file or :class:`~inertest.plan.Plan`).
    data : mapping of columns, or path
        The measurements (CSV, Parquet or HDF5 file, or ``{column: array}``).
    sigma : float, optional
        Known noise per reading [output unit]; estimated from the residuals when omitted.
    store : bool, str or HistoryStore
        False: do not store. True: the default database (``$INERTEST_DB`` or
        ``~/.local/share/inertest/history.db``). A URL or path, or an open
        :class:`~inertest.store.HistoryStore`.
    report_dir : path, optional
        Folder for the self-contained HTML report: a new folder, an empty one or an earlier
        inertest report; never one holding other files or an input.
    pdf : bool
        Also write ``report.pdf`` (needs Chromium).
    tested_at : datetime, optional
        When the test was run (default: now); naive datetimes are UTC.
    allow_duplicate : bool
        File a data file again that is already stored for this instrument and procedure.
    equipment : path or mapping, optional
        The lab equipment file (:func:`inertest.lab.read_equipment`) or its records: the plan's
        ``[test] equipment`` ids are resolved against it (an unknown id is an error naming both
        files) and an overdue calibration on the test date becomes a warning. With it, the
        uncertainty budget is computed: Type A of the fit, and Type B of each item's ``type_b``
        entries and of the site gravity, propagated through the procedure's model
        (:func:`inertest.budget.uncertainty_budget`, JCGM 100:2008 GUM 5.1).
    spec : path or Spec, optional
        An instrument specification (:func:`inertest.conformance.read_spec`, see
        ``examples/specs``): the budget is computed (gravity only without a lab file) and each
        limited quantity gets a verdict under the spec's ILAC-G8 decision rule, its guard band
        the budget's expanded uncertainty U. Budget and verdicts go into the envelope (JSON,
        stored run) and the report.
    noise_model : str, optional
        Overrides the plan's ``[procedure] noise_model`` (:func:`inertest.api.fit`).

    Returns
    -------
    RunOutcome

    Raises
    ------
    InertestError
        Bad plan or data, an unsafe report folder, a duplicate run, or an unusable database;
        nothing was stored or written.
    """
    plan_path = None if isinstance(plan, Plan) else Path(plan)
    data_path = None if isinstance(data, Mapping) else Path(data)
    if report_dir is not None:
        check_outputs([report_dir], [p for p in (plan_path, data_path) if p is not None])
    if pdf and report_dir is None:
        raise PlanError("a PDF is part of the report: give report_dir as well")
    p = plan if isinstance(plan, Plan) else load_plan(plan)
    lab, lab_source = _lab(equipment)
    used: tuple[Equipment, ...] = ()
    if lab is not None and p.test is not None:  # an unknown id fails before any work
        used = select_equipment(lab, p.test.equipment, plan_source=_source("plan", plan_path),
                                lab_source=lab_source)
    spec_doc = _spec(spec)
    d = data if isinstance(data, Mapping) else load_data(data)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fit(p, d, sigma=sigma, noise_model=noise_model)
    messages = tuple(str(w.message) for w in caught)
    budget, conformance = (judge(p, result, used, spec_doc)
                           if lab is not None or spec_doc is not None else (None, None))
    when = _utc(tested_at) if tested_at is not None else datetime.now(UTC)
    digest = file_sha256(data_path) if data_path is not None else columns_sha256(d)
    plan_text = plan_path.read_text(encoding="utf-8") if plan_path is not None else repr(p)
    return file_run(
        result, p, plan_text=plan_text, data_sha256=digest, data_summary=_data_summary(
            data_path, d, digest), tested_at=when, store=store, report_dir=report_dir, pdf=pdf,
        allow_duplicate=allow_duplicate, warnings_=messages,
        inputs=[x for x in (plan_path, data_path) if x is not None], lab=lab,
        lab_source=lab_source, plan_source=_source("plan", plan_path), budget=budget,
        conformance=conformance)


def judge(plan: Plan, result: Any, equipment: Sequence[Equipment], spec: Spec | None
          ) -> tuple[UncertaintyBudget, Conformance | None]:
    """The result's uncertainty budget and, with a spec, its verdicts (budget's U as guard band).

    Raises
    ------
    SpecError
        A limited quantity that is no quantity of the procedure (one of its model the test
        does not determine is judged "not determined"), or a limit unit that cannot express
        it; raised before anything is written.
    """
    from inertest.budget import uncertainty_budget
    from inertest.conformance import model_names, verdicts

    if spec is not None:  # a misnamed quantity fails before the budget's simulations
        spec.check_quantities(_quantity_names(result), model_names(result),
                              kind=getattr(result, "kind", "the result"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the budget's noise-free refits warn about nothing real
        budget = uncertainty_budget(plan, result, equipment)
    return budget, None if spec is None else verdicts(result, spec, budget)


def _quantity_names(result: Any) -> list[str]:
    return [*result.coefficients, *(c.name for c in result.combinations)]


def _spec(spec: PathLike | Spec | None) -> Spec | None:
    if spec is None:
        return None
    from inertest.conformance import Spec, read_spec

    return spec if isinstance(spec, Spec) else read_spec(spec)


def _source(what: str, path: Path | None) -> str:
    return f"{what} {path}" if path is not None else f"the {what}"


def _lab(equipment: PathLike | Mapping[str, Equipment] | None
         ) -> tuple[Mapping[str, Equipment] | None, str]:
    """The lab's equipment records and how to name their file in messages."""
    if equipment is None:
        return None, "the lab file"
    if isinstance(equipment, Mapping):
        return equipment, "the lab equipment records"
    return read_equipment(equipment), f"lab file {equipment}"


def file_run(
    result: Any,
    plan: Plan,
    *,
    plan_text: str,
    data_sha256: str,
    data_summary: Mapping[str, object],
    tested_at: datetime,
    store: bool | str | HistoryStore = False,
    report_dir: PathLike | None = None,
    pdf: bool = False,
    allow_duplicate: bool = False,
    warnings_: Sequence[str] = (),
    inputs: Sequence[PathLike] = (),
    lab: Mapping[str, Equipment] | None = None,
    lab_source: str = "the lab file",
    plan_source: str = "the plan",
    budget: UncertaintyBudget | None = None,
    conformance: Conformance | None = None,
) -> RunOutcome:
    """Report and store an already computed result, as one transaction (see :func:`run`).

    ``budget`` and ``conformance`` (from :func:`judge`) go into the stored envelope and the
    report.
    """
    if store is not False and store is not None:  # SQLAlchemy, Alembic: only when storing
        from inertest.store import HistoryStore, RunRecord, StoreError

    version = metadata.version("inertest")
    test = identity_block(plan.test, lab=lab, tested_at=tested_at, software_version=version,
                          data_sha256=data_sha256, plan_source=plan_source,
                          lab_source=lab_source)
    used = [lab[i] for i in plan.test.equipment] if lab is not None and plan.test else []
    notices = overdue_messages(used, _dt.date.fromisoformat(str(test["date"])))
    if lab is None and plan.test is not None and plan.test.equipment:
        notices.append(unchecked_equipment_message(plan.test.equipment))
    warnings_ = [*warnings_, *notices]
    envelope_doc = _with_notices(with_blocks(
        result.to_dict(), test=test,
        uncertainty_budget=None if budget is None else budget.to_dict(),
        conformance=None if conformance is None else conformance.to_dict()), notices)
    own_store = store is True or isinstance(store, str)
    db: HistoryStore | None
    if store is False or store is None:
        db = None
    elif isinstance(store, HistoryStore):
        db = store
    else:
        db = HistoryStore(None if store is True else str(store))
    try:
        record = None
        if db is not None:
            record = RunRecord.from_result(
                envelope_doc, serial=plan.instrument.serial,
                instrument_kind=plan.instrument.kind, plan_text=plan_text,
                data_sha256=data_sha256, software_version=version, tested_at=tested_at)
            if not allow_duplicate:
                earlier = db.runs_with_data(plan.instrument.serial, result.kind, data_sha256)
                if earlier:
                    raise DuplicateRunError(
                        f"this data file (sha256 {data_sha256[:12]}...) is already filed for "
                        f"{plan.instrument.serial} / {result.kind} (run {earlier[0]}); nothing "
                        "stored. Use --allow-duplicate to file it again, or --no-store")
        report_path = None
        if report_dir is not None:
            history: list = []
            if db is not None and record is not None:
                from inertest.store.summary import summarize_runs

                try:
                    earlier_runs = db.runs(plan.instrument.serial, procedure=result.kind)
                except StoreError:
                    earlier_runs = []
                history = summarize_runs(sorted([*earlier_runs, record],
                                                key=lambda r: r.tested_at))
            html = _report_html(result, plan, plan_text, data_summary, tested_at, version,
                                history, test, envelope_doc)
            added = False
            try:
                with target_directory(report_dir, inputs=inputs) as tmp:
                    (tmp / "index.html").write_text(html, encoding="utf-8")
                    if pdf:
                        from inertest.report.pdf import html_to_pdf

                        html_to_pdf(tmp / "index.html", tmp / "report.pdf")
                    # Store last inside the block: a failed store leaves no report, and a
                    # failed report leaves no stored run.
                    if db is not None and record is not None:
                        db.add(record)
                        added = True
            except BaseException:
                if added:  # moving the report into place failed (full disk): withdraw the run
                    db.discard(record.run_uuid)  # type: ignore[union-attr]
                raise
            report_path = Path(report_dir) / "index.html"
        elif db is not None and record is not None:
            db.add(record)
        return RunOutcome(
            result=result, plan=plan, data_sha256=data_sha256, tested_at=tested_at,
            stored_run=None if record is None else record.run_uuid,
            database=None if db is None else db.display_url, report=report_path,
            warnings=tuple(warnings_), test=test, budget=budget, conformance=conformance,
            notices=tuple(notices))
    finally:
        if db is not None and own_store:
            db.close()


def _report_html(result: Any, plan: Plan, plan_text: str, data_summary: Mapping[str, object],
                 tested_at: datetime, version: str, history: list,
                 test: Mapping[str, Any] | None = None,
                 doc: Mapping[str, Any] | None = None) -> str:
    from inertest.report.campaign import campaign_page

    inst = plan.instrument
    return campaign_page(
        result,
        instrument={"serial": inst.serial or "-", "kind": inst.kind,
                    "output unit": inst.output_unit, "scale factor": inst.scale_factor or "-"},
        site={"latitude [deg]": f"{plan.site.latitude_deg:.6f}",
              "gravity [m/s^2]": f"{plan.site.gravity_m_s2:.7f}"},
        plan_text=plan_text, data=data_summary, tested_at=tested_at,
        software_version=version, history=history, test=test,
        uncertainty_budget=None if doc is None else doc.get("uncertainty_budget"),
        conformance=None if doc is None else doc.get("conformance"))


def _data_summary(path: Path | None, data: Mapping[str, Any], digest: str) -> dict[str, object]:
    n = len(next(iter(data.values()))) if data else 0
    return {"file": str(path) if path is not None else "(in memory)", "rows": n,
            "columns": ", ".join(map(str, data)), "sha256": digest}


def columns_sha256(data: Mapping[str, Any]) -> str:
    """SHA-256 over the column names and values of in-memory data (stable across runs)."""
    import numpy as np

    h = hashlib.sha256()
    for name in sorted(data):
        a = np.asarray(data[name])
        h.update(name.encode("utf-8") + b"\0" + str(a.dtype).encode() + b"\0")
        h.update(a.astype(str).tobytes() if a.dtype.kind in "OUS" else a.tobytes())
    return h.hexdigest()


def _utc(t: datetime) -> datetime:
    return t.replace(tzinfo=UTC) if t.tzinfo is None else t.astimezone(UTC)


# --- many runs -------------------------------------------------------------------------------


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
        _spec(spec)
    for lab in sorted({t.equipment for t in todo if t.equipment is not None}):
        _lab(lab)


def _compute(task: BatchTask) -> tuple[Any, ...]:
    """Worker side of a batch task: read, fit and judge (no database, no report)."""
    p = load_plan(task.plan)
    lab, lab_source = _lab(task.equipment)
    used: tuple[Equipment, ...] = ()
    if lab is not None and p.test is not None:
        used = select_equipment(lab, p.test.equipment, plan_source=_source("plan", task.plan),
                                lab_source=lab_source)
    spec_doc = _spec(task.spec)
    d = load_data(task.data)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fit(p, d, sigma=task.sigma)
    budget, conformance = (judge(p, result, used, spec_doc)
                           if lab is not None or spec_doc is not None else (None, None))
    digest = file_sha256(task.data)
    return (result, p, task.plan.read_text(encoding="utf-8"), digest,
            tuple(str(w.message) for w in caught), _data_summary(task.data, d, digest),
            lab, lab_source, budget, conformance)


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
        however long the manifest); default twice the executor's worker count, at least 4.
    timeout : float, optional
        Longest a fit may take [s], counted from when every earlier run is filed (the run is
        then at the head of the queue); a run over it fails and its worker is stopped (a
        process pool is restarted; on Dask the future is cancelled). Default: no limit. With
        a timeout and no ``executor`` the fits run in a pool even for ``workers=1``.

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
    own = executor is None and (timeout is not None or (workers > 1 and len(todo) > 1))
    return _file_all(todo, local_pool(min(workers, len(todo))) if own else executor,
                     store=store, allow_duplicate=allow_duplicate, tested_at=tested_at,
                     progress=progress, max_pending=max_pending, timeout=timeout, own=own)


def local_pool(workers: int) -> Any:
    """A process pool of ``min(workers, cpu count)`` processes, safe in a threaded program.

    Workers start from a fork server (a clean single-threaded process that has imported
    inertest) where the platform has one, so a caller running threads (a Dask client, a GUI, a
    database driver) cannot deadlock them; elsewhere the platform's default start method. Each
    worker runs its BLAS single-threaded, as Dask's workers do: the parallelism is across fits,
    and n workers x n BLAS threads would oversubscribe the cores (about 2x slower on 2 cores).
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    n = max(1, min(workers, os.cpu_count() or 1))
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["inertest.runner"])
        return ProcessPoolExecutor(max_workers=n, mp_context=ctx,
                                   initializer=_single_threaded_blas)
    return ProcessPoolExecutor(max_workers=n, initializer=_single_threaded_blas)


def _single_threaded_blas() -> None:
    """Pool-worker initialiser: one BLAS/OpenMP thread (threadpoolctl, via scikit-learn)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - scikit-learn brings it
        return
    threadpool_limits(1)


WORKER_DIED = "worker process died (killed or out of memory)"
_POLL_S = 0.5  # how often the driver looks at a pool while it waits for a fit [s]
_MAX_BREAKS_IN_A_ROW = 3  # pool restarts with no fit finished in between, then give up


class _RunStoppedError(InertestError):
    """A run the batch stopped or lost: its worker died, it timed out, or it was never run."""


def _file_all(todo: Sequence[BatchTask], executor: Any, *, store: bool | str | HistoryStore,
              allow_duplicate: bool, tested_at: datetime | None,
              progress: Callable[[BatchItem], None] | None, max_pending: int | None,
              timeout: float | None = None, own: bool = False) -> list[BatchItem]:
    """Submit the fits through a sliding window and file each result in task order."""
    from inertest.store import HistoryStore

    window = max_pending or max(4, 2 * _slots(executor))
    fits = _Fits(todo, executor, own=own, timeout=timeout)
    own_db = store is True or isinstance(store, str)
    db: Any = None
    when = _utc(tested_at) if tested_at is not None else datetime.now(UTC)
    out: list[BatchItem] = []
    try:
        db = HistoryStore(None if store is True else str(store)) if own_db else store
        for k, t in enumerate(todo):
            fits.submit_up_to(k + window)
            try:
                (result, p, plan_text, digest, msgs, summary, lab, lab_source, budget,
                 conformance) = fits.collect(k)
                outcome = file_run(
                    result, p, plan_text=plan_text, data_sha256=digest, data_summary=summary,
                    tested_at=when, store=db if db else False, report_dir=t.report_dir,
                    allow_duplicate=allow_duplicate, warnings_=msgs,
                    inputs=[x for x in (t.plan, t.data, t.spec, t.equipment) if x is not None],
                    lab=lab, lab_source=lab_source, plan_source=_source("plan", t.plan),
                    budget=budget, conformance=conformance)
                item = BatchItem(t, outcome, None)
            except (InertestError, OSError) as exc:
                item = BatchItem(t, None, error_message(exc))
            out.append(item)
            if progress is not None:
                progress(item)
    finally:
        fits.close()
        if own_db and db:
            db.close()
    return out


class _Fits:
    """The batch's fits on an executor: submitted in a window, collected in task order.

    A process pool that breaks (a worker killed, out of memory, or gone without a word) is
    restarted with the same settings; the fits that were in flight are run again one at a time,
    and the one that kills its worker alone fails with :data:`WORKER_DIED` (never retried
    again). After ``_MAX_BREAKS_IN_A_ROW`` restarts with no fit finished in between the pool is
    given up and the runs not yet done fail. The driver never waits on a future without a
    timeout: every ``_POLL_S`` it checks the pool's health and the run's ``timeout``.
    """

    def __init__(self, todo: Sequence[BatchTask], executor: Any, *, own: bool,
                 timeout: float | None) -> None:
        self.todo, self.executor, self.timeout = todo, executor, timeout
        self.owned: list[Any] = [executor] if own and executor is not None else []
        self.pending: dict[int, Any] = {}
        self.ready: dict[int, Any] = {}  # results (or _RunStoppedError) of runs collected early
        self.submitted = 0
        self.breaks_in_a_row = 0
        self.gave_up: str | None = None

    # -- submitting -----------------------------------------------------------------------

    def _submit(self, k: int) -> Any:
        task = self.todo[k]
        if self.executor is None:
            return _Immediate(_compute, task)
        try:
            return self.executor.submit(_compute, task)
        except Exception as exc:  # noqa: BLE001 - a pool that broke since: handled on collect
            if not _is_broken_pool(exc):
                raise
            from concurrent.futures import Future

            fut: Future[Any] = Future()
            fut.set_exception(exc)
            return fut

    def submit_up_to(self, n: int) -> None:
        while self.submitted < min(n, len(self.todo)) and self.gave_up is None:
            self.pending[self.submitted] = self._submit(self.submitted)
            self.submitted += 1

    # -- collecting -----------------------------------------------------------------------

    def collect(self, k: int) -> tuple[Any, ...]:
        """Run ``k``'s computed tuple; raises its error, or :class:`_RunStoppedError`."""
        if k not in self.ready and k not in self.pending:
            raise _RunStoppedError(self.gave_up or "not run")
        if k not in self.ready:
            self.ready[k] = self._wait(k)
        got = self.ready.pop(k)
        if isinstance(got, BaseException):
            raise got
        return got  # type: ignore[no-any-return]

    def _wait(self, k: int) -> Any:
        """Wait for run ``k`` (pending): its tuple or its exception, never forever."""
        fut = self.pending[k]
        if self.executor is None:  # serial: computed here and now
            del self.pending[k]
            try:
                return fut.result()
            except (InertestError, OSError) as exc:
                return exc
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        while True:
            try:
                value = fut.result(timeout=_POLL_S)
            except TimeoutError:
                if fut.done():  # the computation's own TimeoutError (an OSError): its error
                    del self.pending[k]
                    return fut.exception()
                if _pool_broken(self.executor):
                    return self._broken(k)
                if deadline is not None and time.monotonic() > deadline:
                    return self._timed_out(k)
                continue
            except Exception as exc:  # noqa: BLE001 - sorted below; the unknown re-raised
                if _is_broken_pool(exc):
                    return self._broken(k)
                del self.pending[k]
                lost = _worker_lost(exc)
                if lost is not None:
                    self.breaks_in_a_row = 0
                    return _RunStoppedError(lost)
                if isinstance(exc, InertestError | OSError):
                    self.breaks_in_a_row = 0
                    return exc
                raise
            del self.pending[k]
            self.breaks_in_a_row = 0
            return value

    def _timed_out(self, k: int) -> _RunStoppedError:
        fut = self.pending.pop(k)
        stopped = _RunStoppedError(f"fit took longer than the {self.timeout:g} s timeout; stopped")
        if self._restartable():  # the only way to stop a fit in a pool worker: end the worker
            innocent = sorted(i for i, f in self.pending.items() if not _finished(f))
            for i in innocent:
                del self.pending[i]
            self._restart()
            for i in innocent:
                self.pending[i] = self._submit(i)
        else:
            fut.cancel()
        return stopped

    def _broken(self, k: int) -> Any:
        """The pool died under run ``k`` (or another): rerun the suspects alone, return ``k``'s."""
        suspects = sorted(i for i, f in self.pending.items() if not _finished(f))
        for i in suspects:
            del self.pending[i]
        self.breaks_in_a_row += 1
        while suspects:
            if self.breaks_in_a_row > _MAX_BREAKS_IN_A_ROW:
                self.gave_up = (f"not run: the worker pool broke {self.breaks_in_a_row - 1} "
                                f"times in a row without finishing a fit ({WORKER_DIED})")
                for i in suspects:
                    self.ready[i] = _RunStoppedError(self.gave_up)
                break
            if _pool_broken(self.executor):
                self._restart()
            i = suspects.pop(0)
            self.pending[i] = self._submit(i)
            got = self._wait_alone(i)
            self.ready[i] = got
        return self.ready.pop(k)

    def _wait_alone(self, i: int) -> Any:
        """Run ``i`` as the only fit on a fresh pool: if the pool breaks, ``i`` broke it."""
        fut = self.pending[i]
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        while not _finished(fut) and not _pool_broken(self.executor):
            if deadline is not None and time.monotonic() > deadline:
                return self._timed_out(i)
            try:
                fut.result(timeout=_POLL_S)
            except Exception:  # noqa: BLE001, S110 - read below, once finished
                pass
        if _finished(fut):
            return self._wait(i)
        del self.pending[i]
        self.breaks_in_a_row += 1  # a restart that found its culprit; the next run resets it
        return _RunStoppedError(WORKER_DIED)

    # -- the pool ---------------------------------------------------------------------------

    def _restartable(self) -> bool:
        from concurrent.futures import ProcessPoolExecutor

        return isinstance(self.executor, ProcessPoolExecutor)

    def _restart(self) -> None:
        """End the current process pool's workers and start one with the same settings."""
        old = self.executor
        _end_pool(old)
        new = _same_pool(old)
        self.owned.append(new)
        self.executor = new

    def close(self) -> None:
        for fut in self.pending.values():
            cancel = getattr(fut, "cancel", None)
            if cancel is not None:
                cancel()
        for pool in self.owned:
            if _pool_broken(pool):
                _end_pool(pool)
            else:
                pool.shutdown(wait=True, cancel_futures=True)


def _finished(fut: Any) -> bool:
    """Done, with a result or the computation's own error (a broken pool is not finished)."""
    if not fut.done():
        return False
    if fut.cancelled():
        return True
    return not _is_broken_pool(fut.exception())


def _is_broken_pool(exc: BaseException | None) -> bool:
    from concurrent.futures.process import BrokenProcessPool

    return isinstance(exc, BrokenProcessPool)


def _worker_lost(exc: BaseException) -> str | None:
    """Why a Dask worker lost under the run (KilledWorker) or a cancelled future failed it."""
    from concurrent.futures import CancelledError

    if isinstance(exc, CancelledError):
        return "cancelled on the executor (its worker or the scheduler was lost)"
    distributed = sys.modules.get("distributed")
    killed = getattr(distributed, "KilledWorker", None)
    if killed is not None and isinstance(exc, killed):
        tries = getattr(exc, "allowed_failures", None)
        return (f"{WORKER_DIED}, on {tries + 1} Dask workers in turn" if isinstance(tries, int)
                else f"{WORKER_DIED}, on Dask")
    return None


def _pool_broken(executor: Any) -> bool:
    """A process pool that broke, or one of whose workers has exited (not yet noticed)."""
    from concurrent.futures import ProcessPoolExecutor

    if not isinstance(executor, ProcessPoolExecutor):
        return False
    if getattr(executor, "_broken", False):
        return True
    processes = getattr(executor, "_processes", None) or {}
    return any(p.exitcode is not None for p in list(processes.values()))


def _end_pool(pool: Any) -> None:
    """Kill a process pool's workers and shut it down without waiting on them.

    A worker killed while it wrote its result leaves half a message in the result pipe; the
    pool's manager thread then reads forever (this process holds the pipe's write end too), and
    the interpreter hangs at exit joining it (CPython 3.11). With every worker dead nothing
    writes there any more: closing our write end turns the wait into end-of-file, and the
    manager thread ends as for any broken pool.
    """
    processes = list((getattr(pool, "_processes", None) or {}).values())
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)  # gone on shutdown
    for p in processes:
        if p.exitcode is None:
            p.kill()
    for p in processes:
        p.join(timeout=5)
    pool.shutdown(wait=False, cancel_futures=True)
    if writer is not None and all(p.exitcode is not None for p in processes):
        writer.close()


def _same_pool(old: Any) -> Any:
    """A new process pool with ``old``'s size, start method and initializer."""
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(max_workers=old._max_workers, mp_context=old._mp_context,
                               initializer=old._initializer, initargs=old._initargs)


def _slots(executor: Any) -> int:
    """Worker slots of a process pool or a Dask client (1 when unknown or serial)."""
    if executor is None:
        return 1
    n = getattr(executor, "_max_workers", None)
    if isinstance(n, int) and n > 0:
        return n
    nthreads = getattr(executor, "nthreads", None)
    if callable(nthreads):  # dask.distributed.Client: {worker address: threads}
        return max(1, sum(nthreads().values()))
    return 4


class _Immediate:
    """A future computed on demand (serial batches)."""

    def __init__(self, fn: Any, *args: Any) -> None:
        self._fn, self._args = fn, args

    def result(self, timeout: float | None = None) -> Any:
        return self._fn(*self._args)

    def cancel(self) -> bool:
        return False
