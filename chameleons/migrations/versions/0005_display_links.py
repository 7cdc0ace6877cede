"""display links the PI can rotate and that expire when their booth is retired

Issue 15: a booth's display link was an HMAC of the booth id alone, valid for ever.

Revision ID: 0004_i15_display_links
Revises: 0003_i13_optional_items
Create Date: 2026-11-25 00:30:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0004_i15_display_links'
down_revision = '0003_i13_optional_items'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        'display_link',
        sa.Column('booth', sa.String(length=64), nullable=False),
        sa.Column('generation', sa.Integer(), nullable=False),
        sa.Column('retired_at', sa.DateTime(timezone=True), nullable=True),
        sa.Column('updated_at', sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint('booth', name=op.f('pk_display_link')),
    )


def downgrade() -> None:
    op.drop_table('display_link')
