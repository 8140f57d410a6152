"""What is stored about a run, without the database: records, labels, the stored envelope text.

Apart from :mod:`inertest.store.history` so that a batch worker can prepare a run's record
without importing SQLAlchemy and Alembic (0.6 s of CPU in each worker process; the first
stored batch of a cluster paid it on every worker at once).
"""

from __future__ import annotations

import json
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from inertest.errors import InertestError, InputError
from inertest.results import read_envelope


class StoreError(InertestError):
    """The history database cannot be used (unreachable, newer schema, unknown serial)."""


#: Longest serial or label stored (the ``runs.serial`` column is VARCHAR(200)).
MAX_LABEL_CHARS = 200


def check_label(text: object, what: str = "serial") -> str:
    """``text`` if it can be stored and shown as a serial or label on every backend.

    Printable characters only (no NUL, which PostgreSQL refuses, no terminal escape codes or
    newlines), at most :data:`MAX_LABEL_CHARS` characters; anything else is a
    :class:`StoreError` naming the fix.
    """
    if not isinstance(text, str):
        raise StoreError(f"the {what} must be text, got {type(text).__name__}")
    if len(text) > MAX_LABEL_CHARS:
        raise StoreError(f"the {what} has {len(text)} characters; at most {MAX_LABEL_CHARS} can "
                         f"be stored: shorten it")
    bad = next((c for c in text if not c.isprintable()), None)
    if bad is not None:
        raise StoreError(f"the {what} {text.encode('unicode_escape').decode('ascii')[:80]!r} "
                         f"holds the control character U+{ord(bad):04X}; use printable text")
    return text


@dataclass(frozen=True)
class StoredEstimate:
    """A coefficient or combination as stored, in engineering units."""

    name: str
    kind: str
    value: float
    std: float
    unit: str
    terms: Mapping[str, float] | None = None


@dataclass(frozen=True)
class RunRecord:
    """Everything stored about one fit.

    ``tested_at`` is when the test was performed (the one test date,
    :func:`inertest.quality.lab.test_time`): the history's axis. ``filed_at`` is when the run
    was stored (the ``stored_at`` column); None until it is.
    """

    serial: str
    instrument_kind: str
    procedure: str
    tested_at: datetime
    software_version: str
    latitude_deg: float | None
    gravity_m_s2: float | None
    plan_text: str
    data_sha256: str
    n_observations: int
    dof: int
    estimates: tuple[StoredEstimate, ...]
    result: Mapping[str, Any] = field(repr=False)
    residual_rms: float | None = None
    residual_unit: str | None = None
    noise_sigma: float | None = None
    noise_unit: str | None = None
    run_uuid: str = field(default_factory=lambda: str(uuid.uuid4()))
    filed_at: datetime | None = None
    #: The envelope as JSON text, when made beforehand (a batch worker writes it, so that the
    #: process filing the run does not serialise it again); else written on :meth:`add`.
    result_json: str | None = field(default=None, repr=False, compare=False)

    @classmethod
    def from_result(
        cls,
        result: Mapping[str, Any],
        *,
        serial: str,
        instrument_kind: str,
        plan_text: str,
        data_sha256: str,
        software_version: str,
        tested_at: datetime | None = None,
        filed_at: datetime | None = None,
        serialise: bool = False,
    ) -> RunRecord:
        """Build from any result's ``to_dict()`` (the result envelope, schema version 2).

        ``tested_at``: when the test was performed (default now); ``filed_at``: when it is
        stored (default: the time of :meth:`HistoryStore.add`). ``serialise``: write the
        envelope's JSON text now (:attr:`result_json`), where the result was computed.

        Every kind can be stored: the identification block (coefficients and combinations),
        when the kind has one, becomes the run's estimates; the whole envelope is kept as the
        run's result document.
        """
        if not serial:
            raise StoreError(
                "the plan gives no [instrument] serial; a run cannot be stored without one "
                "(add serial = \"...\" or use --no-store)"
            )
        check_label(serial, "[instrument] serial")
        try:
            doc: dict[str, Any] = read_envelope(result, source="the result to store")
        except InputError as exc:
            raise StoreError(f"{exc}; pass result.to_dict()") from None
        result = doc
        ident = doc.get("identification") or {}
        ests = [
            StoredEstimate(n, "coefficient", float(e["value"]), float(e["std"]), str(e["unit"]))
            for n, e in (ident.get("coefficients") or {}).items()
        ]
        ests += [
            StoredEstimate(c["name"], "combination", float(c["value"]), float(c["std"]),
                           str(c["unit"]), dict(c["terms"]))
            for c in ident.get("combinations") or []
        ]
        site = doc.get("site") or {}
        noise = ident.get("noise") or {}
        rms = ident.get("residual_rms") or {}
        sigma = noise.get("sigma")
        return cls(
            serial=serial,
            instrument_kind=instrument_kind,
            procedure=str(result["kind"]),
            tested_at=as_utc(tested_at or datetime.now(UTC)),
            software_version=software_version,
            latitude_deg=_optional_float(site.get("latitude_deg")),
            gravity_m_s2=_optional_float(site.get("gravity_m_s2")),
            plan_text=plan_text,
            data_sha256=data_sha256,
            n_observations=int(ident.get("n_observations", 0)),
            dof=int(ident.get("dof", 0)),
            estimates=tuple(ests),
            result=result,
            residual_rms=None if rms.get("value") is None else float(rms["value"]),
            residual_unit=rms.get("unit"),
            noise_sigma=None if sigma is None or sigma != sigma else float(sigma),
            noise_unit=noise.get("unit"),
            filed_at=None if filed_at is None else as_utc(filed_at),
            result_json=envelope_json(result) if serialise else None,
        )


def envelope_json(doc: Mapping[str, Any]) -> str:
    """The stored text of an envelope; the filing time is kept in ``stored_at`` alone."""
    test = doc.get("test")
    if isinstance(test, Mapping) and "filed_at" in test:
        doc = {**doc, "test": {k: v for k, v in test.items() if k != "filed_at"}}
    return json.dumps(doc, allow_nan=True)


def _optional_float(v: object) -> float | None:
    return None if v is None else float(v)  # type: ignore[arg-type]


def as_utc(t: datetime) -> datetime:
    """``t`` in UTC; a naive time (as SQLite returns them) is taken as UTC, as it was stored."""
    return t.replace(tzinfo=UTC) if t.tzinfo is None else t.astimezone(UTC)
