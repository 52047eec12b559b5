"""The claim index in the claim's order: (status, priority DESC, created_at, id), so a claim walks the index
instead of sorting every queued job.

Revision ID: d41e5d03a9fe
Revises: 34a956e6a963
Create Date: 2026-11-22 12:54:55.294813
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "d41e5d03a9fe"
down_revision = "34a956e6a963"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_jobs_claim"))
        batch_op.create_index(
            "ix_jobs_claim", ["status", sa.literal_column("priority DESC"), "created_at", "id"], unique=False
        )


def downgrade() -> None:
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.drop_index("ix_jobs_claim")
        batch_op.create_index(batch_op.f("ix_jobs_claim"), ["status", "priority", "created_at"], unique=False)
