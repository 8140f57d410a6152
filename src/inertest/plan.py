"""A test plan: where (site), what (instrument) and how (procedure), without any file I/O.

Plan files are TOML (read by :mod:`inertest.io.plan_file`)::

    [site]
    latitude_deg = 34.25        # gravity = 9.7966 (m/s^2, optional: normal gravity otherwise)

    [instrument]
    kind = "sdf-gyro"
    serial = "FG-17"
    output_unit = "mA"          # or a rate unit: "deg/h", "deg/s", "rad/s"
    scale_factor = 12.5         # S_T [deg/h per output unit]; needed when the output is not a rate

    [procedure]
    kind = "polar-tumble"       # parameters of the procedure follow
"""

from __future__ import annotations

import datetime as _dt
import difflib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertest.earth import Site
from inertest.errors import InertestError, PlanError
from inertest.units import (
    ACCEL_UNITS,
    COUNT_UNITS,
    DEG_PER_H_TO_RAD_PER_S,
    ELECTRICAL_UNITS,
    RATE_UNITS,
)

#: Instrument kinds a plan may name; each procedure says which it accepts.
INSTRUMENT_KINDS: tuple[str, ...] = (
    "sdf-gyro", "rate-gyro", "accelerometer", "gyro-triad", "accelerometer-triad", "imu",
)


@dataclass(frozen=True)
class Instrument:
    """The instrument under test and how its output is read.

    Attributes
    ----------
    kind : str
        Instrument kind (``"sdf-gyro"``).
    serial : str
        Serial number (free text).
    output_unit : str
        Unit of the recorded output: a rate unit (``deg/h``, ``deg/s``, ``rad/s``), an
        electrical unit (``mA``, ``uA``, ``A``, ``V``, ``mV``) of a torque-rebalance loop, a
        specific-force unit (``m/s^2``, ``g``, ``mg``, ``ug``) or ``count`` (raw digital output).
    scale_factor : float or None
        Torquer scale factor S_T [deg/h per output unit] for electrical outputs.
    """

    kind: str = "sdf-gyro"
    serial: str = ""
    output_unit: str = "deg/h"
    scale_factor: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in INSTRUMENT_KINDS:
            raise PlanError(
                f'unknown instrument kind "{self.kind}"; use one of {", ".join(INSTRUMENT_KINDS)}'
            )
        known = [*RATE_UNITS, *ELECTRICAL_UNITS, *ACCEL_UNITS, *COUNT_UNITS]
        if self.output_unit not in known:
            raise PlanError(
                f'unknown output_unit "{self.output_unit}"; use one of {", ".join(known)}'
            )
        if self.kind == "sdf-gyro" and self.output_unit not in RATE_UNITS:
            sf = self.scale_factor
            if sf is None or not np.isfinite(sf) or sf == 0:
                raise PlanError(
                    f'output_unit "{self.output_unit}" needs [instrument] scale_factor = S_T in '
                    f"deg/h per {self.output_unit} (finite, non-zero)"
                )

    @property
    def rad_s_per_output_unit(self) -> float:
        """Factor from the recorded output to the indicated rate [rad/s per output unit].

        A rate output converts by its unit; any other output needs the scale factor
        [deg/h per output unit].
        """
        if self.output_unit in RATE_UNITS:
            return RATE_UNITS[self.output_unit]
        if self.scale_factor is None:
            raise PlanError(
                f'output_unit "{self.output_unit}" is not a rate: give [instrument] scale_factor '
                f"in deg/h per {self.output_unit}"
            )
        return float(self.scale_factor) * DEG_PER_H_TO_RAD_PER_S

    def output_to_rate(self, output: ArrayLike) -> NDArray[np.float64]:
        """Indicated rate [rad/s] from recorded output (``S_T * i`` for a torque loop)."""
        return np.asarray(output, dtype=float) * self.rad_s_per_output_unit

    def rate_to_output(self, rate_rad_s: ArrayLike) -> NDArray[np.float64]:
        """Recorded output for an indicated rate [rad/s]."""
        return np.asarray(rate_rad_s, dtype=float) / self.rad_s_per_output_unit


