"""booth checks stored with the session, in a table of their own (exported)

Issue 14: the booth check's result (pass/fail per step, the figures: face stream, head turn,
configured and measured copy delay, the test prompt's speech start/end, free disk) is kept
per run and exported as booth_checks.csv.

Revision ID: 0007_links_booth_checks
Revises: 0007_lab_pause
Create Date: 2026-11-25 03:10:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0007_links_booth_checks'
down_revision = '0007_lab_pause'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        'booth_check',
        sa.Column('id', sa.Integer(), sa.Identity(), nullable=False),
        sa.Column('booth', sa.String(length=64), nullable=False),
        sa.Column('study_id', sa.Integer(), nullable=True),
        sa.Column('session_id', sa.Integer(), nullable=True),
        sa.Column('checked_at', sa.DateTime(timezone=True), nullable=False),
        sa.Column('passed', sa.Boolean(), nullable=False),
        sa.Column('steps', sa.JSON(), nullable=False),
        sa.Column('face_fps', sa.Float(), nullable=True),
        sa.Column('capture_to_send_ms', sa.Float(), nullable=True),
        sa.Column('head_yaw_deg', sa.Float(), nullable=True),
        sa.Column('head_pitch_deg', sa.Float(), nullable=True),
        sa.Column('copy_delay_s', sa.Float(), nullable=True),
        sa.Column('measured_delay_s', sa.Float(), nullable=True),
        sa.Column('speech_start_ms', sa.Float(), nullable=True),
        sa.Column('speech_ok', sa.Boolean(), nullable=True),
        sa.Column('disk_free_bytes', sa.BigInteger(), nullable=True),
        sa.ForeignKeyConstraint(
            ['session_id'], ['session.id'],
            name=op.f('fk_booth_check_session_id_session'), ondelete='CASCADE',
        ),
        sa.ForeignKeyConstraint(
            ['study_id'], ['study.id'],
            name=op.f('fk_booth_check_study_id_study'), ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_booth_check')),
        sqlite_autoincrement=True,
    )
    with op.batch_alter_table('booth_check', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_booth_check_session_id'), ['session_id'],
                              unique=False)


def downgrade() -> None:
    with op.batch_alter_table('booth_check', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_booth_check_session_id'))
    op.drop_table('booth_check')
