"""Run a test end to end as one transaction: fit, report, store (``inertest fit``).

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

import functools
import hashlib
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inertest.api import fit, load_data, load_plan
from inertest.errors import InertestError, PlanError
from inertest.io.atomic import check_outputs, target_directory
from inertest.io.data_file import file_sha256
from inertest.io.frames import is_frame
from inertest.plan import Instrument, Plan
from inertest.quality.lab import (
    Equipment,
    TestTime,
    identity_block,
    overdue_messages,
    read_equipment,
    read_laboratory,
    read_signatories,
    select_equipment,
    test_time,
    unchecked_equipment_message,
)
from inertest.report.html import report_id_of
from inertest.results import with_blocks

if TYPE_CHECKING:
    from inertest.quality.budget import UncertaintyBudget
    from inertest.quality.conformance import Conformance, Spec
    from inertest.store import HistoryStore

PathLike = str | os.PathLike[str]
class DuplicateRunError(InertestError):
    """The same data file is already filed for this instrument and procedure.

    ``str()`` speaks the Python API's language (``allow_duplicate=True``, ``store=False``);
    :attr:`cli_message` the command line's (``--allow-duplicate``, ``--no-store``).
    """

    def __init__(self, message: str, cli_message: str | None = None) -> None:
        super().__init__(message)
        self.cli_message = cli_message

    def __reduce__(self) -> tuple[type, tuple[str, str | None]]:  # pickled across processes
        return (type(self), (str(self), self.cli_message))


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
        When the test was performed (UTC): ``--tested-at``, else the plan's ``[test] date``,
        else the time of the analysis (:func:`inertest.quality.lab.test_time`).
    filed_at : datetime or None
        When the run was stored (UTC); None when it was not.
    report_id : str or None
        The report's id (certificate number, run id or derived; None without a report).
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
        The envelope's ``test`` block (:func:`inertest.quality.lab.identity_block`): operator, date,
        equipment with calibration status, environment, software version, data SHA-256.
    budget : UncertaintyBudget or None
        Type A and Type B per quantity (:func:`inertest.quality.budget.uncertainty_budget`),
        when a lab file or a specification was given.
    conformance : Conformance or None
        Verdicts against the specification (:func:`inertest.quality.conformance.verdicts`).
    """

    result: Any
    plan: Plan | None
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
    filed_at: datetime | None = None
    report_id: str | None = None

    def to_pandas(self) -> object:
        """The result's coefficients and combinations as a ``pandas.DataFrame``."""
        return self.result.to_pandas()

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
    data: Any,
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
    command: str | None = None,
    topic: str | None = None,
    layout: PathLike | None = None,
) -> RunOutcome:
    """Fit, report and store one test as a single transaction (``inertest fit``).

    Parameters
    ----------
    plan : Plan or path
        The test plan (TOML file or :class:`~inertest.plan.Plan`).
    data : path, pandas.DataFrame, pyarrow.Table or mapping of arrays
        The measurements: any file :func:`inertest.load_data` reads (CSV, Parquet, HDF5, ROS
        bag, MCAP, ULog, TDMS, text, binary with ``layout``) or a table in memory.
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
        When the test was performed (``--tested-at``; a naive time is UTC). It overrides the
        plan's ``[test] date`` (a notice says so); without either, the time of the analysis.
        The one test date is used for the record, the report, the equipment's calibration
        status and the history axis (:func:`inertest.quality.lab.test_time`).
    allow_duplicate : bool
        File a data file again that is already stored for this instrument and procedure.
    equipment : path or mapping, optional
        The lab equipment file (:func:`inertest.quality.lab.read_equipment`) or its records:
        the plan's ``[test] equipment`` ids are resolved against it (an unknown id is an error
        naming both files) and an overdue calibration on the test date becomes a warning. With
        it, the uncertainty budget is computed: Type A of the fit, and Type B of each item's
        ``type_b`` entries and of the site gravity, propagated through the procedure's model
        (:func:`inertest.quality.budget.uncertainty_budget`, JCGM 100:2008 GUM 5.1).
    spec : path or Spec, optional
        An instrument specification (:func:`inertest.quality.conformance.read_spec`, see
        ``examples/specs``): the budget is computed (gravity only without a lab file) and each
        limited quantity gets a verdict under the spec's ILAC-G8 decision rule, its guard band
        the budget's expanded uncertainty U. Budget and verdicts go into the envelope (JSON,
        stored run) and the report.
    noise_model : str, optional
        Overrides the plan's ``[procedure] noise_model`` (:func:`inertest.api.fit`).
    command : str, optional
        The command line that ran this (``inertest fit ...``), stated in the report beside each
        input file's path and SHA-256, so that the report can be reproduced from itself.
    topic, layout : optional
        For recordings: the ROS topic / ULog message / TDMS group, and a binary file's TOML
        record layout (:func:`inertest.load_data`).

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
    data_path = Path(data) if isinstance(data, str | os.PathLike) else None
    sources = [Path(x) for x in (plan_path, data_path, equipment, spec)
               if isinstance(x, str | os.PathLike)]
    if report_dir is not None:
        check_outputs([report_dir], sources)
    if pdf and report_dir is None:
        raise PlanError("a PDF is part of the report: give report_dir as well")
    p = plan if isinstance(plan, Plan) else load_plan(plan)
    lab, lab_source = lab_of(equipment)
    signatories, laboratory = ((read_signatories(equipment), read_laboratory(equipment))
                               if isinstance(equipment, str | os.PathLike) else (None, None))
    used: tuple[Equipment, ...] = ()
    if lab is not None and p.test is not None:  # an unknown id fails before any work
        used = select_equipment(lab, p.test.equipment, plan_source=source_name("plan", plan_path),
                                lab_source=lab_source)
    spec_doc = spec_of(spec)
    d = load_data(data, topic, layout=layout) if data_path is not None else (
        data if isinstance(data, Mapping) and not is_frame(data) else load_data(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fit(p, d, sigma=sigma, noise_model=noise_model)
    messages = tuple(str(w.message) for w in caught)
    budget, conformance = (judge(p, result, used, spec_doc)
                           if lab is not None or spec_doc is not None else (None, None))
    digest = file_sha256(data_path) if data_path is not None else columns_sha256(d)
    plan_text = plan_path.read_text(encoding="utf-8") if plan_path is not None else repr(p)
    return file_run(
        result, p, plan_text=plan_text, data_sha256=digest, data_summary=data_summary(
            data_path, d, digest), tested_at=tested_at, store=store, report_dir=report_dir, pdf=pdf,
        allow_duplicate=allow_duplicate, warnings_=messages,
        inputs=sources, lab=lab, command=command,
        lab_source=lab_source, plan_source=source_name("plan", plan_path), budget=budget,
        conformance=conformance, signatories=signatories, laboratory=laboratory, spec=spec_doc)


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
    from inertest.quality.budget import uncertainty_budget
    from inertest.quality.conformance import model_names, verdicts

    if spec is not None:  # a misnamed quantity fails before the budget's simulations
        spec.check_quantities(_quantity_names(result), model_names(result),
                              kind=getattr(result, "kind", "the result"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the budget's noise-free refits warn about nothing real
        budget = uncertainty_budget(plan, result, equipment)
    return budget, None if spec is None else verdicts(result, spec, budget)


def _quantity_names(result: Any) -> list[str]:
    return [*result.coefficients, *(c.name for c in result.combinations)]


def spec_of(spec: PathLike | Spec | None) -> Spec | None:
    """The specification read from a path (or as given)."""
    if spec is None:
        return None
    from inertest.quality.conformance import Spec, read_spec

    return spec if isinstance(spec, Spec) else read_spec(spec)


def source_name(what: str, path: Path | None) -> str:
    """How messages name an input: ``"plan plan.toml"`` or ``"the plan"``."""
    return f"{what} {path}" if path is not None else f"the {what}"


def lab_of(equipment: PathLike | Mapping[str, Equipment] | None
         ) -> tuple[Mapping[str, Equipment] | None, str]:
    """The lab's equipment records and how to name their file in messages."""
    if equipment is None:
        return None, "the lab file"
    if isinstance(equipment, Mapping):
        return equipment, "the lab equipment records"
    return read_equipment(equipment), f"lab file {equipment}"


