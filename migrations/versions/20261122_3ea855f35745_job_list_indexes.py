"""Indexes in the job list's order (newest first): (created_at DESC, id), and the same after status and after
kind, so that `GET /v1/jobs` — unfiltered, or filtered by status or by kind — reads its page off an index
instead of sorting every matching job (100,000 jobs: 87 ms -> 0.1 ms a page, EXPLAIN QUERY PLAN has no
temporary B-tree left).

Revision ID: 3ea855f35745
Revises: d41e5d03a9fe
Create Date: 2026-11-22 14:50:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "3ea855f35745"
down_revision = "d41e5d03a9fe"
branch_labels = None
depends_on = None

NEWEST_FIRST = [sa.literal_column("created_at DESC"), "id"]


def upgrade() -> None:
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.create_index("ix_jobs_created", NEWEST_FIRST, unique=False)
        batch_op.create_index("ix_jobs_status_created", ["status", *NEWEST_FIRST], unique=False)
        batch_op.create_index("ix_jobs_kind_created", ["kind", *NEWEST_FIRST], unique=False)


def downgrade() -> None:
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.drop_index("ix_jobs_kind_created")
        batch_op.drop_index("ix_jobs_status_created")
        batch_op.drop_index("ix_jobs_created")
