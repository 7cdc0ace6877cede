"""Password hashing with argon2 (argon2-cffi's recommended parameters)."""

from __future__ import annotations

import gzip
from difflib import SequenceMatcher
from functools import cache
from pathlib import Path

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError

_hasher = PasswordHasher()


@cache
def _dummy_hash() -> str:
    """Verified against when the user does not exist, so timing does not reveal valid
    usernames. Made on first use, not at import (hashing costs tens of milliseconds)."""
    return _hasher.hash("not-a-real-password")


MIN_PASSWORD_LENGTH = 8  # Django's MinimumLengthValidator default; NIST SP 800-63B's floor
_HERE = Path(__file__).parent
# Django's CommonPasswordValidator list (20,000 entries, BSD licence: see
# django_common_passwords_LICENSE.txt) and this project's additions.
_DJANGO_COMMON_FILE = _HERE / "django_common_passwords.txt.gz"
_COMMON_FILE = _HERE / "common_passwords.txt"


@cache
def _common() -> frozenset[str]:
    """Read on the first password check, not at import: the CLI starts without it."""
    with gzip.open(_DJANGO_COMMON_FILE, "rt", encoding="utf-8") as listing:
        django = [line.strip() for line in listing]
    ours = [
        line.strip().lower()
        for line in _COMMON_FILE.read_text(encoding="utf-8").splitlines()
        if not line.startswith("#")
    ]
    return frozenset(word for word in (*django, *ours) if word)


def password_problem(password: str, username: str = "") -> str | None:
    """Why a new staff password is refused (None when it is fine): Django's validators
    (common passwords, similarity to the user name, all digits) in short."""
    lowered = password.lower()
    if lowered.strip() in _common():
        return "This password is too common: choose one that is not on breach lists."
    # Django's UserAttributeSimilarityValidator: a password too like the user name.
    if username and SequenceMatcher(a=lowered, b=username.lower()).quick_ratio() >= 0.7:
        return "The password is too similar to the user name."
    if password.isdigit():
        return "The password must not be only digits."
    if len(set(password)) < 4:
        return "The password needs more different characters."
    return None


def hash_password(password: str) -> str:
    return _hasher.hash(password)


def verify_password(password_hash: str | None, password: str) -> bool:
    try:
        return _hasher.verify(password_hash or _dummy_hash(), password) and bool(password_hash)
    except (VerificationError, InvalidHashError):
        return False
