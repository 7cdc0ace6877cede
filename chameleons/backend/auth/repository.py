from __future__ import annotations

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from chameleons.backend.models import StaffUser


def get_by_username(db: Session, username: str) -> StaffUser | None:
    return db.scalars(
        select(StaffUser).where(func.lower(StaffUser.username) == username.lower())
    ).first()


def get_by_id(db: Session, user_id: int) -> StaffUser | None:
    return db.get(StaffUser, user_id)


def add(db: Session, user: StaffUser) -> StaffUser:
    db.add(user)
    db.flush()
    return user
