from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field, field_validator

from chameleons.backend.input_guard import MAX_ROW_ID

WorkerTime = Field(default=None, description="The worker's clock for this action, if known")


class SessionCreate(BaseModel):
    study_id: int = Field(ge=1, le=MAX_ROW_ID)
    participant_code: str | None = Field(
        default=None, max_length=32, description="Omitted: register a new participant"
    )
    booth: str = Field(default="booth-1", min_length=1, max_length=64)
    rehearsal: bool = False
    language: str | None = Field(
        default=None,
        max_length=16,
        description="One of the study's languages; omitted: its default",
    )


class StartRequest(BaseModel):
    worker_time: float | None = WorkerTime


class AdvanceRequest(BaseModel):
    position: int = Field(ge=1, le=100)
    to: str = Field(max_length=32)
    worker_time: float | None = WorkerTime


class DecisionRequest(BaseModel):
    position: int = Field(ge=1, le=100)
    index: int = Field(ge=1, le=100)
    accepted: bool
    worker_time: float | None = WorkerTime


class UndoRequest(BaseModel):
    position: int = Field(ge=1, le=100)
    index: int = Field(ge=1, le=100)


class ConditionRequest(BaseModel):
    condition: str = Field(max_length=64)
    position: int | None = Field(default=None, ge=1, le=100)
    confirm_deviation: bool = Field(
        default=False,
        description="Go ahead with a switch to a condition this session has already run "
        "(refused with 409 otherwise); it is logged as a deviation.",
    )
    worker_time: float | None = WorkerTime


class PauseRequest(BaseModel):
    reason: str = Field(
        max_length=32,
        description="participant_break, technical_failure, interruption or other",
    )
    note: str = Field(default="", max_length=1000, description="Required for 'other'")


class EndRequest(BaseModel):
    reason: str = Field(
        max_length=32,
        description="participant_withdrew, technical_failure, time or other",
    )
    note: str = Field(default="", max_length=1000, description="Required for 'other'")
    worker_time: float | None = WorkerTime


class NoteRequest(BaseModel):
    kind: str = Field(pattern=r"^[a-z][a-z0-9_]*(\.[a-z0-9_]+)*$", max_length=48)
    payload: dict[str, Any] = Field(default_factory=dict)
    position: int | None = Field(default=None, ge=1, le=100)
    worker_time: float | None = WorkerTime


class WizardNoteCreate(BaseModel):
    """A free-text observation the wizard stamps on the timeline ("participant laughed")."""

    text: str = Field(min_length=1, max_length=2000)

    @field_validator("text")
    @classmethod
    def _readable(cls, text: str) -> str:
        text = text.strip()
        if not text:
            raise ValueError("The note is empty: write what you observed.")
        if "\x00" in text:
            raise ValueError("The note contains a NUL character; retype it.")
        return text


class SessionSummary(BaseModel):
    id: int
    study_id: int
    participant_code: str
    state: str
    current_position: int
    booth: str
    is_rehearsal: bool
    created_at: str