@dataclass(frozen=True)
class Plan:
    """A complete test plan.

    Attributes
    ----------
    site : Site
    instrument : Instrument
    procedure : Any
        The procedure's own parameter object (e.g. :class:`~inertest.procedures.polar_tumble.
        PolarTumbleSpec`), whose ``kind`` names the procedure.
    test : TestConditions or None
        The optional ``[test]`` table: operator, date, equipment ids, environment.
    """

    site: Site
    instrument: Instrument
    procedure: Any
    test: TestConditions | None = None

    @property
    def kind(self) -> str:
        """The procedure kind, e.g. ``"polar-tumble"``."""
        return str(self.procedure.kind)


def toml_table(
    doc: Mapping[str, Any], name: str, source: str, *, error: type[InertestError] = PlanError
) -> Mapping[str, Any]:
    """The ``[name]`` table of a parsed TOML document (empty when absent); ``error`` otherwise."""
    t = doc.get(name, {})
    if not isinstance(t, Mapping):
        raise error(f"{source}: [{name}] must be a table")
    return t


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """`` (did you mean "x"?)`` for the closest known name, or an empty string."""
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f' (did you mean "{close[0]}"?)' if close else ""


def check_known_keys(
    t: Mapping[str, Any], known: set[str], where: str, *, error: type[InertestError] = PlanError
) -> None:
    """Reject keys not in ``known``: a misspelt key would otherwise be a silent default."""
    unknown = sorted(set(t) - known)
    if unknown:
        hints = "".join(did_you_mean(k, known) for k in unknown[:1])
        raise error(f"{where}: unknown key(s) {', '.join(unknown)}{hints}; known: "
                    f"{', '.join(sorted(known))}")


_REQUIRED: Any = object()


@dataclass(frozen=True)
class Field:
    """One parameter of a plan table, read by :func:`read_fields`.

    Attributes
    ----------
    name : str
        Key in the table (units in the name's suffix, e.g. ``radius_m``).
    kind : str
        ``"number"`` (finite float; a boolean or text is refused), ``"integer"``, ``"bool"``,
        ``"text"``, ``"numbers"`` (non-empty list of finite floats), ``"texts"`` (non-empty list
        of text).
    default : object
        Value when absent; required when not given.
    unit : str
        Unit, for messages.
    minimum, maximum : float, optional
        Inclusive bounds of a number or integer (of every element of a list).
    positive : bool
        Strictly greater than zero.
    choices : tuple, optional
        Allowed values of a text (of every element of a list of texts).
    doc : str
        What the parameter is, for messages.
    """

    name: str
    kind: str = "number"
    default: Any = _REQUIRED
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    positive: bool = False
    choices: tuple[str, ...] | None = None
    doc: str = ""


def read_fields(
    table: Mapping[str, Any],
    fields: Sequence[Field],
    where: str,
    *,
    ignore: Iterable[str] = (),
    error: type[InertestError] = PlanError,
) -> dict[str, Any]:
    """Read a plan table by its declared fields: unknown keys, wrong types and bounds are errors.

    One reader for every table of every plan, so that a misspelt key, ``latitude_deg = true``
    or a count of ``2.5`` never becomes a silent default or a silently converted value.

    Parameters
    ----------
    table : mapping
        The parsed TOML table.
    fields : sequence of Field
        What the table may hold.
    where : str
        Where the table is, for messages (``"plan p.toml: [site]"``).
    ignore : iterable of str
        Keys read elsewhere (e.g. ``kind``).

    Returns
    -------
    dict
        ``{name: value}`` for every field, defaults filled in.
    """
    known = {f.name for f in fields} | set(ignore)
    check_known_keys(table, known, where, error=error)
    out: dict[str, Any] = {}
    for f in fields:
        if f.name not in table:
            if f.default is _REQUIRED:
                what = f" ({f.doc})" if f.doc else ""
                raise error(f"{where} needs {f.name}{what}")
            out[f.name] = f.default
            continue
        out[f.name] = _read_field(table[f.name], f, where, error)
    return out


