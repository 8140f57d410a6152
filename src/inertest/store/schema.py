"""ORM tables of the history database. Change them only together with a new migration."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import DateTime, Float, ForeignKey, Index, Integer, String, Text
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


class Base(DeclarativeBase):
    """Declarative base of the history tables."""


class Run(Base):
    """One stored fit: an instrument tested once with one procedure."""

    __tablename__ = "runs"
    # Filing looks for a run of the same serial and procedure made from the same data.
    __table_args__ = (Index("ix_runs_same_data", "serial", "procedure", "data_sha256"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_uuid: Mapped[str] = mapped_column(String(36), unique=True, nullable=False)
    serial: Mapped[str] = mapped_column(String(200), index=True, nullable=False)
    instrument_kind: Mapped[str] = mapped_column(String(50), nullable=False)
    procedure: Mapped[str] = mapped_column(String(80), nullable=False)
    tested_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), nullable=False)
    stored_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), nullable=False)
    software_version: Mapped[str] = mapped_column(String(40), nullable=False)
    latitude_deg: Mapped[float | None] = mapped_column(Float)
    gravity_m_s2: Mapped[float | None] = mapped_column(Float)
    plan_text: Mapped[str] = mapped_column(Text, nullable=False)
    data_sha256: Mapped[str] = mapped_column(String(64), nullable=False)
    n_observations: Mapped[int] = mapped_column(Integer, nullable=False)
    residual_rms: Mapped[float | None] = mapped_column(Float)
    residual_unit: Mapped[str | None] = mapped_column(String(40))
    noise_sigma: Mapped[float | None] = mapped_column(Float)
    noise_unit: Mapped[str | None] = mapped_column(String(40))
    dof: Mapped[int] = mapped_column(Integer, nullable=False)
    result_json: Mapped[str] = mapped_column(Text, nullable=False)
    estimates: Mapped[list[EstimateRow]] = relationship(
        back_populates="run", cascade="all, delete-orphan", order_by="EstimateRow.id"
    )


class EstimateRow(Base):
    """One coefficient or combination of a run, in engineering units."""

    __tablename__ = "estimates"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(
        ForeignKey("runs.id", ondelete="CASCADE"), index=True, nullable=False
    )
    name: Mapped[str] = mapped_column(String(200), nullable=False)
    kind: Mapped[str] = mapped_column(String(20), nullable=False)  # coefficient | combination
    terms_json: Mapped[str | None] = mapped_column(Text)
    value: Mapped[float] = mapped_column(Float, nullable=False)
    std: Mapped[float] = mapped_column(Float, nullable=False)
    unit: Mapped[str] = mapped_column(String(40), nullable=False)
    run: Mapped[Run] = relationship(back_populates="estimates")


class Campaign(Base):
    """One acceptance campaign: a series of runs on one unit under test, judged clause by clause.

    Each run of the series stays its own row of ``runs``; :class:`CampaignRun` links them.
    """

    __tablename__ = "campaigns"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    campaign_uuid: Mapped[str] = mapped_column(String(36), unique=True, nullable=False)
    serial: Mapped[str] = mapped_column(String(200), index=True, nullable=False)
    unit_type: Mapped[str] = mapped_column(String(200), index=True, nullable=False)
    title: Mapped[str] = mapped_column(Text, nullable=False)
    spec_name: Mapped[str] = mapped_column(Text, nullable=False)
    overall: Mapped[str] = mapped_column(String(40), nullable=False)
    report_id: Mapped[str] = mapped_column(String(200), nullable=False)
    tested_from: Mapped[datetime] = mapped_column(DateTime(timezone=True), nullable=False)
    tested_to: Mapped[datetime] = mapped_column(DateTime(timezone=True), nullable=False)
    filed_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), nullable=False)
    document_json: Mapped[str] = mapped_column(Text, nullable=False)
    runs: Mapped[list[CampaignRun]] = relationship(
        back_populates="campaign", cascade="all, delete-orphan", order_by="CampaignRun.position"
    )


class CampaignRun(Base):
    """A stored run that belongs to a campaign, with the campaign's name for its test."""

    __tablename__ = "campaign_runs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    campaign_id: Mapped[int] = mapped_column(
        ForeignKey("campaigns.id", ondelete="CASCADE"), index=True, nullable=False
    )
    run_uuid: Mapped[str] = mapped_column(String(36), index=True, nullable=False)
    test_name: Mapped[str] = mapped_column(String(200), nullable=False)
    position: Mapped[int] = mapped_column(Integer, nullable=False)
    campaign: Mapped[Campaign] = relationship(back_populates="runs")
