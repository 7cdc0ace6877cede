"""Helpers shared by CLI commands: settings with readable errors."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import click
from pydantic import SecretStr, ValidationError
from pydantic_settings import SettingsError

from chameleons.settings import InsecureSettingsError, Settings

ENV_PREFIX = "CHAMELEONS_"
# Values never repeated in an error (a key, or a database URL with its password).
_SECRET_NAMES = re.compile(r"secret|password|database_url", re.IGNORECASE)
_FIELD_IN_ERROR = re.compile(r'field "(\w+)"')


def load_settings(*, secure: bool = False, **overrides: object) -> Settings:
    """Build settings from the environment; turn problems into a clean CLI error: one
    sentence per bad setting, naming its ``CHAMELEONS_`` variable (or the option given)."""
    given = {k: v for k, v in overrides.items() if v is not None}
    try:
        settings = Settings(**given)  # type: ignore[arg-type]
        if secure:
            settings.require_secure()
    except ValidationError as exc:
        raise click.ClickException(invalid_settings(exc, given)) from exc
    except SettingsError as exc:  # a variable that must be JSON (a mapping) is not
        raise click.ClickException(unreadable_setting(exc)) from exc
    except InsecureSettingsError as exc:
        raise click.ClickException(str(exc)) from exc
    return settings


def setting_name(field: str, given: Mapping[str, object] | None = None) -> str:
    """Where the user set ``field``: the command-line option, else the environment variable."""
    if given and field in given:
        return f"--{field.replace('_', '-')}"
    return f"{ENV_PREFIX}{field.upper()}"


def invalid_settings(error: ValidationError, given: Mapping[str, object] | None = None) -> str:
    """One sentence per bad setting (a line each)."""
    sentences = []
    for problem in error.errors():
        location = problem.get("loc") or ()
        field = str(location[0]) if location else ""
        message = str(problem.get("msg", "is not valid")).removeprefix("Value error, ")
        message = message[:1].lower() + message[1:]
        if not field:  # a rule across settings (a model validator)
            sentences.append(f"Invalid settings: {message.rstrip('.')}.")
            continue
        shown = _shown(field, problem.get("input"))
        inner = "".join(f"[{part}]" for part in location[1:])
        sentences.append(f"{setting_name(field, given)}{inner}{shown}: {message.rstrip('.')}.")
    return "\n".join(sentences)


def unreadable_setting(error: SettingsError) -> str:
    match = _FIELD_IN_ERROR.search(str(error))
    if match is None:
        return f"Cannot read the settings: {error}."
    return (f"{setting_name(match.group(1))} cannot be read: it must be JSON, "
            'e.g. {"face-1": "Isabel"}.')  # fmt: skip


def _shown(field: str, value: Any) -> str:
    if value is None or isinstance(value, dict) or _secret(field):
        return ""
    return f" is {str(value)!r}"


def _secret(field: str) -> bool:
    info = Settings.model_fields.get(field)
    annotation = str(info.annotation) if info is not None else ""
    return bool(_SECRET_NAMES.search(field)) or SecretStr.__name__ in annotation
