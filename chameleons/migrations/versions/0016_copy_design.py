"""what the robot's behaviour did, per interaction: its parameters and the same in words

Issue 31: copy became a design space (channels, gain, mirror, jittered delay, coexpress,
intermittent bouts, congruent-only expressions); each interaction records the parameters the
worker was sent (interaction.behaviour_params, JSON, with the seed the server chose) and a
canonical sentence (interaction.behaviour_words), both exported.

Revision ID: 0016_copy_design
Revises: 0015_face_source
Create Date: 2026-12-06 13:10:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = '0016_copy_design'
down_revision = '0015_face_source'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('interaction', schema=None) as batch_op:
        batch_op.add_column(sa.Column('behaviour_params', sa.JSON(), nullable=True))
        batch_op.add_column(sa.Column('behaviour_words', sa.String(length=512), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table('interaction', schema=None) as batch_op:
        batch_op.drop_column('behaviour_words')
        batch_op.drop_column('behaviour_params')