def _read_field(v: Any, f: Field, where: str, error: type[InertestError]) -> Any:
    unit = f" [{f.unit}]" if f.unit else ""
    if f.kind in ("numbers", "texts"):
        if not isinstance(v, list) or not v:
            raise error(f"{where}: {f.name} must be a non-empty list{unit}, got {v!r}")
        one = Field(f.name, f.kind[:-1] if f.kind == "texts" else "number", unit=f.unit,
                    minimum=f.minimum, maximum=f.maximum, positive=f.positive,
                    choices=f.choices)
        return tuple(_read_field(x, one, where, error) for x in v)
    if f.kind == "bool":
        if not isinstance(v, bool):
            raise error(f"{where}: {f.name} must be true or false, got {v!r}")
        return v
    if f.kind == "text":
        if not isinstance(v, str):
            raise error(f"{where}: {f.name} must be text, got {v!r}")
        if f.choices is not None and v not in f.choices:
            raise error(f'{where}: {f.name} = "{v}" is not one of {", ".join(f.choices)}'
                        f"{did_you_mean(v, f.choices)}")
        return v
    if f.kind == "integer":
        if isinstance(v, bool) or not isinstance(v, int):
            raise error(f"{where}: {f.name} must be a whole number{unit}, got {v!r}")
        x: float = v
    else:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise error(f"{where}: {f.name} must be a number{unit}, got {v!r}")
        x = float(v)
        if not math.isfinite(x):
            raise error(f"{where}: {f.name} must be finite{unit}, got {v!r}")
    if f.positive and x <= 0:
        raise error(f"{where}: {f.name} must be positive{unit}, got {v!r}")
    if f.minimum is not None and x < f.minimum or f.maximum is not None and x > f.maximum:
        if f.maximum is None:
            bound = f"be >= {f.minimum:g}"
        elif f.minimum is None:
            bound = f"be <= {f.maximum:g}"
        else:
            bound = f"lie in [{f.minimum}, {f.maximum}]"
        raise error(f"{where}: {f.name} must {bound}{unit}, got {v!r}")
    return v if f.kind == "integer" else x


def finite_number(
    v: Any, key: str, source: str, *, error: type[InertestError] = PlanError
) -> float:
    """``v`` as a finite float; booleans and strings are errors naming ``key`` and ``source``."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise error(f"{source}: {key} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise error(f"{source}: {key} must be finite, got {v!r}")
    return x


#: Where the data of a test come from (``data_origin``): a real unit, or a simulation.
DATA_ORIGINS = ("measured", "simulated")


@dataclass(frozen=True)
class TestItem:
    """The job and the item tested, as a test report states them (ISO/IEC 17025:2017 7.8.2.1).

    Read from a plan's ``[test]`` table or a campaign manifest's ``[campaign]`` table
    (:func:`read_test_item`)::

        customer = "Example Avionics GmbH"          # e: the customer
        customer_contact = "J. Buyer, +49 ..."       # e: and how to reach them
        receipt_date = 2026-11-16                   # f: date of receipt of the item
        condition_on_receipt = "sealed, no damage"  # h: condition of the item on receipt
        deviations = ["thermal: 5 steps, not 7"]    # 7.8.3.1 a: [] states that there are none
        data_origin = "simulated"                   # or "measured"

    Attributes
    ----------
    customer, customer_contact, condition_on_receipt : str
        Empty when not stated.
    receipt_date : datetime.date or None
        When the item was received; None when not stated.
    deviations : tuple of str or None
        Deviations from, additions to or exclusions from the test method; ``()`` states that
        there are none, None that nothing is stated.
    data_origin : str
        ``"measured"``, ``"simulated"`` (:data:`DATA_ORIGINS`) or empty (not stated).
    """

    __test__ = False                     # not a pytest class despite its name

    customer: str = ""
    customer_contact: str = ""
    receipt_date: _dt.date | None = None
    condition_on_receipt: str = ""
    deviations: tuple[str, ...] | None = None
    data_origin: str = ""

    def over(self, other: TestItem) -> TestItem:
        """The statements of this item, and ``other``'s where this one states nothing."""
        return TestItem(
            customer=self.customer or other.customer,
            customer_contact=self.customer_contact or other.customer_contact,
            receipt_date=self.receipt_date or other.receipt_date,
            condition_on_receipt=self.condition_on_receipt or other.condition_on_receipt,
            deviations=self.deviations if self.deviations is not None else other.deviations,
            data_origin=self.data_origin or other.data_origin)

    def to_dict(self) -> dict[str, object]:
        """JSON form (the envelope's ``test`` block): None where not stated."""
        return {"customer": self.customer or None,
                "customer_contact": self.customer_contact or None,
                "receipt_date": None if self.receipt_date is None
                else self.receipt_date.isoformat(),
                "condition_on_receipt": self.condition_on_receipt or None,
                "deviations": None if self.deviations is None else list(self.deviations),
                "data_origin": self.data_origin or None}


