"""The CLI as a user runs it: a real subprocess against a real database file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest


def run_cli(
    *args: str, env: dict[str, str], stdin: str | None = None
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "chameleons", *args],
        env=env, input=stdin, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip


@pytest.fixture
def cli_env(tmp_path: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env["CHAMELEONS_DATA_DIR"] = str(tmp_path / "data")
    return env


def test_help_lists_commands(cli_env: dict[str, str]) -> None:
    result = run_cli("--help", env=cli_env)
    assert result.returncode == 0
    for command in ("serve", "db", "user"):
        assert command in result.stdout


def test_version(cli_env: dict[str, str]) -> None:
    from chameleons import __version__

    result = run_cli("--version", env=cli_env)
    assert __version__ in result.stdout


def test_db_upgrade_then_current(cli_env: dict[str, str]) -> None:
    before = run_cli("db", "current", env=cli_env)
    assert "needs `chameleons db upgrade`" in before.stdout
    assert run_cli("db", "upgrade", env=cli_env).returncode == 0
    after = run_cli("db", "current", env=cli_env)
    assert "up to date" in after.stdout


def test_user_add_with_prompted_password_and_duplicate(cli_env: dict[str, str]) -> None:
    run_cli("db", "upgrade", env=cli_env)
    created = run_cli(
        "user", "add", "pia", "--role", "pi", env=cli_env, stdin="pw-123456\npw-123456\n"
    )
    assert created.returncode == 0, created.stderr
    assert "created pi account 'pia'" in created.stdout
    again = run_cli("user", "add", "pia", "--role", "pi", "--password", "pw-123456", env=cli_env)
    assert again.returncode != 0
    assert "already exists" in again.stderr


def test_user_add_rejects_short_password(cli_env: dict[str, str]) -> None:
    run_cli("db", "upgrade", env=cli_env)
    result = run_cli("user", "add", "wiz", "--role", "wizard", "--password", "x", env=cli_env)
    assert result.returncode != 0
    assert "password" in result.stderr


@pytest.mark.parametrize(
    ("password", "why"),
    [
        ("password123", "This password is too common: choose one that is not on breach lists."),
        ("wizard99x", "The password is too similar to the user name."),
    ],
)
def test_user_add_with_a_refused_password_says_why_in_one_sentence(
    cli_env: dict[str, str], password: str, why: str
) -> None:
    """The password check judges the whole account (a model check, no field): it crashed
    the command with an IndexError traceback."""
    run_cli("db", "upgrade", env=cli_env)
    result = run_cli("user", "add", "wizard", "--role", "wizard", "--password", password,
                     env=cli_env)  # fmt: skip
    assert result.returncode == 1
    assert result.stderr == f"Error: {why}\n"
    listed = run_cli("user", "list", env=cli_env)
    assert listed.stdout == ""  # nothing was created


def test_serve_refuses_without_secret(cli_env: dict[str, str]) -> None:
    result = run_cli("serve", env=cli_env)
    assert result.returncode != 0
    assert "CHAMELEONS_SECRET_KEY" in result.stderr


def test_user_add_before_migrations_says_what_to_do(cli_env: dict[str, str]) -> None:
    result = run_cli("user", "add", "pia", "--role", "pi", "--password", "pw-123456", env=cli_env)
    assert result.returncode != 0
    assert "run `chameleons db upgrade` first" in result.stderr
    assert "Traceback" not in result.stderr
