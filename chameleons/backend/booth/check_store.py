"""Stores a booth check's result: a ``booth_check`` row (pass/fail per step, the figures
as columns, exported as ``booth_checks``) and the ``booth.checked`` timeline event."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.booth.check import CHECKED
from chameleons.backend.events import repository as events
from chameleons.backend.models import BoothCheck, Session


def _figure(steps: dict[str, Mapping[str, Any]], step: str, name: str) -> Any:
    figures = (steps.get(step) or {}).get("figures") or {}
    value = figures.get(name)
    return value if isinstance(value, int | float) and not isinstance(value, bool) else None


def store(
    db: DbSession, booth: str, session: Session | None, result: dict[str, Any],
    study_id: int | None = None,
) -> int:  # fmt: skip
    """Add the row and the event; returns the event's id. A check without a session belongs
    to ``study_id`` (the study whose copy delay it ran with), so its study's export has it."""
    steps = {s["id"]: s for s in result["steps"]}
    speech = steps.get("speech") or {}
    row = BoothCheck(
        booth=booth, study_id=session.study_id if session else study_id,
        session_id=session.id if session else None, passed=bool(result["passed"]),
        steps=list(result["steps"]),
        face_fps=_figure(steps, "face", "fps"),
        capture_to_send_ms=_figure(steps, "face", "latency_ms"),
        # The movement from the resting pose (the rest itself is in the step's figures).
        head_yaw_deg=_figure(steps, "head", "turn_deg"),
        head_pitch_deg=_figure(steps, "head", "nod_deg"),
        copy_delay_s=_figure(steps, "copy", "delay_s"),
        measured_delay_s=_figure(steps, "copy", "measured_s"),
        speech_start_ms=_figure(steps, "speech", "start_ms"),
        speech_ok=None if speech.get("status") in (None, "warn") else speech["status"] == "pass",
        disk_free_bytes=_figure(steps, "disk", "free_bytes"),
    )  # fmt: skip
    db.add(row)
    event = events.record(
        db, CHECKED, source="server", study_id=row.study_id, session_id=row.session_id,
        payload={"booth": booth, **result},
    )  # fmt: skip
    db.flush()
    return int(event.id)
