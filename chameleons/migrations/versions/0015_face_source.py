"""face source: which capture source recorded the participant, per recording and interaction

Issue 29: a webcam (the capture page in a browser, or the worker's own camera) is a face
source beside the iPhone apps (Live Link Face, FaceCaptureX). The participant's recording
says which source its frames came from (recording.face_source: livelink, facecapturex,
webcam-browser, webcam-python) and how a webcam was calibrated (recording.face_calibration:
geometric, neutral, iphone:<hash>, neutral+iphone:<hash>; empty for an iPhone); the
interaction keeps its participant recording's (interaction.face_source, face_calibration),
exported so the analysis can split by it.

Revision ID: 0015_face_source
Revises: 0014_instruments
Create Date: 2026-12-06 13:00:00
"""
from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0015_face_source'
down_revision = '0014_instruments'
branch_labels = None
depends_on = None


def upgrade() -> None:
    for table in ('recording', 'interaction'):
        with op.batch_alter_table(table, schema=None) as batch_op:
            batch_op.add_column(sa.Column('face_source', sa.String(length=32), nullable=True))
            batch_op.add_column(sa.Column('face_calibration', sa.String(length=64),
                                          nullable=True))


def downgrade() -> None:
    for table in ('interaction', 'recording'):
        with op.batch_alter_table(table, schema=None) as batch_op:
            batch_op.drop_column('face_calibration')
            batch_op.drop_column('face_source')
