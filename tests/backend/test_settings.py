from __future__ import annotations

import secrets
from collections.abc import Callable

import pytest

from chameleons.backend.app import create_app
from chameleons.key_entropy import estimated_bits, smallest_period
from chameleons.settings import InsecureSettingsError, Settings

REPEATED_OR_RUN = [
    "ab" * 64,  # 128 characters of two letters: variety alone put it at 128 bits
    "changeme" * 6,  # an example value repeated: variety put it at 132 bits
    "password" * 8,  # a dictionary word repeated
    "dragon" * 10 + "x",  # a repetition with a different last character
    "Summer2024!" * 4,
    "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789",  # a keyboard run
]


@pytest.mark.parametrize(
    "secret",
    ["", "change-me", "short", "x" * 64, "ab" * 40, "correct horse battery", *REPEATED_OR_RUN],
)
def test_insecure_secret_refused_outside_demo(secret: str) -> None:
    settings = Settings(secret_key=secret, _env_file=None)
    with pytest.raises(InsecureSettingsError, match="CHAMELEONS_SECRET_KEY"):
        create_app(settings)


@pytest.mark.parametrize("make", [secrets.token_urlsafe, secrets.token_hex])
@pytest.mark.parametrize("size", [32, 48, 64])
def test_random_keys_are_accepted(make: Callable[[int], str], size: int) -> None:
    for _ in range(50):  # fresh random keys each run: the estimate must hold for any
        key = make(size)
        assert estimated_bits(key) >= 128, key
        Settings(secret_key=key, _env_file=None).require_secure()


def test_repetition_counts_once() -> None:
    assert smallest_period("changeme" * 6) == 8
    assert smallest_period("abcab") == 3  # the last copy may be cut short
    assert smallest_period("abc") == 3
    key = secrets.token_urlsafe(32)
    assert estimated_bits(key * 4) == pytest.approx(estimated_bits(key))


def test_demo_mode_runs_without_secret(tmp_path: object) -> None:
    settings = Settings(demo_mode=True, data_dir=tmp_path, _env_file=None)
    assert create_app(settings).state.settings.demo_mode


def test_environment_prefix(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CHAMELEONS_PORT", "9123")
    monkeypatch.setenv("CHAMELEONS_DATABASE_URL", "sqlite:///x.db")
    settings = Settings(_env_file=None)
    assert settings.port == 9123
    assert settings.effective_database_url == "sqlite:///x.db"
