"""Staff JSON API for the current user and (PI only) user management."""

from __future__ import annotations

from fastapi import Depends, HTTPException, status

from chameleons.backend.auth import service
from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI, CurrentStaff
from chameleons.backend.auth.schemas import StaffUserCreate, StaffUserRead
from chameleons.backend.dependencies import DbSession
from chameleons.backend.routing import make_router

router = make_router(prefix="/api/staff", tags=["staff"])


@router.get("/me")
def me(user: CurrentStaff) -> StaffUserRead:
    return StaffUserRead.model_validate(user)


@router.post("/users", status_code=status.HTTP_201_CREATED, dependencies=[Depends(verify_csrf)])
def create_user(data: StaffUserCreate, _pi: CurrentPI, db: DbSession) -> StaffUserRead:
    try:
        return StaffUserRead.model_validate(service.create_user(db, data))
    except service.UserExistsError as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from exc
