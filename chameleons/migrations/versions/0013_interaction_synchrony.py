"""interaction synchrony: the recorded faces' synchrony per interaction

Issue 32: the robot following the participant (did the manipulation run?) and the
participant following the robot (mimicry), with their surrogate baseline, computed when an
interaction's recording stops; one row per interaction with how it was computed.

Revision ID: 0013_interaction_synchrony
Revises: 0012_display_renderer
Create Date: 2026-12-06 10:10:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0013_interaction_synchrony'
down_revision = '0012_display_renderer'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        'interaction_synchrony',
        sa.Column('id', sa.Integer(), sa.Identity(), nullable=False),
        sa.Column('interaction_id', sa.Integer(), nullable=False),
        sa.Column('computed_at', sa.DateTime(timezone=True), nullable=False),
        sa.Column('reason', sa.String(length=32), nullable=True),
        sa.Column('detail', sa.String(length=512), nullable=False),
        sa.Column('sync_lag_s', sa.Float(), nullable=True),
        sa.Column('sync_r', sa.Float(), nullable=True),
        sa.Column('sync_band_r', sa.Float(), nullable=True),
        sa.Column('sync_p', sa.Float(), nullable=True),
        sa.Column('mimicry_lag_s', sa.Float(), nullable=True),
        sa.Column('mimicry_r', sa.Float(), nullable=True),
        sa.Column('mimicry_raw_r', sa.Float(), nullable=True),
        sa.Column('mimicry_surrogate_r', sa.Float(), nullable=True),
        sa.Column('mimicry_p', sa.Float(), nullable=True),
        sa.Column('check', sa.String(length=16), nullable=True),
        sa.Column('check_reason', sa.String(length=512), nullable=False),
        sa.Column('usable_share', sa.Float(), nullable=True),
        sa.Column('face_source', sa.String(length=32), nullable=True),
        sa.Column('surrogate_kind', sa.String(length=16), nullable=False),
        sa.Column('surrogate_count', sa.Integer(), nullable=False),
        sa.Column('params', sa.JSON(), nullable=False),
        sa.Column('surrogates', sa.JSON(), nullable=False),
        sa.Column('recordings', sa.JSON(), nullable=False),
        sa.Column('channels', sa.JSON(), nullable=False),
        sa.Column('curves', sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(
            ['interaction_id'], ['interaction.id'],
            name=op.f('fk_interaction_synchrony_interaction_id_interaction'),
            ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_interaction_synchrony')),
        sa.UniqueConstraint(
            'interaction_id', name=op.f('uq_interaction_synchrony_interaction_id')
        ),
        sqlite_autoincrement=True,
    )


def downgrade() -> None:
    op.drop_table('interaction_synchrony')
