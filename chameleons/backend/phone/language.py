"""The phone in the participant's language: template context, translated error sentences,
and the language of ``/join`` (before any session is known: the browser's preference)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from fastapi import HTTPException, Request
from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.models import Session as SessionRow
from chameleons.backend.studies.errors import ConfirmationNeededError, FlowError
from chameleons.i18n import SOURCE_LANGUAGE, catalogue_languages, script_catalogue, translations


def page_context(language: str) -> dict[str, Any]:
    """What every phone template needs: the language (``lang``/``dir`` and ``_()``) and the
    script's strings in it."""
    return {"language": language, "script_messages": script_catalogue(language)}


def translate(language: str, error: FlowError) -> str:
    text = translations(language).gettext(error.template)
    return text.format(**error.params) if error.params else text


@contextmanager
def phone_errors(language: str) -> Iterator[None]:
    """Like ``http_errors``, with the sentence in the participant's language."""
    try:
        yield
    except ConfirmationNeededError:  # never raised to the phone; kept as the wizard's
        raise
    except FlowError as exc:
        raise HTTPException(exc.status_code, translate(language, exc)) from exc


def browser_language(request: Request) -> str:
    """The first of the browser's ``Accept-Language`` that has a catalogue, else English."""
    available = set(catalogue_languages())
    ranked: list[tuple[float, int, str]] = []
    header = request.headers.get("accept-language", "")
    for index, part in enumerate(header.split(",")[:20]):
        tag, _, quality = part.strip().partition(";q=")
        code = tag.split("-")[0].strip().lower()
        try:
            weight = float(quality) if quality else 1.0
        except ValueError:
            continue
        if code in available:
            ranked.append((-weight, index, code))
    return min(ranked)[2] if ranked else SOURCE_LANGUAGE


def language_of(db: Session, token: str) -> str:
    """The language of the session behind a phone link (English for an unknown link: its
    "not valid" answer is then in English)."""
    found = db.scalar(select(SessionRow.language).where(SessionRow.phone_token == token))
    return found or SOURCE_LANGUAGE
