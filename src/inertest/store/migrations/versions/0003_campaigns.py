"""Acceptance campaigns: a series of runs on one unit, filed together (issue 32).

Adds the tables ``campaigns`` and ``campaign_runs``; the ``runs`` table is unchanged, so every
run stored before reads as it did (a run belongs to no campaign).

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-26
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Create the campaign tables."""
    op.create_table(
        "campaigns",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("campaign_uuid", sa.String(36), nullable=False, unique=True),
        sa.Column("serial", sa.String(200), nullable=False, index=True),
        sa.Column("unit_type", sa.String(200), nullable=False, index=True),
        sa.Column("title", sa.Text, nullable=False),
        sa.Column("spec_name", sa.Text, nullable=False),
        sa.Column("overall", sa.String(40), nullable=False),
        sa.Column("report_id", sa.String(200), nullable=False),
        sa.Column("tested_from", sa.DateTime(timezone=True), nullable=False),
        sa.Column("tested_to", sa.DateTime(timezone=True), nullable=False),
        sa.Column("filed_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("document_json", sa.Text, nullable=False),
    )
    op.create_table(
        "campaign_runs",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("campaign_id", sa.Integer,
                  sa.ForeignKey("campaigns.id", ondelete="CASCADE"), nullable=False,
                  index=True),
        sa.Column("run_uuid", sa.String(36), nullable=False, index=True),
        sa.Column("test_name", sa.String(200), nullable=False),
        sa.Column("position", sa.Integer, nullable=False),
    )


def downgrade() -> None:
    """Drop the campaign tables (the runs stay)."""
    op.drop_table("campaign_runs")
    op.drop_table("campaigns")