def file_run(
    result: Any,
    plan: Plan | None,
    *,
    plan_text: str,
    data_sha256: str,
    data_summary: Mapping[str, object],
    tested_at: datetime | None = None,
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
    instrument: Instrument | None = None,
    report_html: Callable[..., str] | None = None,
    outputs: Callable[[], None] | None = None,
    signatories: Mapping[str, str] | None = None,
    spec: Spec | None = None,
    command: str | None = None,
    laboratory: Mapping[str, str] | None = None,
) -> RunOutcome:
    """Report and store an already computed result, as one transaction (see :func:`run`).

    Every stored kind goes through here (a procedure's fit, a batch run, a thermal fit):
    :func:`prepare_run`, then :func:`file_prepared`. ``budget`` and ``conformance`` (from
    :func:`judge`) go into the stored envelope and the report. Without a plan (an analysis
    that has none), ``instrument`` names the instrument and ``report_html(history)`` builds the
    report page; ``outputs()`` writes the command's other files (figures, model files) inside
    the transaction: when it fails, the run is withdrawn and the report not moved into place.

    The report states each of ``inputs`` by its path and SHA-256, and ``command`` (the command
    line) when given. ``tested_at`` is ``--tested-at`` (None: the plan's ``[test] date``, else
    now); the one test date it resolves to (:func:`inertest.quality.lab.test_time`) dates the
    record, the report, the equipment's calibration status and the history. A stored run also
    carries when it was filed (``test.filed_at``); a run not stored has no filing time. With a
    report, the folder also holds ``certificate.json``
    (:func:`inertest.report.certificate.certificate`).
    """
    to_store = store is not False and store is not None
    prepared = prepare_run(
        result, plan, plan_text=plan_text, data_sha256=data_sha256, data_summary=data_summary,
        tested_at=tested_at, for_store=to_store, warnings_=warnings_, lab=lab,
        lab_source=lab_source, plan_source=plan_source, budget=budget, conformance=conformance,
        instrument=instrument, signatories=signatories, laboratory=laboratory)
    return file_prepared(prepared, store=store, report_dir=report_dir, pdf=pdf,
                         allow_duplicate=allow_duplicate, inputs=inputs, report_html=report_html,
                         outputs=outputs, spec=spec, command=command)


