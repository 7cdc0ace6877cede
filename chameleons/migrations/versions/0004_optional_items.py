"""optional questionnaire items: a skipped item is stored as skipped

Issue 13: items may be optional (``required: false``; open questions are optional by
default). A skipped item gets a row with ``skipped`` true and neither value nor text, so
the export shows it empty; every other row still has an answer.

Revision ID: 0003_i13_optional_items
Revises: 0002_i13_suggestions_natural
Create Date: 2026-11-24 23:50:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0003_i13_optional_items'
down_revision = '0002_i13_suggestions_natural'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('questionnaire_response', schema=None) as batch_op:
        batch_op.add_column(
            sa.Column('skipped', sa.Boolean(), server_default=sa.false(), nullable=False)
        )
        batch_op.drop_constraint(op.f('ck_questionnaire_response_has_answer'), type_='check')
        batch_op.create_check_constraint(
            op.f('ck_questionnaire_response_has_answer'),
            'skipped OR value IS NOT NULL OR text IS NOT NULL',
        )


def downgrade() -> None:
    # Refused by the database while a skipped answer is stored (it has nothing to keep).
    with op.batch_alter_table('questionnaire_response', schema=None) as batch_op:
        batch_op.drop_constraint(op.f('ck_questionnaire_response_has_answer'), type_='check')
        batch_op.create_check_constraint(
            op.f('ck_questionnaire_response_has_answer'), 'value IS NOT NULL OR text IS NOT NULL'
        )
        batch_op.drop_column('skipped')
