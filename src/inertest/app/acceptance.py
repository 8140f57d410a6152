"""An acceptance campaign: every test of one unit under test, judged clause by clause, filed once.

A lab's acceptance test procedure (ATP) is a series of tests on one delivered instrument against
its specification. The campaign manifest (TOML) names the unit, the specification and the tests,
and which of the specification's clauses each test verifies::

    [campaign]
    title = "Acceptance test of FOG-Z-0231"
    serial = "FOG-Z-0231"              # every plan must name this unit
    unit_type = "FOG-Z tactical IFOG"  # the lot it belongs to (inertest lot)
    spec = "../specs/fog_acceptance.toml"
    equipment = "../lab/equipment.toml"    # optional: Type B of the plans' equipment, and
                                           # the laboratory ([laboratory] of the lab file)
    certificate = "ATP-2026-0231"          # optional: the certificate's number
    customer = "Example Avionics GmbH"     # optional: the job and the item (TestItem) ...
    customer_contact = "J. Buyer, Example Street 1, Example Town"
    receipt_date = 2026-11-16              # ... when the unit was received,
    condition_on_receipt = "sealed, no visible damage"   # in which condition,
    deviations = []                        # deviations from the method ([]: none),
    data_origin = "measured"               # "measured" or "simulated"

    [[test]]
    name = "turn-on"
    plan = "turn_on/plan.toml"
    runs = ["turn_on/run1.csv", "turn_on/run2.csv"]   # one file per power-on ...
    verifies = ["bias", "bias-repeatability"]         # clause ids of the spec ([[limit]] id)

    [[test]]
    name = "warm-up"
    plan = "warm_up/plan.toml"
    data = "warm_up/record.csv"                       # ... or one data file
    verifies = ["warm-up-time"]

Paths are relative to the manifest. ``runs`` entries are files (the run's label is the file's
name without suffix) or tables ``{data = "...", label = "..."}``; they are joined into one table
with a ``run`` column for the procedure. A test without ``data`` or ``runs`` is *planned* (its
clauses are "not tested"); ``sigma`` (known noise per reading) and ``truth`` (the nominal
instrument, for ``plan-check``) are optional. The job and the item (customer and contact,
receipt date, condition on receipt, deviations from the method, data origin:
:class:`inertest.plan.TestItem`) are stated for the series and go into every test's ``test``
block, over what its plan's ``[test]`` states; the certificate prints "not stated" for each
one no file gives, as for the laboratory (the lab file's ``[laboratory]``).

:func:`run_campaign` checks everything it can before any fit (the manifest's keys, every file,
the spec, each clause id, each plan's serial), then fits every test through the batch machinery
(:func:`inertest.app.batch.run_batch`, on a process pool with ``workers`` or a Dask client),
computes each test's uncertainty budget and judges each clause it verifies by the spec's decision
rule (:func:`inertest.app.run.judge`), and only then files the series: each run its own record
(:func:`inertest.app.run.file_run`), then the campaign's row (:mod:`inertest.store.campaigns`),
and writes one certificate covering the series (:mod:`inertest.report.acceptance`). Any failure
withdraws what was filed: nothing is stored or written half-way.

Clause verdicts are those of :mod:`inertest.quality.conformance` (ILAC-G8:09/2019), plus
*not tested* (its test is planned, not performed) and *not verified* (no test of the campaign
verifies the clause); both rank with *not determined*, below any pass, so the series passes only
when every clause is judged and passes.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inertest.api import load_data, load_plan
from inertest.app.batch import BatchTask, run_batch
from inertest.app.run import (
    PathLike,
    RunOutcome,
    data_summary,
    file_run,
    judge,
    lab_of,
    source_name,
)
from inertest.errors import InertestError, PlanError
from inertest.io.data_file import file_sha256, write_table
from inertest.io.plan_file import read_toml
from inertest.plan import (
    TEST_ITEM_KEYS,
    Plan,
    TestConditions,
    TestItem,
    check_known_keys,
    did_you_mean,
    read_test_item,
)
from inertest.quality.conformance import VERDICTS, Spec, Verdict, read_spec, rule_text
from inertest.quality.lab import LABORATORY_KEYS, Equipment, read_laboratory, read_signatories
from inertest.results import envelope

if TYPE_CHECKING:
    from inertest.store import HistoryStore

#: Verdicts of a clause in a campaign, best first: the conformance verdicts and the two of a
#: series (:data:`NOT_TESTED`, :data:`NOT_VERIFIED`), ranked with "not determined".
NOT_TESTED = "not tested"
NOT_VERIFIED = "not verified"
SERIES_VERDICTS = ("pass", "conditional pass", "not determined", NOT_TESTED, NOT_VERIFIED,
                   "conditional fail", "fail")
_RANK = {v: i for i, v in enumerate(SERIES_VERDICTS)}
_RANK[NOT_TESTED] = _RANK[NOT_VERIFIED] = _RANK["not determined"]
assert set(VERDICTS) <= set(SERIES_VERDICTS)

_CAMPAIGN_KEYS = {"title", "serial", "unit_type", "spec", "equipment", "certificate",
                  *TEST_ITEM_KEYS}
_TEST_KEYS = {"name", "title", "plan", "data", "runs", "verifies", "sigma", "truth", "noise"}


class CampaignError(PlanError):
    """A campaign manifest that cannot be run (named key, file or clause, and the fix)."""


@dataclass(frozen=True)
class CampaignTest:
    """One test of a campaign.

    Attributes
    ----------
    name, title : str
    plan : Path
    data : Path or None
        One data file.
    runs : tuple of (str, Path)
        ``(label, file)`` of each run, joined with a ``run`` column; empty with ``data``.
    verifies : tuple of str
        The spec's clause ids this test verifies.
    sigma : float or None
    truth : Path or None
        The nominal instrument (``plan-check``, simulation); default ``truth.toml`` beside the plan.
    noise : float
        White noise per reading for simulation [output unit].
    """

    name: str
    title: str
    plan: Path
    data: Path | None
    runs: tuple[tuple[str, Path], ...]
    verifies: tuple[str, ...]
    sigma: float | None = None
    truth: Path | None = None
    noise: float = 0.0

    @property
    def performed(self) -> bool:
        """Whether the test has data (a planned test has none)."""
        return self.data is not None or bool(self.runs)

    @property
    def inputs(self) -> tuple[Path, ...]:
        """The test's files: its plan and its data."""
        return (self.plan, *((self.data,) if self.data is not None else ()),
                *(p for _, p in self.runs))


