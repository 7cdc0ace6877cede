"""the participant's language, per session

Issue 19: a session's language is chosen at registration (the study's default otherwise)
or on the phone's first page; the phone pages, the study's texts and the prompts the
console offers follow it, and the export records it. Sessions from before were English.

Revision ID: 0007_i19_session_language
Revises: 0007_links_booth_checks
Create Date: 2026-11-25 02:45:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0007_i19_session_language'
down_revision = '0007_links_booth_checks'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.add_column(
            sa.Column('language', sa.String(length=16), server_default='en', nullable=False)
        )


def downgrade() -> None:
    with op.batch_alter_table('session', schema=None) as batch_op:
        batch_op.drop_column('language')
