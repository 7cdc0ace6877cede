"""Request-scoped dependencies shared by every feature package."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.templating import Jinja2Templates
from sqlalchemy.orm import Session

from chameleons.backend.events.unit_of_work import get_write_db
from chameleons.settings import Settings


def get_settings(request: Request) -> Settings:
    settings: Settings = request.app.state.settings
    return settings


def get_templates(request: Request) -> Jinja2Templates:
    templates: Jinja2Templates = request.app.state.templates
    return templates


# The one place that commits: the request's unit of work commits or rolls back in
# get_write_db, and events recorded in it reach the live hub after the commit.
# scope="function": the commit happens before the response is sent, so a client told
# "saved" can rely on it (the default scope would commit after the response went out).
# The same dependency as events' WriteDb, so a request has one database session.
DbSession = Annotated[Session, Depends(get_write_db, scope="function")]
AppSettings = Annotated[Settings, Depends(get_settings)]
Templates = Annotated[Jinja2Templates, Depends(get_templates)]