@dataclass(frozen=True)
class Campaign:
    """A campaign manifest read and checked (:func:`read_campaign`).

    ``item`` is the job and the item its ``[campaign]`` states (customer, receipt, condition,
    deviations, data origin).
    """

    path: Path
    title: str
    serial: str
    unit_type: str
    spec_path: Path
    spec: Spec
    equipment: Path | None
    certificate: str
    tests: tuple[CampaignTest, ...]
    item: TestItem = TestItem()

    def sub_spec(self, test: CampaignTest) -> Spec:
        """The spec's limits this test verifies (its clauses), same rule and name."""
        return replace(self.spec, limits=tuple(lim for lim in self.spec.limits
                                               if lim.clause_id in test.verifies))


def read_campaign(path: PathLike) -> Campaign:
    """Read and check a campaign manifest (module docstring).

    Raises
    ------
    CampaignError
        An unknown key, a missing file (named with its test), a clause id that is not in the
        spec (with did-you-mean), a plan whose serial is not the campaign's unit, two tests of
        one name.
    """
    mpath = Path(path)
    where = f"campaign {mpath}"
    if not mpath.is_file():
        raise CampaignError(f"{where}: no such file; give the campaign manifest (TOML, see "
                            "examples/fog_acceptance/campaign.toml)")
    doc = read_toml(mpath, "campaign")
    check_known_keys(doc, {"campaign", "test"}, where, error=CampaignError)
    head = doc.get("campaign")
    if not isinstance(head, dict):
        raise CampaignError(f"{where} has no [campaign] table (serial, spec, ...)")
    check_known_keys(head, _CAMPAIGN_KEYS, f"{where}: [campaign]", error=CampaignError)
    for key in ("serial", "spec"):
        if not isinstance(head.get(key), str) or not head[key]:
            raise CampaignError(f"{where}: [campaign] needs {key} (text)")
    base = mpath.parent

    def file(value: object, what: str) -> Path:
        if not isinstance(value, str) or not value:
            raise CampaignError(f"{where}: {what} must be a file path (text), got {value!r}")
        p = base / value
        if not p.is_file():
            raise CampaignError(f"{where}: {what} {p} does not exist; fix the path (relative to "
                                "the manifest)")
        return p

    item = read_test_item(head, f"{where}: [campaign]", error=CampaignError)
    spec_path = file(head["spec"], "[campaign] spec")
    spec = read_spec(spec_path)
    equipment = file(head["equipment"], "[campaign] equipment") if "equipment" in head else None
    tests_doc = doc.get("test")
    if not isinstance(tests_doc, list) or not tests_doc:
        raise CampaignError(f"{where} lists no [[test]] tables (name, plan, data or runs, "
                            "verifies)")
    ids = [lim.clause_id for lim in spec.limits]
    tests: list[CampaignTest] = []
    for k, t in enumerate(tests_doc, start=1):
        if not isinstance(t, dict):
            raise CampaignError(f"{where}: test {k} must be a [[test]] table")
        name = str(t.get("name") or f"test {k}")
        tw = f"{where}, test {name!r}"
        check_known_keys(t, _TEST_KEYS, tw, error=CampaignError)
        if "plan" not in t:
            raise CampaignError(f"{tw} needs plan (and data or runs to be performed)")
        if "data" in t and "runs" in t:
            raise CampaignError(f"{tw}: give data (one file) or runs (one file per run), not "
                                "both")
        verifies = t.get("verifies", [])
        if not isinstance(verifies, list) or not all(isinstance(v, str) for v in verifies):
            raise CampaignError(f"{tw}: verifies must be a list of clause ids of the spec")
        for v in verifies:
            if v not in ids:
                raise CampaignError(
                    f"{tw} verifies clause {v!r}, which {spec.source} does not have"
                    f"{did_you_mean(v, ids)}; its clauses: {', '.join(ids)}")
        runs: list[tuple[str, Path]] = []
        for j, r in enumerate(t.get("runs", []) or [], start=1):
            if isinstance(r, dict):
                check_known_keys(r, {"data", "label"}, f"{tw}, run {j}", error=CampaignError)
                p = file(r.get("data"), f"test {name!r}, run {j} data")
                runs.append((str(r.get("label") or p.stem), p))
            else:
                p = file(r, f"test {name!r}, run {j}")
                runs.append((p.stem, p))
        labels = [lab for lab, _ in runs]
        if len(set(labels)) != len(labels):
            raise CampaignError(f"{tw}: two runs share a label; give each run its own label")
        sigma = t.get("sigma")
        if sigma is not None and (isinstance(sigma, bool) or not isinstance(sigma, int | float)
                                  or not sigma > 0):
            raise CampaignError(f"{tw}: sigma must be a positive number (noise per reading)")
        noise = t.get("noise", 0.0)
        if isinstance(noise, bool) or not isinstance(noise, int | float) or noise < 0:
            raise CampaignError(f"{tw}: noise must be a number >= 0 (noise per reading)")
        plan_path = file(t["plan"], f"test {name!r} plan")
        truth = (file(t["truth"], f"test {name!r} truth") if "truth" in t
                 else plan_path.parent / "truth.toml")
        tests.append(CampaignTest(
            name=name, title=str(t.get("title") or name), plan=plan_path,
            data=file(t["data"], f"test {name!r} data") if "data" in t else None,
            runs=tuple(runs), verifies=tuple(verifies),
            sigma=None if sigma is None else float(sigma),
            truth=truth if truth.is_file() else None, noise=float(noise)))
    names = [t.name for t in tests]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise CampaignError(f"{where}: two tests are named {twice[0]!r}; name each test once")
    serial = str(head["serial"])
    for t in tests:
        plan_serial = load_plan(t.plan).instrument.serial
        if plan_serial != serial:
            raise CampaignError(
                f"{where}, test {t.name!r}: its plan {t.plan} names the unit "
                f"{plan_serial or '(no serial)'!r}, the campaign's unit is {serial!r}; every "
                "test of a campaign is on one unit")
    return Campaign(path=mpath, title=str(head.get("title") or f"Acceptance test of {serial}"),
                    serial=serial, unit_type=str(head.get("unit_type") or ""),
                    spec_path=spec_path, spec=spec, equipment=equipment,
                    certificate=str(head.get("certificate") or ""), tests=tuple(tests),
                    item=item)


