from __future__ import annotations

import pytest

from chameleons.backend.app import create_app
from chameleons.settings import InsecureSettingsError, Settings


@pytest.mark.parametrize(
    "secret", ["", "change-me", "short", "x" * 64, "ab" * 40, "correct horse battery"]
)
def test_insecure_secret_refused_outside_demo(secret: str) -> None:
    settings = Settings(secret_key=secret, _env_file=None)
    with pytest.raises(InsecureSettingsError, match="CHAMELEONS_SECRET_KEY"):
        create_app(settings)


def test_a_random_key_is_accepted() -> None:
    import secrets

    from chameleons.settings import estimated_bits

    key = secrets.token_urlsafe(32)
    assert estimated_bits(key) >= 128
    Settings(secret_key=key, _env_file=None).require_secure()


def test_demo_mode_runs_without_secret(tmp_path: object) -> None:
    settings = Settings(demo_mode=True, data_dir=tmp_path, _env_file=None)
    assert create_app(settings).state.settings.demo_mode


def test_environment_prefix(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CHAMELEONS_PORT", "9123")
    monkeypatch.setenv("CHAMELEONS_DATABASE_URL", "sqlite:///x.db")
    settings = Settings(_env_file=None)
    assert settings.port == 9123
    assert settings.effective_database_url == "sqlite:///x.db"
