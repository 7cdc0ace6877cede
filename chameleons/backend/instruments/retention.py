"""A withdrawal deletes what the other instruments recorded of the participant: the
imported streams (rows and Parquet files) and the coders' annotations of their sessions."""

from __future__ import annotations

import shutil
from pathlib import Path

from sqlalchemy import delete
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import CodedAnnotation, InstrumentStream

FOLDER = "instruments"


def session_folder(data_dir: Path, session_id: int) -> Path:
    return data_dir / FOLDER / f"session-{session_id}"


def forget_instruments(db: DbSession, session_ids: list[int], data_dir: Path) -> int:
    """Delete the sessions' instrument rows and folders; returns the files deleted."""
    if not session_ids:
        return 0
    db.execute(delete(InstrumentStream).where(InstrumentStream.session_id.in_(session_ids)))
    db.execute(delete(CodedAnnotation).where(CodedAnnotation.session_id.in_(session_ids)))
    deleted = 0
    for session_id in session_ids:
        folder = session_folder(data_dir, session_id)
        if folder.is_dir() and not folder.is_symlink():
            deleted += sum(1 for path in folder.rglob("*") if path.is_file())
            shutil.rmtree(folder)
    return deleted
