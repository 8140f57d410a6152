"""Initial schema: runs and their estimates.

Revision ID: 0001
Revises:
Create Date: 2026-11-23
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Create the tables."""
    op.create_table(
        "runs",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("run_uuid", sa.String(36), nullable=False, unique=True),
        sa.Column("serial", sa.String(200), nullable=False, index=True),
        sa.Column("instrument_kind", sa.String(50), nullable=False),
        sa.Column("procedure", sa.String(80), nullable=False),
        sa.Column("tested_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("stored_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("software_version", sa.String(40), nullable=False),
        sa.Column("latitude_deg", sa.Float, nullable=False),
        sa.Column("gravity_m_s2", sa.Float, nullable=False),
        sa.Column("plan_text", sa.Text, nullable=False),
        sa.Column("data_sha256", sa.String(64), nullable=False),
        sa.Column("n_observations", sa.Integer, nullable=False),
        sa.Column("residual_rms", sa.Float),
        sa.Column("residual_unit", sa.String(40)),
        sa.Column("noise_sigma", sa.Float),
        sa.Column("noise_unit", sa.String(40)),
        sa.Column("dof", sa.Integer, nullable=False),
        sa.Column("result_json", sa.Text, nullable=False),
    )
    op.create_table(
        "estimates",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("run_id", sa.Integer, sa.ForeignKey("runs.id", ondelete="CASCADE"),
                  nullable=False, index=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("kind", sa.String(20), nullable=False),
        sa.Column("terms_json", sa.Text),
        sa.Column("value", sa.Float, nullable=False),
        sa.Column("std", sa.Float, nullable=False),
        sa.Column("unit", sa.String(40), nullable=False),
    )


def downgrade() -> None:
    """Drop the tables."""
    op.drop_table("estimates")
    op.drop_table("runs")
