"""sessions ended early, excluded participants, plan rows handed on from dropouts

Revision ID: 0002_i12_dropouts
Revises: 0001
Create Date: 2026-11-23 10:00:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0002_i12_dropouts'
down_revision = '0001'
branch_labels = None
depends_on = None

OLD_STATUS = "status IN ('registered', 'active', 'complete')"
NEW_STATUS = "status IN ('registered', 'active', 'complete', 'ended_early')"


def upgrade() -> None:
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.add_column(sa.Column('ended_at', sa.DateTime(timezone=True), nullable=True))
        batch_op.add_column(sa.Column('end_reason', sa.String(length=32), nullable=True))
        batch_op.add_column(sa.Column('end_note', sa.Text(), nullable=True))
    with op.batch_alter_table('participant', schema=None) as batch_op:
        batch_op.add_column(sa.Column('excluded_at', sa.DateTime(timezone=True), nullable=True))
        batch_op.add_column(sa.Column('exclusion_reason', sa.Text(), nullable=True))
        batch_op.drop_constraint(batch_op.f('ck_participant_status'), type_='check')
        batch_op.create_check_constraint('status', NEW_STATUS)
    with op.batch_alter_table('plan_row', schema=None) as batch_op:
        batch_op.add_column(
            sa.Column('dropouts', sa.Integer(), server_default='0', nullable=False)
        )


def downgrade() -> None:
    with op.batch_alter_table('plan_row', schema=None) as batch_op:
        batch_op.drop_column('dropouts')
    op.execute("UPDATE participant SET status = 'active' WHERE status = 'ended_early'")
    with op.batch_alter_table('participant', schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f('ck_participant_status'), type_='check')
        batch_op.create_check_constraint('status', OLD_STATUS)
        batch_op.drop_column('exclusion_reason')
        batch_op.drop_column('excluded_at')
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.drop_column('end_note')
        batch_op.drop_column('end_reason')
        batch_op.drop_column('ended_at')
