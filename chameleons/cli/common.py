"""Helpers shared by CLI commands: settings with readable errors."""

from __future__ import annotations

import click
from pydantic import ValidationError

from chameleons.settings import InsecureSettingsError, Settings


def load_settings(*, secure: bool = False, **overrides: object) -> Settings:
    """Build settings from the environment; turn problems into a clean CLI error."""
    try:
        settings = Settings(**{k: v for k, v in overrides.items() if v is not None})  # type: ignore[arg-type]
        if secure:
            settings.require_secure()
    except ValidationError as exc:
        raise click.ClickException(f"invalid settings:\n{exc}") from exc
    except InsecureSettingsError as exc:
        raise click.ClickException(str(exc)) from exc
    return settings