@dataclass(frozen=True)
class ClauseVerdict:
    """One clause of the spec as the campaign judged it (one row per verifying test)."""

    clause_id: str
    requirement: str
    reference: str
    quantity: str
    test: str | None
    verdict: str
    value: float | None = None
    expanded: float | None = None
    coverage_factor: float | None = None
    unit: str = ""
    note: str = ""
    limit_unit: str = ""

    def to_dict(self) -> dict[str, object]:
        """JSON form: value and U in the result's ``unit``, the limit in ``limit_unit``."""
        return {"clause": self.clause_id, "requirement": self.requirement,
                "reference": self.reference, "quantity": self.quantity, "test": self.test,
                "value": self.value, "expanded_uncertainty": self.expanded,
                "coverage_factor": self.coverage_factor, "unit": self.unit,
                "limit_unit": self.limit_unit or self.unit,
                "verdict": self.verdict, "note": self.note}


@dataclass(frozen=True)
class TestOutcome:
    """A test of the campaign: its outcome (None when planned only) and its input files."""

    __test__ = False   # not a pytest class despite its name

    test: CampaignTest
    outcome: RunOutcome | None
    files: tuple[tuple[str, str], ...] = ()   # (path, SHA-256)


@dataclass(frozen=True)
class AcceptanceOutcome:
    """What :func:`run_campaign` did.

    Attributes
    ----------
    campaign : Campaign
    tests : tuple of TestOutcome
    clauses : tuple of ClauseVerdict
        One row per (clause, verifying test), spec order; a clause no test verifies has one row
        with verdict :data:`NOT_VERIFIED`.
    campaign_uuid : str or None
        The stored campaign (None when not stored).
    database : str or None
    report : Path or None
        The certificate's ``index.html``.
    report_id : str
    filed_at : datetime or None
    laboratory : mapping or None
        The lab file's ``[laboratory]`` (name, address, accreditation).
    """

    campaign: Campaign
    tests: tuple[TestOutcome, ...]
    clauses: tuple[ClauseVerdict, ...]
    report_id: str
    campaign_uuid: str | None = None
    database: str | None = None
    report: Path | None = None
    filed_at: datetime | None = None
    laboratory: Mapping[str, str] | None = None

    @property
    def messages(self) -> list[str]:
        """Notes of the series: planned tests, unverified clauses, each test's messages."""
        return _messages(self.tests, self.clauses)

    @property
    def overall(self) -> str:
        """The worst clause verdict (a series passes when every clause passes)."""
        return max((c.verdict for c in self.clauses), key=_RANK.__getitem__, default="pass")

    @property
    def complete(self) -> bool:
        """Whether every clause was judged by a performed test."""
        return not any(c.verdict in (NOT_TESTED, NOT_VERIFIED) for c in self.clauses)

    def tested_range(self) -> tuple[datetime, datetime]:
        """Earliest and latest test date of the performed tests (UTC)."""
        dates = [t.outcome.tested_at for t in self.tests if t.outcome is not None]
        now = datetime.now(UTC)
        return (min(dates), max(dates)) if dates else (now, now)

    def to_dict(self) -> dict[str, object]:
        """The result envelope (kind ``acceptance``): the series, its clauses, each test's own."""
        c = self.campaign
        lo, hi = self.tested_range()
        tests = []
        for t in self.tests:
            o = t.outcome
            tests.append({
                "name": t.test.name, "title": t.test.title, "plan": str(t.test.plan),
                "performed": o is not None, "verifies": list(t.test.verifies),
                "files": [{"path": p, "sha256": h} for p, h in t.files],
                "stored_run": None if o is None else o.stored_run,
                "result": None if o is None else o.to_dict()})
        return envelope(
            "acceptance",
            instrument={"serial": c.serial, "unit_type": c.unit_type},
            result={
                "campaign": {"title": c.title, "manifest": str(c.path),
                             "campaign_id": self.campaign_uuid, "report_id": self.report_id,
                             "certificate": c.certificate or None,
                             "tested_from": lo.isoformat(timespec="seconds"),
                             "tested_to": hi.isoformat(timespec="seconds"),
                             "filed_at": None if self.filed_at is None
                             else self.filed_at.isoformat(timespec="seconds"),
                             **c.item.to_dict()},
                "laboratory": {k: (self.laboratory or {}).get(k) or None
                               for k in LABORATORY_KEYS},
                "specification": {"name": c.spec.name, "file": str(c.spec_path),
                                  "decision_rule": c.spec.decision_rule,
                                  "rule": rule_text(c.spec.decision_rule,
                                                    (v.coverage_factor for v in self.clauses),
                                                    per="clause")},
                "overall": self.overall, "complete": self.complete,
                "clauses": [v.to_dict() for v in self.clauses],
                "tests": tests},
            messages=self.messages)


