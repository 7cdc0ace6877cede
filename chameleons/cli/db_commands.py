from __future__ import annotations

import click
from sqlalchemy.exc import SQLAlchemyError

from chameleons.backend.db import build_engine
from chameleons.backend.migrate import current_revision, head_revision, upgrade
from chameleons.cli.common import load_settings


@click.group()
def db() -> None:
    """Database schema: apply and inspect migrations."""


@db.command("upgrade")
@click.option("--revision", default="head", show_default=True, help="Target revision.")
def db_upgrade(revision: str) -> None:
    """Apply migrations (creates the database on first run)."""
    settings = load_settings()
    try:
        upgrade(settings.effective_database_url, revision)
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not migrate the database: {exc}") from exc
    click.echo(f"database at {revision} ({_safe_url(settings.effective_database_url)})")


@db.command("current")
def db_current() -> None:
    """Show the database's schema revision and the code's head revision."""
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    try:
        current = current_revision(engine)
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not read the database: {exc}") from exc
    finally:
        engine.dispose()
    head = head_revision()
    state = "up to date" if current == head else "needs `chameleons db upgrade`"
    click.echo(f"current: {current or '(empty)'}\nhead:    {head}\n{state}")


def _safe_url(url: str) -> str:
    from sqlalchemy.engine import make_url

    return make_url(url).render_as_string(hide_password=True)
