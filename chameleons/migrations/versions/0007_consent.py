"""consent on the phone: when the participant agreed, per session

Issue 13: a study's consent page comes first on the phone; the session cannot start
before consent, and ``consent_at`` records when it was given; declining ends the session
(reason ``consent_declined``) and makes the participant ``declined``.

Revision ID: 0004_i13_consent
Revises: 0003_i13_optional_items
Create Date: 2026-11-25 00:10:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0004_i13_consent'
down_revision = '0005_i15_staff_sessions'
branch_labels = None
depends_on = None

OLD_STATUS = "status IN ('registered', 'active', 'complete', 'ended_early')"
NEW_STATUS = "status IN ('registered', 'active', 'complete', 'ended_early', 'declined')"


def upgrade() -> None:
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.add_column(sa.Column('consent_at', sa.DateTime(timezone=True), nullable=True))
    with op.batch_alter_table('participant', schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f('ck_participant_status'), type_='check')
        batch_op.create_check_constraint('status', NEW_STATUS)


def downgrade() -> None:
    op.execute("UPDATE participant SET status = 'ended_early' WHERE status = 'declined'")
    with op.batch_alter_table('participant', schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f('ck_participant_status'), type_='check')
        batch_op.create_check_constraint('status', OLD_STATUS)
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.drop_column('consent_at')