def run_campaign(
    campaign: PathLike | Campaign,
    *,
    store: bool | str | HistoryStore = False,
    report_dir: PathLike | None = None,
    workers: int = 1,
    executor: Any = None,
    allow_duplicate: bool = False,
    tested_at: datetime | None = None,
    command: str | None = None,
) -> AcceptanceOutcome:
    """Run every test of a campaign, judge every clause, file the series, write the certificate.

    Parameters
    ----------
    campaign : path or Campaign
        The manifest (:func:`read_campaign`).
    store : bool, str or HistoryStore
        As :func:`inertest.app.run.run`: False, True (the default database), a URL or path, or an
        open store.
    report_dir : path, optional
        Folder for the series certificate (``index.html``, ``certificate.json``).
    workers, executor
        Where the fits run (:func:`inertest.app.batch.run_batch`).
    allow_duplicate : bool
        File data already stored for the unit and procedure.
    tested_at : datetime, optional
        Overrides every plan's test date (as ``inertest fit --tested-at``).
    command : str, optional
        The command line, stated in the certificate.

    Raises
    ------
    InertestError
        A bad manifest, a test whose fit fails (named), a clause whose quantity is not one of its
        test's procedure, a duplicate run, an unusable database or report folder; nothing was
        stored or written.
    """
    from inertest.io.atomic import check_outputs

    c = campaign if isinstance(campaign, Campaign) else read_campaign(campaign)
    inputs = [c.path, c.spec_path, *([c.equipment] if c.equipment else []),
              *(p for t in c.tests for p in t.inputs)]
    if report_dir is not None:
        check_outputs([report_dir], inputs)
    lab, lab_source = lab_of(c.equipment)
    signatories = read_signatories(c.equipment) if c.equipment is not None else None
    laboratory = read_laboratory(c.equipment) if c.equipment is not None else None
    performed = [t for t in c.tests if t.performed]
    with tempfile.TemporaryDirectory(prefix="inertest-campaign-") as tmp:
        tasks = [BatchTask(plan=t.plan, data=_data_of(t, Path(tmp)), sigma=t.sigma,
                           equipment=c.equipment) for t in performed]
        # full results: each test is judged against its clauses and filed here
        items = run_batch(tasks, executor=executor, workers=workers, store=False, full_results=True,
                          tested_at=tested_at)
        failed = [(t, i) for t, i in zip(performed, items, strict=True) if i.error is not None]
        if failed:
            t, i = failed[0]
            raise CampaignError(f"campaign {c.path}, test {t.name!r}: {i.error} (nothing "
                                "stored or written)")
        judged: dict[str, RunOutcome] = {}
        for t, i in zip(performed, items, strict=True):
            assert i.outcome is not None
            judged[t.name] = _judged(c, t, i.outcome, lab, lab_source)
        tests = tuple(TestOutcome(t, judged.get(t.name), tuple(
            (str(p), file_sha256(p)) for p in t.inputs)) for t in c.tests)
        clauses = _clauses(c, tests)
        report_id = c.certificate or _report_id(c, tests)
        outcome = AcceptanceOutcome(campaign=c, tests=tests, clauses=clauses,
                                    report_id=report_id, laboratory=laboratory)
        return _file(outcome, tasks, store=store, report_dir=report_dir,
                     allow_duplicate=allow_duplicate, tested_at=tested_at, lab=lab,
                     lab_source=lab_source, signatories=signatories, inputs=inputs,
                     command=command)


