"""Staff accounts: creation and credential checks. Flushes only; the caller commits."""

from __future__ import annotations

from sqlalchemy.orm import Session

from chameleons.backend.auth import repository, sessions
from chameleons.backend.auth.passwords import hash_password, verify_password
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.models import StaffUser


class UserExistsError(ValueError):
    pass


def create_user(db: Session, data: StaffUserCreate) -> StaffUser:
    if repository.get_by_username(db, data.username) is not None:
        raise UserExistsError(f"a staff user named {data.username!r} already exists")
    user = StaffUser(
        username=data.username, password_hash=hash_password(data.password), role=data.role
    )
    return repository.add(db, user)


def set_password(db: Session, user: StaffUser, password: str) -> None:
    user.password_hash = hash_password(password)
    db.flush()


def set_active(db: Session, user: StaffUser, active: bool) -> None:
    """Deactivating ends the account's sessions at once; it cannot log in until reactivated."""
    user.is_active = active
    if not active:
        sessions.end_all(db, user.id, "deactivated")
    db.flush()


def authenticate(db: Session, username: str, password: str) -> StaffUser | None:
    user = repository.get_by_username(db, username)
    ok = verify_password(user.password_hash if user else None, password)
    if user is None or not ok or not user.is_active:
        return None
    return user
