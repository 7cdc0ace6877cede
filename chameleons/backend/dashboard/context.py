"""What every PI page needs: the study it shows, the ``?study=`` query, a flash message."""

from __future__ import annotations

from typing import Any

from fastapi import HTTPException, Request, status
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession
from sqlalchemy.orm import object_session

from chameleons.backend.export.selection import StudyNotFoundError, resolve_study
from chameleons.backend.models import StaffUser, Study

FLASH_KEY = "pi_flash"


def study_or_404(db: DbSession, study_id: int | None) -> Study:
    try:
        return resolve_study(db, study_id)
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc


def study_query(study: Study | None) -> str:
    return f"?study={study.id}" if study is not None else ""


def flash(request: Request, message: str) -> None:
    request.session[FLASH_KEY] = message


def page_context(
    request: Request, user: StaffUser, study: Study | None, section: str, **extra: Any
) -> dict[str, Any]:
    message = request.session.pop(FLASH_KEY, None)
    db = object_session(study) if study is not None else None
    studies = list(db.scalars(select(Study).order_by(Study.id))) if db is not None else []
    return {
        "studies": studies,
        "user": user,
        "study": study,
        "study_query": study_query(study),
        "section": section,
        "flash": message if isinstance(message, str) else None,
        **extra,
    }