@dataclass(frozen=True)
class PreparedRun:
    """A computed run made ready to file: everything but the database and the report folder.

    :func:`prepare_run` makes it where the fit ran (a batch worker does), so that the process
    that files many runs only writes them (:func:`file_prepared`).

    Attributes
    ----------
    result : procedure result or EnvelopeResult
        The full result (a report is drawn from it), or its envelope alone
        (:class:`inertest.results.EnvelopeResult`) when no report is asked for.
    plan, instrument : Plan or None, Instrument
    plan_text, data_sha256, data_summary
        As given to :func:`file_run`.
    tested : TestTime
        The one test date.
    version : str
        The software version.
    test : dict
        The envelope's ``test`` block (without ``filed_at``, added when filed).
    notices, warnings : tuple of str
        The filing's own warnings; all warnings (the fit's, then the notices).
    envelope : dict or None
        The stored envelope without ``filed_at``; None when shipped without the full result.
    record : RunRecord or None
        The run to store (its envelope already JSON text); None when not storing.
    budget, conformance, lab, lab_source, plan_source, signatories, laboratory
        As given to :func:`file_run`.
    """

    result: Any
    plan: Plan | None
    instrument: Instrument
    plan_text: str
    data_sha256: str
    data_summary: Mapping[str, object]
    tested: TestTime
    version: str
    test: dict[str, Any]
    notices: tuple[str, ...]
    warnings: tuple[str, ...]
    envelope: dict[str, object] | None
    record: Any = None
    budget: UncertaintyBudget | None = None
    conformance: Conformance | None = None
    lab: Mapping[str, Equipment] | None = None
    lab_source: str = "the lab file"
    plan_source: str = "the plan"
    signatories: Mapping[str, str] | None = None
    laboratory: Mapping[str, str] | None = None

    def compact(self) -> PreparedRun:
        """The same run with its result as the envelope alone (no per-sample arrays).

        What a batch worker sends back when the run draws no report.
        """
        from inertest.results import EnvelopeResult

        if isinstance(self.result, EnvelopeResult):
            return self
        # The stored envelope travels as the record's JSON text alone.
        record = None if self.record is None else replace(self.record, result={})
        return replace(self, result=EnvelopeResult.of(self.result), envelope=None,
                       record=record)


@functools.cache
def software_version() -> str:
    """The installed inertest's version (read once: parsing the metadata takes milliseconds)."""
    return metadata.version("inertest")


