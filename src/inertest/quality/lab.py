"""The lab's test equipment: identities, calibration status and Type-B uncertainties.

A lab equipment file (TOML) lists every table, dividing head and centrifuge a plan may name in
its ``[test]`` table (:class:`inertest.plan.TestConditions`)::

    [[equipment]]
    id = "RT-02"                      # referenced from the plan
    name = "Two-axis rate table"
    model = "Acutronic AC2247"        # free text
    serial = "4711"
    calibrated = 2026-03-01           # TOML dates
    calibration_due = 2027-03-01
    certificate = "DKD-K-12345 2026-03"
    [equipment.type_b]                # standard uncertainties (k = 1) this equipment contributes
    rate_ppm = 5.0                    # rate accuracy
    tilt_urad = 20.0                  # axis tilt / alignment
    angle_arcsec = 2.0                # encoder / dividing-head angle error

Type-B keys carry their unit in a suffix (:data:`TYPE_B_UNITS`); each record keeps the values as
written and offers them in SI, named without the suffix (``rate`` [1], ``tilt`` [rad]).
The records are what ISO/IEC 17025 7.8.2 asks a report to identify: the equipment used, and
whether its calibration was valid on the test date. The file's optional ``[laboratory]``
(name, address, accreditation: :func:`laboratory_from_mapping`) and ``[signatories]``
(:func:`signatories_from_mapping`) name the laboratory and who reviews and approves its reports.
"""

from __future__ import annotations

import datetime as _dt
import os
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from inertest.errors import PlanError
from inertest.plan import (
    Field,
    TestConditions,
    check_finite_document,
    check_known_keys,
    did_you_mean,
    read_fields,
)
from inertest.units import ARCSEC_TO_RAD, DEG_TO_RAD, MICRORAD_TO_RAD, PPM_TO_RATIO


class LabFileError(PlanError):
    """A lab equipment file is missing, unreadable or inconsistent with a plan."""


#: Unit suffix of a Type-B key -> (unit as printed, factor to SI).
#: mGal: 1 mGal = 1e-5 m/s^2; um: micrometre.
TYPE_B_UNITS: dict[str, tuple[str, float]] = {
    "_ppm": ("ppm", PPM_TO_RATIO),
    "_urad": ("urad", MICRORAD_TO_RAD),
    "_arcsec": ("arcsec", ARCSEC_TO_RAD),
    "_um": ("um", 1e-6),
    "_mgal": ("mGal", 1e-5),
    "_deg": ("deg", DEG_TO_RAD),
}

_RECORD_FIELDS = (
    Field("id", "text", doc='the identifier plans use, e.g. id = "RT-02"'),
    Field("name", "text", default=""),
    Field("model", "text", default=""),
    Field("serial", "text", default=""),
    Field("certificate", "text", default=""),
)
_DATE_KEYS = ("calibrated", "calibration_due")


@dataclass(frozen=True)
class TypeB:
    """One Type-B standard uncertainty (k = 1) of a piece of equipment.

    Attributes
    ----------
    key : str
        As written in the file, with its unit suffix (``"tilt_urad"``).
    name : str
        Without the suffix (``"tilt"``).
    value : float
        As written, in ``unit``.
    unit : str
        ``"ppm"``, ``"urad"``, ``"arcsec"``, ``"um"``, ``"mGal"`` or ``"deg"``.
    si : float
        The same in SI: ratio, rad, m or m/s^2.
    """

    key: str
    name: str
    value: float
    unit: str
    si: float