TEST_ITEM_FIELDS = (
    Field("customer", "text", default="", doc="who ordered the test"),
    Field("customer_contact", "text", default="", doc="the customer's address or contact"),
    Field("condition_on_receipt", "text", default="",
          doc="the item's condition when received"),
    Field("data_origin", "text", default="", choices=DATA_ORIGINS,
          doc="whether the data are measured or simulated"),
)
#: Every key of :class:`TestItem` (``receipt_date`` and ``deviations`` are read on their own).
TEST_ITEM_KEYS = (*(f.name for f in TEST_ITEM_FIELDS), "receipt_date", "deviations")


def read_test_item(table: Mapping[str, Any], where: str, *,
                   error: type[InertestError] = PlanError) -> TestItem:
    """The :class:`TestItem` keys of ``table`` (other keys are the caller's to check).

    Raises
    ------
    error
        A key of the wrong type, a ``data_origin`` not in :data:`DATA_ORIGINS`, a
        ``receipt_date`` that is not a date, ``deviations`` that are not text or a list of text.
    """
    v = read_fields({k: table[k] for k in (f.name for f in TEST_ITEM_FIELDS) if k in table},
                    TEST_ITEM_FIELDS, where, error=error)
    d = table.get("receipt_date")
    if isinstance(d, str):
        try:
            d = _dt.date.fromisoformat(d)
        except ValueError:
            pass
    if isinstance(d, _dt.datetime):
        d = d.date()
    if d is not None and not isinstance(d, _dt.date):
        raise error(f"{where}: receipt_date must be a date such as receipt_date = 2026-11-16, "
                    f"got {d!r}")
    dev = table.get("deviations")
    if isinstance(dev, str):
        dev = [dev]
    if dev is not None and (not isinstance(dev, list)
                            or not all(isinstance(x, str) and x for x in dev)):
        raise error(f"{where}: deviations must be a list of text, e.g. deviations = "
                    '["thermal: 5 steps, not 7"], or [] when there are none; got '
                    f"{dev!r}")
    return TestItem(receipt_date=d, deviations=None if dev is None else tuple(dev), **v)


@dataclass(frozen=True)
class TestConditions:
    """Who ran the test, with what, and in which conditions: a plan's optional ``[test]`` table.

    ::

        [test]
        operator = "A. Engineer"     # performed by
        date = 2026-11-20            # test date: TOML date, or date-time 2026-11-20T09:30:00Z
        equipment = ["RT-02"]        # ids in the lab equipment file (inertest.quality.lab)
        temperature_C = 22.5
        humidity_pct = 41
        warm_up_min = 60
        notes = "thermal chamber closed"
        certificate = "CAL-2026-0117"  # certificate number (the report id)
        reviewed_by = "B. Reviewer"    # approval fields of the report (optional)
        review_date = 2026-11-23
        approved_by = "C. Quality-Manager"
        approval_date = 2026-11-24
        customer = "Example Avionics GmbH"   # the job and the item: TestItem
        receipt_date = 2026-11-16

    Attributes
    ----------
    operator : str
        Who performed the test.
    date : datetime.date or None
        The test date (UTC date of a date-time); the date of the analysis when absent.
    time_utc : datetime.time or None
        The time of day when ``date`` is a TOML date-time (an offset is converted to UTC; a
        local date-time is taken as UTC).
    equipment : tuple of str
        Ids of the equipment used, resolved against a lab file by :func:`inertest.quality.lab.
        select_equipment`.
    temperature_C : float or None
        Ambient (or chamber) temperature [degC].
    humidity_pct : float or None
        Relative humidity [%].
    warm_up_min : float or None
        Warm-up time of the instrument before the first measurement [min].
    notes : str
    certificate : str
        Certificate (report) number; the report id when given.
    reviewed_by, approved_by : str
        Who reviews and who approves the report (blank lines to sign when absent).
    review_date, approval_date : datetime.date or None
    item : TestItem
        Customer, receipt date, condition on receipt, deviations, data origin.
    """

    __test__ = False                     # not a pytest class despite its name

    operator: str = ""
    date: _dt.date | None = None
    time_utc: _dt.time | None = None
    equipment: tuple[str, ...] = ()
    temperature_C: float | None = None
    humidity_pct: float | None = None
    warm_up_min: float | None = None
    notes: str = ""
    certificate: str = ""
    reviewed_by: str = ""
    review_date: _dt.date | None = None
    approved_by: str = ""
    approval_date: _dt.date | None = None
    item: TestItem = TestItem()

    def environment(self) -> dict[str, dict[str, object]]:
        """``{name: {"value", "unit"}}`` of the conditions given (JSON and report rows)."""
        rows = (("temperature", self.temperature_C, "degC"),
                ("humidity", self.humidity_pct, "%"),
                ("warm_up", self.warm_up_min, "min"))
        return {n: {"value": v, "unit": u} for n, v, u in rows if v is not None}


