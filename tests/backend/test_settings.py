from __future__ import annotations

import random
import secrets
import statistics
import subprocess
from collections.abc import Callable

import pytest

from chameleons.backend.app import create_app
from chameleons.key_entropy import (
    estimated_bits,
    expected_shannon_per_char,
    shannon_bits,
    smallest_period,
)
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


HEXSPEAK = [
    "deadbeef" * 4,
    "decafbadbeefcafefeedfacedeadc0de",  # words of hex letters: 2.6 bits a character
    "c0ffee00c0ffee11c0ffee22c0ffee33",
    "0123456789abcdef" * 2,
    "a1b2c3d4e5f60718293a4b5c6d7e8f90",  # a run in the bytes it spells
    "00112233445566778899aabbccddeeff",
]


def test_random_128_bit_hex_keys_are_accepted() -> None:
    """`openssl rand -hex 16` and secrets.token_hex(16): 32 hex digits, exactly 128 bits.
    Their characters' variety is ~3.6 bits, not 4, by chance: nearly all were refused."""
    made = subprocess.run(["openssl", "rand", "-hex", "16"], capture_output=True, text=True,
                          check=True).stdout.strip()  # fmt: skip
    keys = [made, *(secrets.token_hex(16) for _ in range(500))]
    keys += [key.upper() for key in keys[:50]]
    for key in keys:  # fresh random keys each run: the estimate must hold for any
        assert len(key) == 32
        assert estimated_bits(key) >= 128, key
        Settings(secret_key=key, _env_file=None).require_secure()


# A fixed id for the random key: pytest-xdist workers must collect the same test names.
@pytest.mark.parametrize(
    "secret", [*HEXSPEAK, pytest.param(secrets.token_hex(15), id="random-120-bits")]
)
def test_hex_keys_people_make_or_under_128_bits_are_refused(secret: str) -> None:
    assert estimated_bits(secret) < 128
    with pytest.raises(InsecureSettingsError, match="CHAMELEONS_SECRET_KEY"):
        Settings(secret_key=secret, _env_file=None).require_secure()


def test_the_expected_variety_of_random_hex_matches_a_simulation() -> None:
    """The threshold's reference value, against 20,000 seeded random 32-digit keys."""
    rng = random.Random(7)
    keys = ["".join(rng.choice("0123456789abcdef") for _ in range(32)) for _ in range(20_000)]
    simulated = statistics.fmean(shannon_bits(k) / 32 for k in keys)
    assert expected_shannon_per_char(32, 16) == pytest.approx(simulated, abs=0.005)
    assert expected_shannon_per_char(32, 16) == pytest.approx(3.6115, abs=1e-4)


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