def _data_of(t: CampaignTest, tmp: Path) -> Path:
    """The test's data file: as given, or its runs joined with a ``run`` column (Parquet)."""
    if t.data is not None:
        return t.data
    import numpy as np

    columns: dict[str, list[Any]] = {}
    for label, path in t.runs:
        d = load_data(path)
        if "run" in d:
            raise CampaignError(f"test {t.name!r}: run file {path} has its own run column; "
                                "give it as data, or drop the column")
        n = len(next(iter(d.values())))
        names = ["run", *d]
        if columns and set(columns) != set(names):
            raise CampaignError(f"test {t.name!r}: run file {path} has columns "
                                f"{', '.join(map(str, d))}, the earlier runs "
                                f"{', '.join(k for k in columns if k != 'run')}; give every run "
                                "the same columns")
        for k in names:
            columns.setdefault(k, []).append(np.full(n, label) if k == "run"
                                             else np.asarray(d[k]))
    out = tmp / f"{len(os.listdir(tmp))}-{_safe(t.name)}.parquet"
    write_table(out, {k: np.concatenate(v) for k, v in columns.items()})
    return out


def _safe(name: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in name)[:40] or "test"


def _judged(c: Campaign, t: CampaignTest, o: RunOutcome, lab: Mapping[str, Equipment] | None,
            lab_source: str) -> RunOutcome:
    """``o`` with its uncertainty budget and the verdicts of the clauses ``t`` verifies."""
    from inertest.quality.conformance import verdicts

    plan = o.plan
    assert plan is not None
    sub = c.sub_spec(t)
    try:
        budget = o.budget
        if budget is None:   # no lab file: the budget of the site gravity and Type A
            budget, _ = judge(plan, o.result, (), None)
        conformance = verdicts(o.result, sub, budget) if sub.limits else None
    except InertestError as exc:
        raise CampaignError(f"campaign {c.path}, test {t.name!r}: {exc}") from None
    return replace(o, budget=budget, conformance=conformance)


