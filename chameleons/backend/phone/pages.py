"""The participant's pages: the session page behind the phone link, and ``/join`` where
the short code can be typed instead of scanning the QR code."""

from __future__ import annotations

from typing import Annotated

from fastapi import Form, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from sqlalchemy import select

from chameleons.backend.auth.throttle import LoginThrottle
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.phone.endpoints import DECLINED_MESSAGE, ENDED_MESSAGE
from chameleons.backend.phone.language import browser_language, page_context
from chameleons.backend.phone.view import ended_view, phone_state
from chameleons.backend.routing import make_router
from chameleons.backend.sessions.flow import load_by_token
from chameleons.backend.sessions.service import SHORT_CODE_ALPHABET, SHORT_CODE_LENGTH
from chameleons.backend.studies.errors import NotFoundError
from chameleons.i18n import N_, gettext

router = make_router(tags=["phone"])
# Participants' pages must not be cached or indexed, and never sent to other sites.
PRIVATE_HEADERS = {
    "Cache-Control": "no-store",
    "Referrer-Policy": "no-referrer",
    "X-Robots-Tag": "noindex",
}


def _message(request: Request, templates: Templates, title: str, text: str, code: int) -> Response:
    language = browser_language(request)
    return templates.TemplateResponse(
        request,
        "phone/message.html",
        {"title": gettext(language, title), "text": text, **page_context(language)},
        status_code=code,
        headers=PRIVATE_HEADERS,
    )


@router.get("/p/{token}", response_class=HTMLResponse)
def session_page(token: str, request: Request, db: DbSession, templates: Templates) -> Response:
    try:
        flow = load_by_token(db, token, lock=False)
    except NotFoundError as exc:
        text = gettext(browser_language(request), exc.template, **exc.params)
        return _message(request, templates, N_("Link not valid"), text, status.HTTP_404_NOT_FOUND)
    if flow.session.state in ("complete", "ended"):
        # A reload after the end shows the same last page (the debriefing, if any).
        last = ended_view(flow)
        language = flow.session.language
        return templates.TemplateResponse(
            request,
            "phone/message.html",
            {
                "title": gettext(language, N_("Thank you!")),
                "text": gettext(
                    language, DECLINED_MESSAGE if last.get("declined") else ENDED_MESSAGE
                ),
                "debriefing": last.get("debriefing"),
                **page_context(language),
            },
            status_code=status.HTTP_410_GONE,
            headers=PRIVATE_HEADERS,
        )
    return templates.TemplateResponse(
        request,
        "phone/session.html",
        {"token": token, "state": phone_state(flow), **page_context(flow.session.language)},
        headers=PRIVATE_HEADERS,
    )


@router.get("/join", response_class=HTMLResponse)
def join_form(request: Request, templates: Templates) -> Response:
    return _join(request, templates, None, status.HTTP_200_OK)


def _join(request: Request, templates: Templates, error: str | None, code: int) -> Response:
    language = browser_language(request)
    return templates.TemplateResponse(
        request,
        "phone/join.html",
        {
            "error": error,
            "length": SHORT_CODE_LENGTH,
            **page_context(language),
        },
        status_code=code,
        headers=PRIVATE_HEADERS,
    )


def normalise_code(text: str) -> str:
    cleaned = "".join(ch for ch in text.upper() if ch.isalnum())
    return cleaned if all(ch in SHORT_CODE_ALPHABET for ch in cleaned) else ""


@router.post("/join", response_class=HTMLResponse)
def join(
    request: Request,
    db: DbSession,
    templates: Templates,
    code: Annotated[str, Form(max_length=32)] = "",
) -> Response:
    throttle: LoginThrottle = request.app.state.login_throttle
    key = f"join:{request.client.host if request.client else 'unknown'}"
    wait = throttle.retry_after(key)
    if wait > 0:
        seconds = int(wait) + 1
        text = gettext(
            browser_language(request),
            N_("Too many wrong codes. Please wait {seconds} seconds and try again."),
            seconds=seconds,
        )
        return _join(request, templates, text, status.HTTP_429_TOO_MANY_REQUESTS)
    cleaned = normalise_code(code)
    session = (
        db.scalars(select(SessionRow).where(SessionRow.short_code == cleaned)).first()
        if len(cleaned) == SHORT_CODE_LENGTH
        else None
    )
    if session is None or session.state in ("complete", "ended"):
        throttle.record_failure(key)
        text = gettext(
            browser_language(request),
            N_("That code does not belong to a running session. Please check it and try again."),
        )
        return _join(request, templates, text, status.HTTP_404_NOT_FOUND)
    throttle.reset(key)
    return RedirectResponse(f"/p/{session.phone_token}", status_code=status.HTTP_303_SEE_OTHER)
