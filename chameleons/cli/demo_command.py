"""`chameleons demo`: the embedded default on this machine, with printed URLs and logins."""

from __future__ import annotations

import json
import secrets
from pathlib import Path

import click
import uvicorn
from pydantic import SecretStr

from chameleons.backend.app import create_app
from chameleons.backend.auth import repository, service
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.cli.common import load_settings
from chameleons.settings import Settings

DEMO_USERS = (("pi", "pi"), ("wizard", "wizard"))


def _demo_secret(data_dir: Path) -> str:
    """A random key kept in the data dir, so demo logins survive a restart."""
    path = data_dir / "demo-secret-key"
    if not path.exists():
        path.write_text(secrets.token_urlsafe(32))
        path.chmod(0o600)
    return path.read_text().strip()


def _demo_credentials(settings: Settings) -> dict[str, str]:
    """Create the demo staff users once; later runs reuse (and print) the same passwords."""
    path = settings.data_dir / "demo-credentials.json"
    stored: dict[str, str] = json.loads(path.read_text()) if path.exists() else {}
    engine = build_engine(settings.effective_database_url)
    try:
        for db in session_scope(build_sessionmaker(engine)):
            for username, role in DEMO_USERS:
                password = stored.get(username) or secrets.token_urlsafe(9)
                user = repository.get_by_username(db, username)
                if user is None:
                    data = StaffUserCreate(username=username, password=password, role=role)
                    service.create_user(db, data)
                elif username not in stored:
                    service.set_password(db, user, password)
                stored[username] = password
    finally:
        engine.dispose()
    path.write_text(json.dumps(stored, indent=2))
    path.chmod(0o600)
    return stored


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", type=int, default=8000, show_default=True)
def demo(host: str, port: int) -> None:
    """Start the whole system on its embedded default (SQLite, demo content)."""
    settings = load_settings(demo_mode=True, host=host, port=port)
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    if not settings.secret_key.get_secret_value():
        secret = SecretStr(_demo_secret(settings.data_dir))
        settings = settings.model_copy(update={"secret_key": secret})
    upgrade(settings.effective_database_url)
    credentials = _demo_credentials(settings)
    base = settings.effective_public_url
    click.echo("\nMechanical Chameleons demo (SQLite at " + str(settings.data_dir) + ")")
    click.echo(f"  staff login:   {base}/login")
    for username, password in credentials.items():
        click.echo(f"    {username:<8} password: {password}")
    click.echo(f"  health:        {base}/healthz\n  Ctrl-C stops everything.\n")
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port, log_level="warning")