def _clauses(c: Campaign, tests: Sequence[TestOutcome]) -> tuple[ClauseVerdict, ...]:
    rows: list[ClauseVerdict] = []
    for lim in c.spec.limits:
        cid = lim.clause_id
        by = [t for t in tests if cid in t.test.verifies]
        base: dict[str, Any] = {"clause_id": cid, "requirement": lim.text(),
                                "reference": lim.clause, "quantity": lim.quantity,
                                "unit": lim.unit, "limit_unit": lim.unit}
        if not by:
            rows.append(ClauseVerdict(**base, test=None, verdict=NOT_VERIFIED,
                                      note="no test of the campaign verifies this clause: add "
                                           "one, or list it in a test's verifies"))
            continue
        for t in by:
            if t.outcome is None:
                rows.append(ClauseVerdict(**base, test=t.test.name, verdict=NOT_TESTED,
                                          note=f"test {t.test.name!r} is planned but has no "
                                               "data: run it and list its data or runs"))
                continue
            conf = t.outcome.conformance
            assert conf is not None
            v: Verdict = next(x for x in conf.verdicts if x.quantity == lim.quantity
                              and x.limit == lim.text())
            rows.append(ClauseVerdict(
                **{**base, "unit": v.unit}, test=t.test.name, verdict=v.verdict, value=v.value,
                expanded=v.expanded, coverage_factor=v.coverage_factor, note=v.note))
    return tuple(rows)