@dataclass(frozen=True)
class Equipment:
    """One item of test equipment from the lab file.

    Attributes
    ----------
    id, name, model, serial, certificate : str
        Identity as written in the lab file.
    calibrated, calibration_due : datetime.date or None
        Date of the last calibration and the date the next one is due.
    type_b : tuple of TypeB
        Standard uncertainties (k = 1) this item contributes, in file order.
    """

    id: str
    name: str = ""
    model: str = ""
    serial: str = ""
    certificate: str = ""
    calibrated: _dt.date | None = None
    calibration_due: _dt.date | None = None
    type_b: tuple[TypeB, ...] = field(default=())

    @property
    def type_b_si(self) -> dict[str, float]:
        """``{name without suffix: value in SI}``, e.g. ``{"tilt": 2e-5}`` [rad]."""
        return {t.name: t.si for t in self.type_b}

    def overdue(self, on: _dt.date) -> bool:
        """True when the calibration was due before ``on`` (the test date)."""
        return self.calibration_due is not None and self.calibration_due < on

    def to_dict(self, test_date: _dt.date | None = None) -> dict[str, object]:
        """JSON form; dates as ISO text, Type-B values with their units, ``overdue`` when known."""
        d: dict[str, object] = {
            "id": self.id, "name": self.name, "model": self.model, "serial": self.serial,
            "certificate": self.certificate,
            "calibrated": None if self.calibrated is None else self.calibrated.isoformat(),
            "calibration_due": (None if self.calibration_due is None
                                else self.calibration_due.isoformat()),
            "type_b": {t.key: {"value": t.value, "unit": t.unit} for t in self.type_b},
        }
        if test_date is not None:
            d["calibration_overdue"] = self.overdue(test_date)
        return d


def _date(v: Any, key: str, where: str) -> _dt.date | None:
    if v is None:
        return None
    if isinstance(v, _dt.datetime):
        return v.date()
    if isinstance(v, _dt.date):
        return v
    if isinstance(v, str):
        try:
            return _dt.date.fromisoformat(v)
        except ValueError:
            pass
    raise LabFileError(f"{where}: {key} must be a date such as {key} = 2027-03-01, got {v!r}")


def _type_b(t: Any, where: str) -> tuple[TypeB, ...]:
    if t is None:
        return ()
    if not isinstance(t, Mapping):
        raise LabFileError(f"{where}: type_b must be a table [equipment.type_b]")
    out = []
    for key, v in t.items():
        suffix = next((s for s in TYPE_B_UNITS if key.endswith(s) and len(key) > len(s)), None)
        if suffix is None:
            raise LabFileError(
                f"{where}: type_b key {key} has no unit suffix; end it with one of "
                f"{', '.join(TYPE_B_UNITS)} (e.g. tilt_urad = 20.0)")
        unit, factor = TYPE_B_UNITS[suffix]
        x = read_fields({key: v}, (Field(key, unit=unit, minimum=0.0),), f"{where}: type_b",
                        error=LabFileError)[key]
        out.append(TypeB(key=key, name=key[: -len(suffix)], value=x, unit=unit, si=x * factor))
    return tuple(out)


def equipment_from_mapping(
    doc: Mapping[str, Any], *, source: str = "lab file"
) -> dict[str, Equipment]:
    """The equipment records of a parsed lab file, keyed by id in file order.

    Raises
    ------
    LabFileError
        No ``[[equipment]]`` entries, an unknown key (with did-you-mean), a duplicate id, a date
        that is not a date, a due date before the calibration date, or a Type-B key without a
        unit suffix.
    """
    check_known_keys(doc, {"equipment", "signatories", "laboratory"}, source,
                     error=LabFileError)
    items = doc.get("equipment")
    if not isinstance(items, list) or not items:
        raise LabFileError(f"{source} has no [[equipment]] entries; see "
                           "examples/lab/equipment.toml")
    out: dict[str, Equipment] = {}
    for i, t in enumerate(items):
        where = f"{source}: [[equipment]] #{i + 1}"
        if not isinstance(t, Mapping):
            raise LabFileError(f"{where} must be a table")
        v = read_fields(t, _RECORD_FIELDS, where, ignore=(*_DATE_KEYS, "type_b"),
                        error=LabFileError)
        where = f'{source}: equipment "{v["id"]}"'
        if v["id"] in out:
            raise LabFileError(f'{where} is listed twice; give each item its own id')
        cal, due = (_date(t.get(k), k, where) for k in _DATE_KEYS)
        if cal is not None and due is not None and due < cal:
            raise LabFileError(f"{where}: calibration_due {due} is before calibrated {cal}")
        out[v["id"]] = Equipment(**v, calibrated=cal, calibration_due=due,
                                 type_b=_type_b(t.get("type_b"), where))
    return out