def prepare_run(
    result: Any,
    plan: Plan | None,
    *,
    plan_text: str,
    data_sha256: str,
    data_summary: Mapping[str, object],
    tested_at: datetime | None = None,
    for_store: bool = False,
    warnings_: Sequence[str] = (),
    lab: Mapping[str, Equipment] | None = None,
    lab_source: str = "the lab file",
    plan_source: str = "the plan",
    budget: UncertaintyBudget | None = None,
    conformance: Conformance | None = None,
    instrument: Instrument | None = None,
    signatories: Mapping[str, str] | None = None,
    laboratory: Mapping[str, str] | None = None,
) -> PreparedRun:
    """The run's test block, envelope and (``for_store``) record: no database, no files."""
    if plan is None and instrument is None:
        raise PlanError("file_run needs the plan or the instrument")
    inst = plan.instrument if plan is not None else instrument
    assert inst is not None
    test_table = plan.test if plan is not None else None
    version = software_version()
    tested = test_time(test_table, tested_at)
    test = identity_block(test_table, lab=lab, tested=tested, software_version=version,
                          data_sha256=data_sha256, plan_source=plan_source,
                          lab_source=lab_source, signatories=signatories,
                          laboratory=laboratory)
    used = [lab[i] for i in test_table.equipment] if lab is not None and test_table else []
    notices = overdue_messages(used, tested.date)
    override = tested.override_message()
    if override is not None:
        notices.insert(0, override)
    if lab is None and test_table is not None and test_table.equipment:
        notices.append(unchecked_equipment_message(test_table.equipment))
    envelope_doc = _with_notices(with_blocks(
        result.to_dict(), test=test,
        uncertainty_budget=None if budget is None else budget.to_dict(),
        conformance=None if conformance is None else conformance.to_dict()), notices)
    record = None
    if for_store:  # SQLAlchemy, Alembic: only when storing
        from inertest.store.records import RunRecord

        record = RunRecord.from_result(
            envelope_doc, serial=inst.serial, instrument_kind=inst.kind, plan_text=plan_text,
            data_sha256=data_sha256, software_version=version, tested_at=tested.at,
            serialise=True)
    return PreparedRun(
        result=result, plan=plan, instrument=inst, plan_text=plan_text, data_sha256=data_sha256,
        data_summary=data_summary, tested=tested, version=version, test=test,
        notices=tuple(notices), warnings=(*warnings_, *notices), envelope=envelope_doc,
        record=record, budget=budget, conformance=conformance, lab=lab, lab_source=lab_source,
        plan_source=plan_source, signatories=signatories, laboratory=laboratory)


def file_prepared(
    prepared: PreparedRun,
    *,
    store: bool | str | HistoryStore = False,
    report_dir: PathLike | None = None,
    pdf: bool = False,
    allow_duplicate: bool = False,
    inputs: Sequence[PathLike] = (),
    report_html: Callable[..., str] | None = None,
    outputs: Callable[[], None] | None = None,
    spec: Spec | None = None,
    command: str | None = None,
) -> RunOutcome:
    """File a :class:`PreparedRun`: report into place, run into the database, one transaction.

    See :func:`file_run`.
    """
    r = prepared
    inst, result, test = r.instrument, r.result, dict(r.test)
    if store is not False and store is not None:
        from inertest.store import HistoryStore, RunRecord, StoreError

    filed_at = None
    if store is not False and store is not None:
        filed_at = datetime.now(UTC)
        test["filed_at"] = filed_at.isoformat(timespec="seconds")
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
            record = r.record
            if record is None:  # prepared without storing in mind
                assert r.envelope is not None
                record = RunRecord.from_result(
                    r.envelope, serial=inst.serial, instrument_kind=inst.kind,
                    plan_text=r.plan_text, data_sha256=r.data_sha256,
                    software_version=r.version, tested_at=r.tested.at)
            record = replace(record, filed_at=filed_at)
        report_path = None
        report_id = (str(test.get("certificate") or "") or (
            record.run_uuid if record is not None else report_id_of(
                result.kind, inst.serial, r.data_sha256, r.plan_text, r.tested.at.isoformat())))
        if report_dir is not None:
            if r.envelope is None:
                raise PlanError("a report needs the full result: prepare the run with it")
            envelope_doc = with_blocks(r.envelope, test=test)
            if db is not None and not allow_duplicate:  # before the report is drawn
                _refuse_duplicate(db.runs_with_data(inst.serial, result.kind, r.data_sha256),
                                  inst.serial, result.kind, r.data_sha256)
            history: list = []
            if db is not None and record is not None:
                from inertest.store.summary import summarize_runs

                try:
                    earlier_runs = db.runs(inst.serial, procedure=result.kind)
                except StoreError:
                    earlier_runs = []
                history = summarize_runs(sorted([*earlier_runs, record],
                                                key=lambda x: x.tested_at))
            html = (report_html(history, report_id=report_id, test=test)
                    if report_html is not None else _report_html(
                        result, r.plan, r.plan_text, r.data_summary, r.tested, r.version,
                        history, test, envelope_doc, report_id, spec,
                        source_rows(inputs, command)))
            added = False
            try:
                with target_directory(report_dir, inputs=inputs) as tmp:
                    (tmp / "index.html").write_text(html, encoding="utf-8")
                    if pdf:
                        from inertest.report.pdf import html_to_pdf

                        html_to_pdf(tmp / "index.html", tmp / "report.pdf")
                    from inertest.report.certificate import write_certificate

                    write_certificate(tmp, envelope_doc, report_id=report_id)
                    # Store last inside the block: a failed store leaves no report, and a
                    # failed report leaves no stored run.
                    if db is not None and record is not None:
                        _refuse_duplicate(db.add(record, refuse_same_data=not allow_duplicate),
                                          inst.serial, result.kind, r.data_sha256)
                        added = True
                    if outputs is not None:
                        outputs()
            except BaseException:
                if added:  # moving the report into place failed (full disk): withdraw the run
                    db.discard(record.run_uuid)  # type: ignore[union-attr]
                raise
            report_path = Path(report_dir) / "index.html"
        else:
            if db is not None and record is not None:
                _refuse_duplicate(db.add(record, refuse_same_data=not allow_duplicate),
                                  inst.serial, result.kind, r.data_sha256)
            try:
                if outputs is not None:
                    outputs()
            except BaseException:
                if db is not None and record is not None:
                    db.discard(record.run_uuid)
                raise
        return RunOutcome(
            result=result, plan=r.plan, data_sha256=r.data_sha256, tested_at=r.tested.at,
            stored_run=None if record is None else record.run_uuid,
            database=None if db is None else db.display_url, report=report_path,
            warnings=r.warnings, test=test, budget=r.budget, conformance=r.conformance,
            notices=r.notices, filed_at=filed_at,
            report_id=report_id if report_path is not None else None)
    finally:
        if db is not None and own_store:
            db.close()


