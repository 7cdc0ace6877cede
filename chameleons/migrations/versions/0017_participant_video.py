"""participant video: the booth camera's recording, chunk by chunk, and its consent items

Issue 33: a study may record the participant on video (``procedure.video``), only with the
participant's own consent item (``session.video_consent``, and ``video_audio_consent`` for
the microphone). The browser's ``MediaRecorder`` chunks are appended to a WebM file under
the data dir; ``participant_video`` indexes it, ``participant_video_chunk`` each chunk.

Revision ID: 0017_participant_video
Revises: 0016_copy_design
Create Date: 2026-12-06 16:00:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = '0017_participant_video'
down_revision = '0016_copy_design'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.add_column(sa.Column('video_consent', sa.Boolean(), nullable=True))
        batch_op.add_column(sa.Column('video_audio_consent', sa.Boolean(), nullable=True))
    op.create_table(
        'participant_video',
        sa.Column('id', sa.Integer(), sa.Identity(), nullable=False),
        sa.Column('session_id', sa.Integer(), nullable=False),
        sa.Column('booth', sa.String(length=64), nullable=False),
        sa.Column('mime_type', sa.String(length=128), nullable=False),
        sa.Column('audio', sa.Boolean(), nullable=False),
        sa.Column('path', sa.String(length=512), nullable=False),
        sa.Column('started_at', sa.DateTime(timezone=True), nullable=False),
        sa.Column('clock', sa.JSON(), nullable=False),
        sa.Column('chunks', sa.Integer(), nullable=False),
        sa.Column('size_bytes', sa.Integer(), nullable=False),
        sa.Column('refused', sa.Integer(), nullable=False),
        sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
        sa.Column('last_chunk_at', sa.DateTime(timezone=True), nullable=True),
        sa.Column('stopped_at', sa.DateTime(timezone=True), nullable=True),
        sa.ForeignKeyConstraint(
            ['session_id'], ['session.id'],
            name=op.f('fk_participant_video_session_id_session'), ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_participant_video')),
        sqlite_autoincrement=True,
    )
    op.create_index(
        op.f('ix_participant_video_session_id'), 'participant_video', ['session_id']
    )
    op.create_table(
        'participant_video_chunk',
        sa.Column('id', sa.Integer(), sa.Identity(), nullable=False),
        sa.Column('video_id', sa.Integer(), nullable=False),
        sa.Column('seq', sa.Integer(), nullable=False),
        sa.Column('offset', sa.Integer(), nullable=False),
        sa.Column('size', sa.Integer(), nullable=False),
        sa.Column('media_ms', sa.Float(), nullable=True),
        sa.Column('received_at', sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ['video_id'], ['participant_video.id'],
            name=op.f('fk_participant_video_chunk_video_id_participant_video'),
            ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_participant_video_chunk')),
        sa.UniqueConstraint(
            'video_id', 'seq', name=op.f('uq_participant_video_chunk_video_id_seq'),
        ),
        sqlite_autoincrement=True,
    )
    op.create_index(
        op.f('ix_participant_video_chunk_video_id'), 'participant_video_chunk', ['video_id']
    )


def downgrade() -> None:
    op.drop_index(op.f('ix_participant_video_chunk_video_id'), table_name='participant_video_chunk')
    op.drop_table('participant_video_chunk')
    op.drop_index(op.f('ix_participant_video_session_id'), table_name='participant_video')
    op.drop_table('participant_video')
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.drop_column('video_audio_consent')
        batch_op.drop_column('video_consent')
