from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import click
from pydantic import ValidationError
from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.auth import repository, service, sessions
from chameleons.backend.auth.schemas import StaffUserCreate, refusal
from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.events.pg_fanout import notify_on_commit
from chameleons.backend.migrate import current_revision, head_revision
from chameleons.backend.models import StaffUser
from chameleons.cli.common import load_settings


@click.group()
def user() -> None:
    """Staff accounts (PI and wizards)."""


@user.command("add")
@click.argument("name")
@click.option("--role", type=click.Choice(["pi", "wizard"]), required=True)
@click.option(
    "--password",
    envvar="CHAMELEONS_NEW_USER_PASSWORD",
    help="For scripts (or env CHAMELEONS_NEW_USER_PASSWORD); prompted when omitted.",
)
def user_add(name: str, role: str, password: str | None) -> None:
    """Create a staff account NAME with a role."""
    if password is None:
        password = click.prompt("Password", hide_input=True, confirmation_prompt=True)
    try:
        data = StaffUserCreate(username=name, password=password, role=role)
    except ValidationError as exc:
        raise click.ClickException(refusal(exc)) from exc
    with _database() as db:
        try:
            service.create_user(db, data)
        except service.UserExistsError as exc:
            raise click.ClickException(str(exc)) from exc
    click.echo(f"created {role} account {name!r}")


@contextmanager
def _database() -> Iterator[Session]:
    """A session on the configured database (committed on success); refuses an old schema."""
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    try:
        if current_revision(engine) != head_revision():
            raise click.ClickException(
                "The database is not set up (or not up to date): run `chameleons db upgrade` first."
            )
        with session_scope(build_sessionmaker(engine)) as db:
            yield db
            # Ended staff sessions: their open sockets on a PostgreSQL server close at once
            # (on SQLite, at the server's next re-check: CHAMELEONS_STAFF_SOCKET_RECHECK_S).
            notify_on_commit(db)
    finally:
        engine.dispose()


def _find(db: Session, name: str) -> StaffUser:
    account = repository.get_by_username(db, name)
    if account is None:
        raise click.ClickException(f"there is no staff account {name!r}")
    return account


@user.command("deactivate")
@click.argument("name")
def user_deactivate(name: str) -> None:
    """Deactivate account NAME: its sessions end at once and it cannot log in."""
    with _database() as db:
        service.set_active(db, _find(db, name), active=False)
    click.echo(f"deactivated {name!r} and ended its sessions")


@user.command("activate")
@click.argument("name")
def user_activate(name: str) -> None:
    """Let account NAME log in again."""
    with _database() as db:
        service.set_active(db, _find(db, name), active=True)
    click.echo(f"activated {name!r}")


@user.command("list")
def user_list() -> None:
    """Staff accounts with role, state and open sessions."""
    with _database() as db:
        counts = sessions.open_counts(db)
        for account in db.scalars(select(StaffUser).order_by(StaffUser.username)):
            state = "active" if account.is_active else "deactivated"
            click.echo(
                f"{account.username}\t{account.role}\t{state}\t"
                f"{counts.get(account.id, 0)} open session(s)"
            )
