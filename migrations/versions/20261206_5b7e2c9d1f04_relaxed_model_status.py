"""Model status ``relaxed``: a model registered by a pipeline whose gates are relaxed on purpose (smoke sizes); it
can never be promoted or become the default. Only the models table's status check changes.

Revision ID: 5b7e2c9d1f04
Revises: 7c1e5a0b9d42
Create Date: 2026-12-06 13:40:00
"""

from __future__ import annotations

from alembic import op

revision = "5b7e2c9d1f04"
down_revision = "7c1e5a0b9d42"
branch_labels = None
depends_on = None

OLD = "status IN ('candidate', 'promoted', 'default')"
NEW = "status IN ('candidate', 'promoted', 'default', 'relaxed')"


def _swap(check: str) -> None:
    with op.batch_alter_table("models", schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f("ck_models_status"), type_="check")
        batch_op.create_check_constraint(batch_op.f("ck_models_status"), check)


def upgrade() -> None:
    _swap(NEW)


def downgrade() -> None:
    op.execute("UPDATE models SET status = 'candidate' WHERE status = 'relaxed'")
    _swap(OLD)
