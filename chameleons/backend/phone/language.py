"""The phone in the participant's language: template context, translated error sentences,
and the language of ``/join`` (before any session is known: the browser's preference)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from fastapi import HTTPException, Request
from sqlalchemy import select
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session

from chameleons.backend.models import Session as SessionRow
from chameleons.backend.studies.errors import ConfirmationNeededError, FlowError
from chameleons.i18n import (
    SOURCE_LANGUAGE,
    preferred_language,
    script_catalogue,
    translations,
)


def page_context(language: str) -> dict[str, Any]:
    """What every phone template needs: the language (``lang``/``dir`` and ``_()``) and the
    script's strings in it."""
    return {"language": language, "script_messages": script_catalogue(language)}


def translate(language: str, error: FlowError) -> str:
    text = translations(language).gettext(error.template)
    return text.format(**error.params) if error.params else text


@contextmanager
def phone_errors(db: Session, token: str) -> Iterator[None]:
    """Like ``http_errors``, with the sentence in the language of the session behind
    ``token``, looked up only when there is a sentence to translate (a statement less for
    every phone request that succeeds)."""
    try:
        yield
    except ConfirmationNeededError:  # never raised to the phone; kept as the wizard's
        raise
    except FlowError as exc:
        raise HTTPException(exc.status_code, translate(_language_now(db, token), exc)) from exc


def _language_now(db: Session, token: str) -> str:
    """The session's language as stored (a change the failed request had not flushed yet,
    a participant's new choice, does not count), English if it cannot be read."""
    try:
        with db.no_autoflush:
            return language_of(db, token)
    except SQLAlchemyError:  # a transaction the database has given up on: the sentence only
        return SOURCE_LANGUAGE


def browser_language(request: Request) -> str:
    """The first of the browser's ``Accept-Language`` that has a catalogue, else English."""
    return preferred_language(request.headers.get("accept-language", ""))


def language_of(db: Session, token: str) -> str:
    """The language of the session behind a phone link (English for an unknown link: its
    "not valid" answer is then in English)."""
    found = db.scalar(select(SessionRow.language).where(SessionRow.phone_token == token))
    return found or SOURCE_LANGUAGE