def read_equipment(path: str | os.PathLike[str]) -> dict[str, Equipment]:
    """Read a lab equipment file (TOML); see the module docstring for its layout.

    Parameters
    ----------
    path : path-like
        The lab file, e.g. ``examples/lab/equipment.toml``.

    Returns
    -------
    dict of str to Equipment
        The records keyed by id, in file order.
    """
    source = f"lab file {os.fspath(path)}"
    doc = read_toml_file(path, source=source, error=LabFileError,
                         missing="give --equipment the lab's equipment file (see "
                         "examples/lab/equipment.toml)")
    return equipment_from_mapping(doc, source=source)


_SIGNATORY_FIELDS = (
    Field("reviewed_by", "text", default="", doc="who reviews the lab's reports"),
    Field("approved_by", "text", default="", doc="who approves (signs) them"),
)


def signatories_from_mapping(doc: Mapping[str, Any], *, source: str = "lab file"
                             ) -> dict[str, str]:
    """A lab file's ``[signatories]`` (``reviewed_by``, ``approved_by``), empty when absent.

    ::

        [signatories]
        reviewed_by = "B. Reviewer"
        approved_by = "C. Quality-Manager"

    A plan's ``[test] reviewed_by`` / ``approved_by`` win over these.
    """
    return _text_table(doc, "signatories", _SIGNATORY_FIELDS, source)


def read_signatories(path: str | os.PathLike[str]) -> dict[str, str]:
    """The ``[signatories]`` of the lab file ``path`` (:func:`signatories_from_mapping`)."""
    doc, source = _lab_document(path)
    return signatories_from_mapping(doc, source=source)


def _text_table(doc: Mapping[str, Any], table: str, fields: tuple[Field, ...], source: str
                ) -> dict[str, str]:
    """The given (non-empty) text fields of the lab file's ``[table]``; none when absent."""
    t = doc.get(table, {})
    if not isinstance(t, Mapping):
        raise LabFileError(f"{source}: [{table}] must be a table")
    v = read_fields(t, fields, f"{source}: [{table}]", error=LabFileError)
    return {k: x for k, x in v.items() if x}


def _lab_document(path: str | os.PathLike[str]) -> tuple[dict[str, Any], str]:
    """The lab file ``path`` parsed, and its name for messages."""
    source = f"lab file {os.fspath(path)}"
    return read_toml_file(path, source=source, error=LabFileError,
                          missing="give --equipment the lab's equipment file"), source


_LABORATORY_FIELDS = (
    Field("name", "text", default="", doc="the laboratory's name as on its reports"),
    Field("address", "text", default="", doc="where the tests are performed"),
    Field("accreditation", "text", default="",
          doc='accreditation body and number, e.g. "DAkkS D-PL-12345-01-00"'),
)
#: The keys of a lab file's ``[laboratory]``, in the order a report states them.
LABORATORY_KEYS = tuple(f.name for f in _LABORATORY_FIELDS)


def laboratory_from_mapping(doc: Mapping[str, Any], *, source: str = "lab file"
                            ) -> dict[str, str]:
    """A lab file's ``[laboratory]`` (``name``, ``address``, ``accreditation``), empty if absent.

    ::

        [laboratory]
        name = "Inertial Test Laboratory"
        address = "1 Test Street, 12345 Town, Country"
        accreditation = "DAkkS D-PL-12345-01-00"

    Every report and certificate states them (ISO/IEC 17025:2017 7.8.2.1 b), "not stated"
    where the lab file gives none.
    """
    return _text_table(doc, "laboratory", _LABORATORY_FIELDS, source)


def read_laboratory(path: str | os.PathLike[str]) -> dict[str, str]:
    """The ``[laboratory]`` of the lab file ``path`` (:func:`laboratory_from_mapping`)."""
    doc, source = _lab_document(path)
    return laboratory_from_mapping(doc, source=source)


