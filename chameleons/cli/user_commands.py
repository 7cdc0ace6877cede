from __future__ import annotations

import click
from pydantic import ValidationError

from chameleons.backend.auth import service
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import current_revision, head_revision
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
        problems = "; ".join(f"{e['loc'][0]}: {e['msg']}" for e in exc.errors())
        raise click.ClickException(problems) from exc
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    try:
        if current_revision(engine) != head_revision():
            raise click.ClickException(
                "The database is not set up (or not up to date): run `chameleons db upgrade` first."
            )
        with session_scope(build_sessionmaker(engine)) as db:
            service.create_user(db, data)
    except service.UserExistsError as exc:
        raise click.ClickException(str(exc)) from exc
    finally:
        engine.dispose()
    click.echo(f"created {role} account {name!r}")