def _refuse_duplicate(earlier: Sequence[str] | str | None, serial: str, kind: str,
                      data_sha256: str) -> None:
    """A :class:`DuplicateRunError` when ``earlier`` names a run filed from the same data."""
    if not earlier:
        return
    first = earlier if isinstance(earlier, str) else earlier[0]
    said = (f"this data file (sha256 {data_sha256[:12]}...) is already filed for {serial} / "
            f"{kind} (run {first}); nothing stored.")
    raise DuplicateRunError(
        f"{said} Pass allow_duplicate=True to file it again, or store=False",
        cli_message=f"{said} Use --allow-duplicate to file it again, or --no-store")


def _report_html(result: Any, plan: Plan | None, plan_text: str,
                 data_summary: Mapping[str, object],
                 tested: TestTime, version: str, history: list,
                 test: Mapping[str, Any] | None = None,
                 doc: Mapping[str, Any] | None = None, report_id: str = "",
                 spec: Spec | None = None, sources: Sequence[Sequence[str]] = ()) -> str:
    from inertest.report.campaign import campaign_page

    if plan is None:
        raise PlanError("a report without a plan needs its own page (report_html)")
    inst = plan.instrument
    return campaign_page(
        result,
        instrument={"serial": inst.serial or "-", "kind": inst.kind,
                    "output unit": inst.output_unit, "scale factor": inst.scale_factor or "-"},
        site={"latitude [deg]": f"{plan.site.latitude_deg:.6f}",
              "gravity [m/s^2]": f"{plan.site.gravity_m_s2:.7f}"},
        plan_text=plan_text, data=data_summary, tested=tested,
        software_version=version, history=history, test=test, report_id=report_id, spec=spec,
        sources=sources,
        uncertainty_budget=None if doc is None else doc.get("uncertainty_budget"),
        conformance=None if doc is None else doc.get("conformance"))


def source_rows(inputs: Sequence[PathLike], command: str | None) -> list[list[str]]:
    """Identity rows that reproduce a report: each input's path and SHA-256, the command."""
    rows: list[list[str]] = []
    for f in inputs:
        p = Path(f)
        rows += [["input file", str(p)], [f"SHA-256 of {p.name}", file_sha256(p)]]
    if command:
        rows += [["command", command], ["working folder", str(Path.cwd())]]
    return rows


def data_summary(path: Path | None, data: Mapping[str, Any], digest: str) -> dict[str, object]:
    """What the report says of the data: file, rows, columns, SHA-256."""
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


def as_utc(t: datetime) -> datetime:
    """``t`` in UTC (a naive time is taken as UTC)."""
    return t.replace(tzinfo=UTC) if t.tzinfo is None else t.astimezone(UTC)
