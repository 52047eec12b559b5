"""Job labels: a name, tags and a free-text note on every job (set at submission, editable with
``PATCH /v1/jobs/{id}``), and the ``job_tags`` index behind the job list's ``?tag=`` filter. Existing jobs get
no name, no tags and an empty note.

Revision ID: 7c1e5a0b9d42
Revises: 3ea855f35745
Create Date: 2026-11-24 09:20:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "7c1e5a0b9d42"
down_revision = "3ea855f35745"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # plain ADD COLUMN, no batch mode: SQLite can add these in place, and a batch's table copy would recreate
    # the ix_jobs_*created indexes from reflection without their DESC order
    op.add_column("jobs", sa.Column("name", sa.String(length=200), nullable=True))
    op.add_column("jobs", sa.Column("tags", sa.JSON(), server_default=sa.text("'[]'"), nullable=False))
    op.add_column("jobs", sa.Column("note", sa.Text(), server_default="", nullable=False))
    op.create_index(op.f("ix_jobs_name"), "jobs", ["name"], unique=False)
    op.create_table(
        "job_tags",
        sa.Column("job_id", sa.String(length=32), nullable=False),
        sa.Column("tag", sa.String(length=100), nullable=False),
        sa.ForeignKeyConstraint(
            ["job_id"], ["jobs.id"], name=op.f("fk_job_tags_job_id_jobs"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("job_id", "tag", name=op.f("pk_job_tags")),
    )
    op.create_index("ix_job_tags_tag", "job_tags", ["tag", "job_id"], unique=False)


def downgrade() -> None:
    op.drop_index("ix_job_tags_tag", table_name="job_tags")
    op.drop_table("job_tags")
    op.drop_index(op.f("ix_jobs_name"), table_name="jobs")
    for column in ("note", "tags", "name"):
        op.drop_column("jobs", column)  # SQLite >= 3.35 drops a column in place