TEST_FIELDS = (
    Field("operator", "text", default=""),
    Field("equipment", "texts", default=()),
    Field("temperature_C", default=None, unit="degC", minimum=-100.0, maximum=300.0),
    Field("humidity_pct", default=None, unit="%", minimum=0.0, maximum=100.0),
    Field("warm_up_min", default=None, unit="min", minimum=0.0),
    Field("notes", "text", default=""),
    Field("certificate", "text", default="", doc="the certificate (report) number"),
    Field("reviewed_by", "text", default="", doc="who reviews the report"),
    Field("approved_by", "text", default="", doc="who approves the report"),
)
#: Date keys of ``[test]`` (read by :func:`read_test_table`, not by :data:`TEST_FIELDS`).
TEST_DATE_KEYS = ("date", "review_date", "approval_date")


def read_test_table(table: Mapping[str, Any], where: str) -> TestConditions:
    """A plan's ``[test]`` table by :data:`TEST_FIELDS` (plus its dates); unknown keys are errors.

    ``date`` may be a TOML date or date-time (with its time of day, converted to UTC when it
    has an offset, taken as UTC when not); ``review_date`` and ``approval_date`` are dates.
    """
    if not isinstance(table, Mapping):
        raise PlanError(f"{where} must be a table")
    v = read_fields(table, TEST_FIELDS, where, ignore=(*TEST_DATE_KEYS, *TEST_ITEM_KEYS))
    dates: dict[str, _dt.date | None] = {}
    time_utc = None
    for key in TEST_DATE_KEYS:
        d = table.get(key)
        if isinstance(d, str):
            try:
                d = _dt.datetime.fromisoformat(d) if "T" in d or " " in d.strip() \
                    else _dt.date.fromisoformat(d)
            except ValueError:
                pass
        if isinstance(d, _dt.datetime):
            if d.tzinfo is not None:
                d = d.astimezone(_dt.UTC).replace(tzinfo=None)
            if key == "date":
                time_utc = d.time()
            d = d.date()
        if isinstance(d, _dt.time) or d is not None and not isinstance(d, _dt.date):
            raise PlanError(f"{where}: {key} must be a date such as {key} = 2026-11-20 (the "
                            f"test date may have a time: 2026-11-20T09:30:00Z), got {d!r}")
        dates[key] = d
    return TestConditions(date=dates["date"], time_utc=time_utc,
                          review_date=dates["review_date"],
                          approval_date=dates["approval_date"],
                          item=read_test_item(table, where), **v)


def check_finite_document(
    doc: Any, source: str, *, fix: str, error: type[InertestError] = PlanError,
    may_be_nan: Iterable[str] = (),
) -> None:
    """Refuse a parsed TOML/JSON document holding a NaN or infinite number anywhere.

    TOML and Python's JSON both read ``nan`` and ``inf``; a file that is read back (a
    calibration, a thermal model, a plan, a lab or specification file, a manifest) must never
    carry one into a result. Keys in ``may_be_nan`` hold diagnostics that may be undetermined
    (a p-value without degrees of freedom) and are skipped with everything under them.

    Raises
    ------
    error
        ``"SOURCE: KEY.PATH[3] is nan, not a finite number; FIX"``.
    """
    skip = set(may_be_nan)

    def walk(v: Any, path: str) -> None:
        if isinstance(v, float) and not math.isfinite(v):
            raise error(f"{source}: {path or 'the document'} is {v!r}, not a finite number; "
                        f"{fix}")
        if isinstance(v, Mapping):
            for k, x in v.items():
                if k not in skip:
                    walk(x, f"{path}.{k}" if path else str(k))
        elif isinstance(v, list | tuple):
            for i, x in enumerate(v):
                walk(x, f"{path}[{i}]")

    walk(doc, "")
