from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, Field


class StudyCreate(BaseModel):
    yaml: str | None = Field(
        default=None, max_length=1_000_000, description="Study YAML; omitted: the default study"
    )
    plan_seed: int | None = Field(default=None, ge=0, le=2**31 - 1)


class StudyRead(BaseModel):
    id: int
    name: str
    config_hash: str
    plan_seed: int
    is_active: bool
    created_at: datetime
    plan_rows: int
    participants: int
    # The loader's warnings about the study file (e.g. item wording used twice).
    warnings: list[str] = Field(default_factory=list)
    languages: list[str] = Field(default_factory=list)
    default_language: str = ""
    # language -> why its prompt catalogue cannot run a session (real sessions in it are
    # refused; rehearsals warned): the prompts the study can need that it lacks.
    prompt_gaps: dict[str, str] = Field(default_factory=dict)
    # Why a natural condition must not reach real participants as it is (it replays the
    # shipped synthetic demo clip), or "".
    natural_clip_warning: str = ""


class PlanRequest(BaseModel):
    participants: int = Field(ge=1, le=1000)
    seed: int | None = Field(default=None, ge=0, le=2**31 - 1)


class PlanRowRead(BaseModel):
    id: int
    row_number: int
    withdrawals: int
    participant_code: str | None
    interactions: list[dict[str, Any]]


class ParticipantCreate(BaseModel):
    rehearsal: bool = False


class ParticipantRead(BaseModel):
    id: int
    code: str
    status: str
    is_rehearsal: bool
    row_number: int | None
