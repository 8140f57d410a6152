"""Acceptance campaigns in the history database: a series of runs on one unit, filed together.

A campaign (:mod:`inertest.app.acceptance`) files each of its runs as its own record of ``runs``
(:meth:`inertest.store.HistoryStore.add`, as every fit) and then one row of ``campaigns`` naming
the unit, its type, the specification, the overall verdict and the campaign's JSON document,
with one row of ``campaign_runs`` per run (migration 0003; databases written before it are
migrated on open and read as before: their runs belong to no campaign). Writes are single
transactions; :func:`discard_campaign` withdraws one whose later step failed.
"""

from __future__ import annotations

import json
import uuid
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session, selectinload

from inertest.store.history import HistoryStore, StoreError, check_label
from inertest.store.schema import Campaign, CampaignRun


@dataclass(frozen=True)
class CampaignRecord:
    """One stored campaign.

    Attributes
    ----------
    serial, unit_type, title, spec_name, overall, report_id : str
        The unit under test and its type, the campaign's title, the specification, the worst
        clause verdict, the certificate's id.
    tested_from, tested_to : datetime
        Earliest and latest test date of its runs (UTC).
    runs : tuple of (str, str)
        ``(run_uuid, test name)`` of each stored run, in the campaign's order.
    document : mapping
        The campaign's JSON (:meth:`inertest.app.acceptance.AcceptanceOutcome.to_dict`).
    """

    serial: str
    unit_type: str
    title: str
    spec_name: str
    overall: str
    report_id: str
    tested_from: datetime
    tested_to: datetime
    runs: tuple[tuple[str, str], ...]
    document: Mapping[str, Any] = field(repr=False)
    campaign_uuid: str = field(default_factory=lambda: str(uuid.uuid4()))
    filed_at: datetime | None = None


def add_campaign(store: HistoryStore, record: CampaignRecord) -> None:
    """Store a campaign row and its run links in one transaction (the runs already stored)."""
    check_label(record.serial, "serial")
    check_label(record.unit_type, "unit type")
    row = Campaign(
        campaign_uuid=record.campaign_uuid, serial=record.serial, unit_type=record.unit_type,
        title=record.title, spec_name=record.spec_name, overall=record.overall,
        report_id=record.report_id, tested_from=record.tested_from,
        tested_to=record.tested_to, filed_at=record.filed_at or datetime.now(UTC),
        document_json=json.dumps(record.document, allow_nan=True),
        runs=[CampaignRun(run_uuid=u, test_name=name, position=k)
              for k, (u, name) in enumerate(record.runs)])
    try:
        with Session(store.engine) as session, session.begin():
            session.add(row)
    except SQLAlchemyError as exc:
        raise StoreError(f"could not store the campaign in {store.display_url}: "
                         f"{str(getattr(exc, 'orig', exc)).splitlines()[0]}") from None


def discard_campaign(store: HistoryStore, campaign_uuid: str) -> None:
    """Withdraw a campaign row and its links (its runs are withdrawn by their own discard)."""
    try:
        with Session(store.engine) as session, session.begin():
            row = session.scalars(select(Campaign).where(
                Campaign.campaign_uuid == campaign_uuid)).first()
            if row is not None:
                session.delete(row)
    except SQLAlchemyError as exc:
        raise StoreError(f"could not withdraw campaign {campaign_uuid} from "
                         f"{store.display_url}: {exc}") from None


def campaigns(store: HistoryStore, *, serial: str | None = None,
              unit_type: str | None = None) -> list[CampaignRecord]:
    """Stored campaigns (of one serial or one unit type), oldest test first; [] when none."""
    if not store.serials():       # no database yet, or no run in it: no campaign either
        return []
    stmt = select(Campaign).options(selectinload(Campaign.runs)).order_by(
        Campaign.tested_from, Campaign.id)
    if serial is not None:
        stmt = stmt.where(Campaign.serial == serial)
    if unit_type is not None:
        stmt = stmt.where(Campaign.unit_type == unit_type)
    try:
        with Session(store.engine) as session:
            return [_record(r) for r in session.scalars(stmt)]
    except SQLAlchemyError as exc:
        raise StoreError(f"cannot read the campaigns of {store.display_url}: "
                         f"{str(getattr(exc, 'orig', exc)).splitlines()[0]}") from None


def _record(r: Campaign) -> CampaignRecord:
    def utc(t: datetime) -> datetime:
        return t.replace(tzinfo=UTC) if t.tzinfo is None else t.astimezone(UTC)

    return CampaignRecord(
        serial=r.serial, unit_type=r.unit_type, title=r.title, spec_name=r.spec_name,
        overall=r.overall, report_id=r.report_id, tested_from=utc(r.tested_from),
        tested_to=utc(r.tested_to), runs=tuple((x.run_uuid, x.test_name) for x in r.runs),
        document=json.loads(r.document_json), campaign_uuid=r.campaign_uuid,
        filed_at=utc(r.filed_at))


def run_ids(records: Sequence[CampaignRecord]) -> set[str]:
    """The run UUIDs of some campaigns."""
    return {u for c in records for u, _ in c.runs}
