"""instruments: XDF streams attached to sessions and coders' ELAN annotations

Issue 33: `chameleons import-xdf` attaches the lab's other instruments' streams (EMG, eye
tracking, physiology) to a session, aligned through this system's LSL markers (the samples
in Parquet files under the data dir); `chameleons import-eaf` keeps the coders'
annotations for inter-rater reliability.

Revision ID: 0014_instruments
Revises: 0013_interaction_synchrony
Create Date: 2026-12-06 12:45:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0014_instruments'
down_revision = '0013_interaction_synchrony'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        'instrument_stream',
        sa.Column('id', sa.Integer(), sa.Identity(), nullable=False),
        sa.Column('session_id', sa.Integer(), nullable=False),
        sa.Column('name', sa.String(length=256), nullable=False),
        sa.Column('stream_type', sa.String(length=64), nullable=False),
        sa.Column('source_id', sa.String(length=256), nullable=False),
        sa.Column('channel_format', sa.String(length=16), nullable=False),
        sa.Column('nominal_srate', sa.Float(), nullable=False),
        sa.Column('channels', sa.JSON(), nullable=False),
        sa.Column('samples', sa.Integer(), nullable=False),
        sa.Column('first_s', sa.Float(), nullable=True),
        sa.Column('last_s', sa.Float(), nullable=True),
        sa.Column('path', sa.String(length=512), nullable=False),
        sa.Column('source_file', sa.String(length=512), nullable=False),
        sa.Column('fit', sa.JSON(), nullable=False),
        sa.Column('imported_at', sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ['session_id'], ['session.id'],
            name=op.f('fk_instrument_stream_session_id_session'), ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_instrument_stream')),
        sa.UniqueConstraint(
            'session_id', 'name', 'source_id',
            name=op.f('uq_instrument_stream_session_id_name_source_id'),
        ),
        sqlite_autoincrement=True,
    )
    op.create_index(
        op.f('ix_instrument_stream_session_id'), 'instrument_stream', ['session_id']
    )
    op.create_table(
        'coded_annotation',
        sa.Column('id', sa.Integer(), sa.Identity(), nullable=False),
        sa.Column('session_id', sa.Integer(), nullable=False),
        sa.Column('coder', sa.String(length=64), nullable=False),
        sa.Column('tier', sa.String(length=128), nullable=False),
        sa.Column('start_ms', sa.Integer(), nullable=False),
        sa.Column('end_ms', sa.Integer(), nullable=False),
        sa.Column('value', sa.Text(), nullable=False),
        sa.Column('source_file', sa.String(length=512), nullable=False),
        sa.Column('imported_at', sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ['session_id'], ['session.id'],
            name=op.f('fk_coded_annotation_session_id_session'), ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_coded_annotation')),
        sqlite_autoincrement=True,
    )
    op.create_index(
        op.f('ix_coded_annotation_session_id'), 'coded_annotation', ['session_id']
    )


def downgrade() -> None:
    op.drop_index(op.f('ix_coded_annotation_session_id'), table_name='coded_annotation')
    op.drop_table('coded_annotation')
    op.drop_index(op.f('ix_instrument_stream_session_id'), table_name='instrument_stream')
    op.drop_table('instrument_stream')