def _messages(tests: Sequence[TestOutcome], clauses: Sequence[ClauseVerdict]) -> list[str]:
    out = []
    for t in tests:
        if t.outcome is None:
            out.append(f"test {t.test.name!r} is planned, not performed (no data)")
        elif not t.test.verifies:
            out.append(f"test {t.test.name!r} verifies no clause of the spec (listed for "
                       "information)")
        if t.outcome is not None:
            found = t.outcome.to_dict().get("messages")
            out += [f"{t.test.name}: {m}" for m in (found if isinstance(found, list) else [])]
    for cl in clauses:
        if cl.verdict == NOT_VERIFIED:
            out.append(f"clause {cl.clause_id!r} ({cl.requirement}) is verified by no test of "
                       "the campaign")
    return out


def _report_id(c: Campaign, tests: Sequence[TestOutcome]) -> str:
    from inertest.report.html import report_id_of

    return report_id_of("acceptance", c.serial, c.spec.name,
                        *(h for t in tests for _, h in t.files))


def _file(outcome: AcceptanceOutcome, tasks: Sequence[BatchTask], *,
          store: bool | str | HistoryStore, report_dir: PathLike | None,
          allow_duplicate: bool, tested_at: datetime | None,
          lab: Mapping[str, Equipment] | None, lab_source: str,
          signatories: Mapping[str, str] | None, inputs: Sequence[Path],
          command: str | None) -> AcceptanceOutcome:
    """File every run and the campaign row, write the certificate: all or nothing."""
    from inertest.io.atomic import target_directory

    own = store is True or isinstance(store, str)
    db: Any = None
    if store is not False and store is not None:
        from inertest.store import HistoryStore

        db = HistoryStore(None if store is True else str(store)) if own else store
    created = db is not None and db.path is not None and not db.path.exists()
    filed: list[str] = []
    campaign_uuid: str | None = None
    performed = [t for t in outcome.tests if t.outcome is not None]
    try:
        if db is not None and not allow_duplicate:
            for t in performed:
                o = t.outcome
                assert o is not None and o.plan is not None
                earlier = db.runs_with_data(o.plan.instrument.serial, o.result.kind,
                                            o.data_sha256)
                if earlier:
                    raise CampaignError(
                        f"test {t.test.name!r}: its data (sha256 {o.data_sha256[:12]}...) is "
                        f"already filed for {o.plan.instrument.serial} / {o.result.kind} (run "
                        f"{earlier[0]}); nothing stored. Use --allow-duplicate to file the "
                        "campaign again, or --no-store")
        stored: dict[str, RunOutcome] = {}
        filed_at = datetime.now(UTC) if db is not None else None

        def file_all() -> None:
            nonlocal campaign_uuid
            for t, task in zip(performed, tasks, strict=True):
                o = t.outcome
                assert o is not None and o.plan is not None
                d = load_data(task.data) if db is not None else {}
                s = file_run(
                    o.result, _with_item(o.plan, outcome.campaign.item),
                    plan_text=t.test.plan.read_text(encoding="utf-8"),
                    data_sha256=o.data_sha256, data_summary=data_summary(task.data, d,
                                                                         o.data_sha256),
                    tested_at=tested_at, store=db if db is not None else False,
                    allow_duplicate=True, warnings_=o.warnings, inputs=list(t.test.inputs),
                    lab=lab, lab_source=lab_source,
                    plan_source=source_name("plan", t.test.plan), budget=o.budget,
                    conformance=o.conformance, signatories=signatories,
                    laboratory=outcome.laboratory)
                if s.stored_run is not None:
                    filed.append(s.stored_run)
                stored[t.test.name] = s
            if db is not None:
                from inertest.store.campaigns import CampaignRecord, add_campaign

                lo, hi = outcome.tested_range()
                record = CampaignRecord(
                    serial=outcome.campaign.serial, unit_type=outcome.campaign.unit_type,
                    title=outcome.campaign.title, spec_name=outcome.campaign.spec.name,
                    overall=outcome.overall, report_id=outcome.report_id, tested_from=lo,
                    tested_to=hi, filed_at=filed_at,
                    runs=tuple((stored[t.test.name].stored_run or "", t.test.name)
                               for t in performed),
                    document={})
                campaign_uuid = record.campaign_uuid
                final = _with_stored(outcome, stored, campaign_uuid, db, filed_at)
                add_campaign(db, replace(record, document=final.to_dict()))

        report = None
        if report_dir is not None:
            from inertest.report.acceptance import write_acceptance_report

            with target_directory(report_dir, inputs=inputs) as folder:
                file_all()
                final = _with_stored(outcome, stored, campaign_uuid, db, filed_at)
                write_acceptance_report(
                    folder, final.to_dict(),
                    {t.test.name: t.outcome.result for t in final.tests if t.outcome},
                    command=command)
            report = Path(report_dir) / "index.html"
        else:
            file_all()
        final = _with_stored(outcome, stored, campaign_uuid, db, filed_at)
        return replace(final, report=report)
    except BaseException:
        _withdraw(db, filed, campaign_uuid, created)
        raise
    finally:
        if db is not None and own:
            db.close()


