"""pausing a session: when it was paused, why, how often and for how long in total

Issue 16: the wizard pauses a session with a reason and resumes it; while paused nothing
moves on. ``paused_at`` is set while paused; ``paused_seconds`` and ``pause_count`` add up
the pauses that ended (the events table has each pause and resume).

Revision ID: 0007_lab_pause
Revises: 0006_i12_never_reused_ids
Create Date: 2026-11-25 02:50:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = "0007_lab_pause"
down_revision = "0006_i12_never_reused_ids"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("session", schema=None) as batch_op:
        batch_op.add_column(sa.Column("paused_at", sa.DateTime(timezone=True), nullable=True))
        batch_op.add_column(sa.Column("pause_reason", sa.String(length=32), nullable=True))
        batch_op.add_column(sa.Column("pause_note", sa.Text(), nullable=True))
        batch_op.add_column(
            sa.Column("pause_count", sa.Integer(), server_default="0", nullable=False)
        )
        batch_op.add_column(
            sa.Column("paused_seconds", sa.Float(), server_default="0", nullable=False)
        )


def downgrade() -> None:
    with op.batch_alter_table("session", schema=None) as batch_op:
        batch_op.drop_column("paused_seconds")
        batch_op.drop_column("pause_count")
        batch_op.drop_column("pause_note")
        batch_op.drop_column("pause_reason")
        batch_op.drop_column("paused_at")