def read_toml_file(path: str | os.PathLike[str], *, source: str, error: type[PlanError],
                   missing: str) -> dict[str, Any]:
    """Parse the TOML file ``path``; a missing, unreadable or invalid file raises ``error``.

    ``source`` names the file in the messages (``"lab file PATH"``); ``missing`` is the fix
    given when it does not exist.
    """
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except FileNotFoundError:
        raise error(f"{source} does not exist; {missing}") from None
    except OSError as exc:
        raise error(f"{source} cannot be read: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{source} is not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise error(f"{source} is not UTF-8 text; save it as UTF-8") from None
    check_finite_document(doc, source, fix="give a finite number", error=error)
    return doc


def select_equipment(
    lab: Mapping[str, Equipment], ids: Iterable[str], *, plan_source: str = "the plan",
    lab_source: str = "the lab file",
) -> tuple[Equipment, ...]:
    """The records a plan's ``[test] equipment`` names; an unknown id names both files."""
    out = []
    for eid in ids:
        if eid not in lab:
            raise LabFileError(
                f'{plan_source}: [test] equipment "{eid}" is not in {lab_source}'
                f"{did_you_mean(eid, lab)}; add it there or correct the id (known: "
                f"{', '.join(lab) or 'none'})")
        out.append(lab[eid])
    return tuple(out)


def overdue_messages(equipment: Sequence[Equipment], test_date: _dt.date) -> list[str]:
    """One warning per item whose calibration was overdue on ``test_date``."""
    return [f"Calibration of {e.id} ({e.name or e.model or 'equipment'}, serial "
            f"{e.serial or 'unknown'}) was due {e.calibration_due}, before the test date "
            f"{test_date}: the results are not traceable until it is recalibrated"
            for e in equipment if e.overdue(test_date)]


def unchecked_equipment_message(ids: Iterable[str]) -> str:
    """The warning for a plan naming equipment when no lab file was given."""
    return (f"the plan names equipment {', '.join(ids)} but no lab equipment file was given: "
            "the ids and calibration due dates are not checked and no equipment Type-B "
            "contribution is included in the uncertainty (give --equipment LAB.toml)")


@dataclass(frozen=True)
class TestTime:
    """When the test was performed, and where that date comes from.

    Attributes
    ----------
    at : datetime
        The test time (UTC); midnight UTC when only a date is known.
    date : datetime.date
        The test date: the date of ``at``.
    has_time : bool
        Whether a time of day is known (a plan date-time, ``--tested-at`` with a time, or the
        time of the analysis) or only the date.
    source : str
        ``"plan"`` (the plan's ``[test] date``), ``"--tested-at"`` (given, overriding any plan
        date) or ``"analysis"`` (neither: the time of the analysis).
    overrides : datetime.date or None
        The plan's ``[test] date`` that ``--tested-at`` overrides (when it differs).
    """

    __test__ = False                     # not a pytest class despite its name

    at: _dt.datetime
    date: _dt.date
    has_time: bool
    source: str
    overrides: _dt.date | None = None

    @property
    def text(self) -> str:
        """The test date as printed: ``2026-11-20`` or ``2026-11-20 09:30 UTC``."""
        return (f"{self.at:%Y-%m-%d %H:%M} UTC" if self.has_time and self.at.time() != _dt.time()
                else self.date.isoformat())

    @property
    def source_text(self) -> str:
        """Where the date comes from, as a sentence fragment for reports."""
        if self.source == "plan":
            return "the plan's [test] date"
        if self.source == "--tested-at":
            return ("--tested-at" + (f", overriding the plan's [test] date {self.overrides}"
                                     if self.overrides is not None else ""))
        return "the time of the analysis (the plan gives no [test] date)"

    def to_dict(self) -> dict[str, str | None]:
        """``{"date", "tested_at", "date_source"}`` as in the envelope's ``test`` block."""
        return {"date": self.date.isoformat(),
                "tested_at": self.at.isoformat(timespec="seconds") if self.has_time else None,
                "date_source": self.source}

    def override_message(self) -> str | None:
        """The notice printed when ``--tested-at`` overrides the plan's date, else None."""
        if self.overrides is None:
            return None
        return (f"--tested-at {self.text} overrides the plan's [test] date {self.overrides}: "
                "the record, report, equipment status and history use the --tested-at date")


def test_time(
    conditions: TestConditions | None, given: _dt.datetime | None = None, *,
    now: _dt.datetime | None = None,
) -> TestTime:
    """The one test date of a run: ``--tested-at``, else the plan's ``[test] date``, else now.

    Parameters
    ----------
    conditions : TestConditions or None
        The plan's ``[test]`` table (its ``date``, with ``time_utc`` when the plan gives a
        date-time).
    given : datetime, optional
        ``--tested-at`` (a naive time is UTC); it overrides the plan's date, and says so.
    now : datetime, optional
        The time of the analysis (default: now, UTC).

    Returns
    -------
    TestTime
        Used for the record, the report, the equipment's calibration status, the history axis
        and its trend alike.
    """
    plan_date = conditions.date if conditions is not None else None
    if given is not None:
        at = given.replace(tzinfo=_dt.UTC) if given.tzinfo is None else given.astimezone(_dt.UTC)
        over = plan_date if plan_date is not None and plan_date != at.date() else None
        return TestTime(at, at.date(), True, "--tested-at", over)
    if plan_date is not None:
        t = conditions.time_utc if conditions is not None else None
        at = _dt.datetime.combine(plan_date, t or _dt.time(), tzinfo=_dt.UTC)
        return TestTime(at, plan_date, t is not None, "plan")
    at = (now or _dt.datetime.now(_dt.UTC)).astimezone(_dt.UTC)
    return TestTime(at, at.date(), True, "analysis")


def identity_block(
    conditions: TestConditions | None,
    *,
    lab: Mapping[str, Equipment] | None,
    tested: TestTime,
    software_version: str,
    data_sha256: str,
    plan_source: str = "the plan",
    lab_source: str = "the lab file",
    signatories: Mapping[str, str] | None = None,
    laboratory: Mapping[str, str] | None = None,
) -> dict[str, object]:
    """The envelope's ``test`` block: who, for whom, when, with what, in which conditions.

    Parameters
    ----------
    conditions : TestConditions or None
        The plan's ``[test]`` table.
    lab : mapping of str to Equipment, or None
        The lab file's records; without it the equipment ids are listed unresolved.
    tested : TestTime
        The one test date (:func:`test_time`): the equipment's calibration status is judged on
        it.
    software_version, data_sha256 : str
    signatories : mapping, optional
        The lab file's ``[signatories]`` (``reviewed_by``, ``approved_by``); the plan's
        ``[test]`` names win.
    laboratory : mapping, optional
        The lab file's ``[laboratory]`` (:func:`laboratory_from_mapping`).

    Returns
    -------
    dict
        ``{"operator", "date", "tested_at", "date_source", "software_version", "data_sha256",
        "equipment": [{"id", "name", "model", "serial", "certificate", "calibrated",
        "calibration_due", "calibration_overdue", "type_b"}], "environment": {name: {"value",
        "unit"}}, "notes", "certificate", "approval": {"performed_by", "performed_on",
        "reviewed_by", "reviewed_on", "approved_by", "approved_on"}, "laboratory": {"name",
        "address", "accreditation"}, "customer", "customer_contact", "receipt_date",
        "condition_on_receipt", "deviations", "data_origin"}`` (None where not stated; the
        plan's :class:`~inertest.plan.TestItem`); ``"filed_at"`` is added when the run is
        stored (:func:`inertest.app.run.file_run`).
    """
    c = conditions if conditions is not None else TestConditions()
    date = tested.date
    if lab is not None:
        items: list[dict[str, object]] = [
            e.to_dict(date) for e in select_equipment(lab, c.equipment, plan_source=plan_source,
                                                      lab_source=lab_source)]
    else:
        items = [{"id": i, "calibration_due": None, "calibration_overdue": None}
                 for i in c.equipment]
    sig = dict(signatories or {})
    return {
        "operator": c.operator, **tested.to_dict(),
        "software_version": software_version, "data_sha256": data_sha256,
        "equipment": items, "environment": c.environment(), "notes": c.notes,
        "certificate": c.certificate or None,
        "approval": {
            "performed_by": c.operator or None, "performed_on": date.isoformat(),
            "reviewed_by": c.reviewed_by or sig.get("reviewed_by") or None,
            "reviewed_on": None if c.review_date is None else c.review_date.isoformat(),
            "approved_by": c.approved_by or sig.get("approved_by") or None,
            "approved_on": None if c.approval_date is None else c.approval_date.isoformat(),
        },
        "laboratory": {k: (laboratory or {}).get(k) or None for k in LABORATORY_KEYS},
        **c.item.to_dict(),
    }
