"""PI page for staff accounts (``/pi/staff``): who may log in, their open sessions, and
deactivating, reactivating or logging an account out everywhere. Forms with CSRF."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from pydantic import ValidationError
from sqlalchemy import select

from chameleons.backend.auth import service, sessions
from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.auth.schemas import StaffUserCreate, refusal
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.models import StaffUser
from chameleons.backend.routing import make_router

router = make_router(tags=["auth"])
CSRF = [Depends(verify_csrf)]


def _page(
    request: Request, user: StaffUser, db: DbSession, templates: Templates, **extra: object
) -> Response:
    accounts = db.scalars(select(StaffUser).order_by(StaffUser.username)).all()
    context = {
        "user": user,
        "accounts": accounts,
        "open_sessions": sessions.open_counts(db),
        "error": None,
        "notice": None,
        **extra,
    }
    status_code = status.HTTP_400_BAD_REQUEST if context["error"] else status.HTTP_200_OK
    return templates.TemplateResponse(request, "pi/staff.html", context, status_code=status_code)


@router.get("/pi/staff", response_class=HTMLResponse)
def staff_page(request: Request, user: CurrentPI, db: DbSession, templates: Templates) -> Response:
    return _page(request, user, db, templates)


def _account(db: DbSession, account_id: int) -> StaffUser:
    account = db.get(StaffUser, account_id)
    if account is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such staff account.")
    return account


def _back() -> Response:
    return RedirectResponse("/pi/staff", status_code=status.HTTP_303_SEE_OTHER)


@router.post("/pi/staff/{account_id}/deactivate", dependencies=CSRF)
def deactivate(
    request: Request, account_id: int, user: CurrentPI, db: DbSession, templates: Templates
) -> Response:
    account = _account(db, account_id)
    if account.id == user.id:
        error = "You cannot deactivate your own account (another PI or the CLI can)."
        return _page(request, user, db, templates, error=error)
    service.set_active(db, account, active=False)
    return _back()


@router.post("/pi/staff/{account_id}/activate", dependencies=CSRF)
def activate(account_id: int, _user: CurrentPI, db: DbSession) -> Response:
    service.set_active(db, _account(db, account_id), active=True)
    return _back()


@router.post("/pi/staff/{account_id}/logout", dependencies=CSRF)
def logout_account(account_id: int, _user: CurrentPI, db: DbSession) -> Response:
    """End every session of the account (it stays active: its owner logs in again)."""
    sessions.end_all(db, _account(db, account_id).id, "ended by the PI")
    return _back()


@router.post("/pi/staff", response_class=HTMLResponse, dependencies=CSRF)
def add_account(
    request: Request,
    user: CurrentPI,
    db: DbSession,
    templates: Templates,
    username: Annotated[str, Form(max_length=64)] = "",
    password: Annotated[str, Form(max_length=256)] = "",
    role: Annotated[str, Form(max_length=16)] = "wizard",
) -> Response:
    try:
        data = StaffUserCreate.model_validate(
            {"username": username, "password": password, "role": role}
        )
        service.create_user(db, data)
    except ValidationError as exc:
        return _page(request, user, db, templates, error=refusal(exc))
    except service.UserExistsError as exc:
        return _page(request, user, db, templates, error=str(exc))
    return _page(request, user, db, templates, notice=f"Created {role} account {username}.")
