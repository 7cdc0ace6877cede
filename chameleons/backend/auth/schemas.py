from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from chameleons.backend.auth.passwords import MIN_PASSWORD_LENGTH, password_problem

Role = Literal["pi", "wizard"]


class StaffUserCreate(BaseModel):
    username: str = Field(min_length=2, max_length=64, pattern=r"^[A-Za-z0-9_.@-]+$")
    password: str = Field(min_length=MIN_PASSWORD_LENGTH, max_length=256)
    role: Role

    @model_validator(mode="after")
    def _not_guessable(self) -> StaffUserCreate:
        problem = password_problem(self.password, self.username)
        if problem:
            raise ValueError(problem)
        return self


def refusal(exc: ValidationError) -> str:
    """Why a new account was refused, as a person reads it: ``password: String should have
    at least 8 characters``, or the password check's own sentence (it judges the whole
    account, so it names no field and carries no "Value error," prefix)."""
    sentences = []
    for error in exc.errors():
        cause = (error.get("ctx") or {}).get("error")
        message = str(cause) if isinstance(cause, ValueError) else str(error["msg"])
        field = ".".join(str(part) for part in error["loc"])
        sentences.append(f"{field}: {message}" if field else message)
    return "; ".join(sentences)


class StaffUserRead(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    username: str
    role: Role
    is_active: bool
