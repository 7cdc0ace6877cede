"""the robot display's renderer (2D face or 3D head), per booth and per interaction

Issue 30: a booth's display has a default renderer and optionally a lab's own 3D head
(display_link.renderer, display_link.head); a study's condition may choose the renderer,
and the interaction records what it chose (interaction.renderer), so embodiment can be a
counterbalanced factor.

Revision ID: 0012_display_renderer
Revises: 0007_i19_session_language
Create Date: 2026-12-06 09:00:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0012_display_renderer'
down_revision = '0007_i19_session_language'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('display_link', schema=None) as batch_op:
        batch_op.add_column(sa.Column('renderer', sa.String(length=8), nullable=True))
        batch_op.add_column(sa.Column('head', sa.String(length=128), nullable=True))
    with op.batch_alter_table('interaction', schema=None) as batch_op:
        batch_op.add_column(sa.Column('renderer', sa.String(length=8), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table('interaction', schema=None) as batch_op:
        batch_op.drop_column('renderer')
    with op.batch_alter_table('display_link', schema=None) as batch_op:
        batch_op.drop_column('head')
        batch_op.drop_column('renderer')
