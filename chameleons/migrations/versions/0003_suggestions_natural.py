"""suggestions may move down and number more than three; what natural replayed

Issue 13: the best-move rule proposes the move that most lowers the error score, up or
down, and ``suggestions_per_interaction`` may be up to 20; each interaction records the
source the ``natural`` behaviour replayed.

Revision ID: 0002_i13_suggestions_natural
Revises: 0002_i12_dropouts
Create Date: 2026-11-23 10:00:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0002_i13_suggestions_natural'
down_revision = '0002_i12_dropouts'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('interaction', schema=None) as batch_op:
        batch_op.add_column(sa.Column('natural_source', sa.String(length=16), nullable=True))
        batch_op.add_column(sa.Column('natural_recording', sa.String(length=255), nullable=True))
    with op.batch_alter_table('suggestion', schema=None) as batch_op:
        batch_op.drop_constraint(op.f('ck_suggestion_moves_up'), type_='check')
        batch_op.drop_constraint(op.f('ck_suggestion_index_range'), type_='check')
        batch_op.create_check_constraint(
            op.f('ck_suggestion_moves'), 'to_rank <> from_rank AND to_rank >= 1'
        )
        batch_op.create_check_constraint(op.f('ck_suggestion_index_range'), '"index" >= 1')


def downgrade() -> None:
    with op.batch_alter_table('interaction', schema=None) as batch_op:
        batch_op.drop_column('natural_recording')
        batch_op.drop_column('natural_source')
    # Refused by the database when a stored suggestion moves down or has index > 3.
    with op.batch_alter_table('suggestion', schema=None) as batch_op:
        batch_op.drop_constraint(op.f('ck_suggestion_moves'), type_='check')
        batch_op.drop_constraint(op.f('ck_suggestion_index_range'), type_='check')
        batch_op.create_check_constraint(op.f('ck_suggestion_moves_up'), 'to_rank < from_rank')
        batch_op.create_check_constraint(
            op.f('ck_suggestion_index_range'), '"index" BETWEEN 1 AND 3'
        )
