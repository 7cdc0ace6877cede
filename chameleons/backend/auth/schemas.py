from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

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


class StaffUserRead(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    username: str
    role: Role
    is_active: bool
