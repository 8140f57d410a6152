"""Site optional: results of every kind are stored, and not every analysis has a site.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-24
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    """Let latitude and gravity be NULL (batch mode: SQLite rebuilds the table)."""
    with op.batch_alter_table("runs") as batch:
        batch.alter_column("latitude_deg", existing_type=sa.Float(), nullable=True)
        batch.alter_column("gravity_m_s2", existing_type=sa.Float(), nullable=True)


def downgrade() -> None:
    """Require them again (fails if a stored run has none)."""
    with op.batch_alter_table("runs") as batch:
        batch.alter_column("latitude_deg", existing_type=sa.Float(), nullable=False)
        batch.alter_column("gravity_m_s2", existing_type=sa.Float(), nullable=False)
