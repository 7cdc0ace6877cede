"""Rows of the ``booth_checks`` export table: every booth check run for a counted session
(:class:`~chameleons.backend.models.BoothCheck`), in time order."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.queries import BATCH, joined
from chameleons.backend.export.selection import iso
from chameleons.backend.models import BoothCheck, Participant, Session, Study

STEP_IDS = ("face", "head", "robot", "copy", "speech", "disk")
FIGURES = ("face_fps", "capture_to_send_ms", "head_yaw_deg", "head_pitch_deg", "copy_delay_s",
           "measured_delay_s", "speech_start_ms", "speech_ok", "disk_free_bytes")  # fmt: skip


def booth_check_rows(
    db: DbSession, study: Study, include_rehearsal: bool
) -> Iterator[dict[str, Any]]:
    query = select(BoothCheck, Participant.code).join(Session, Session.id == BoothCheck.session_id)
    query = joined(query, study.id, include_rehearsal).order_by(BoothCheck.checked_at,
                                                                BoothCheck.id)  # fmt: skip
    for check, code in db.execute(query.execution_options(yield_per=BATCH)):
        statuses = {s.get("id"): s.get("status") for s in check.steps or []}
        yield {
            "participant": code,
            "session": check.session_id,
            "booth": check.booth,
            "checked_at": iso(check.checked_at),
            "passed": check.passed,
            **{f"{step}_status": statuses.get(step) for step in STEP_IDS},
            **{name: getattr(check, name) for name in FIGURES},
        }