def _with_item(plan: Plan, item: TestItem) -> Plan:
    """``plan`` with the campaign's job and item over what its ``[test]`` states."""
    if item == TestItem():
        return plan
    cond = plan.test if plan.test is not None else TestConditions()
    return replace(plan, test=replace(cond, item=item.over(cond.item)))


def _with_stored(outcome: AcceptanceOutcome, stored: Mapping[str, RunOutcome],
                 campaign_uuid: str | None, db: Any, filed_at: datetime | None
                 ) -> AcceptanceOutcome:
    tests = tuple(replace(t, outcome=stored.get(t.test.name, t.outcome)) for t in outcome.tests)
    return replace(outcome, tests=tests, campaign_uuid=campaign_uuid,
                   database=None if db is None else db.display_url, filed_at=filed_at)


def _withdraw(db: Any, runs: Sequence[str], campaign_uuid: str | None, created: bool) -> None:
    """Undo a partly filed campaign (its row, its runs; a database it created, whole)."""
    if db is None:
        return
    try:
        if campaign_uuid is not None:
            from inertest.store.campaigns import discard_campaign

            discard_campaign(db, campaign_uuid)
        for u in runs:
            db.discard(u)
    except InertestError:
        pass
    if created and db.path is not None:
        db.close()
        for suffix in ("", "-wal", "-shm", "-journal"):
            Path(str(db.path) + suffix).unlink(missing_ok=True)


def plans_of(c: Campaign) -> list[tuple[CampaignTest, Plan]]:
    """Each test with its plan (for ``plan-check``)."""
    return [(t, load_plan(t.plan)) for t in c.tests]


__all__ = ["NOT_TESTED", "NOT_VERIFIED", "SERIES_VERDICTS", "AcceptanceOutcome", "Campaign",
           "CampaignError", "CampaignTest", "ClauseVerdict", "TestOutcome", "plans_of",
           "read_campaign", "run_campaign"]
