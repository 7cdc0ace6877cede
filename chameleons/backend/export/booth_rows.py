"""Rows of the ``booth_checks`` export table: every booth check of the study
(:class:`~chameleons.backend.models.BoothCheck`), in time order: those run for a counted
session with its participant and session, and those run without a session (a booth
checked between participants, stored with the study whose copy delay it ran) with both
empty."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from sqlalchemy import and_, or_, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.queries import BATCH, session_filter
from chameleons.backend.export.selection import iso
from chameleons.backend.models import BoothCheck, Participant, Session, Study

STEP_IDS = ("face", "head", "robot", "copy", "speech", "disk")
FIGURES = ("face_fps", "capture_to_send_ms", "head_yaw_deg", "head_pitch_deg", "copy_delay_s",
           "measured_delay_s", "speech_start_ms", "speech_ok", "disk_free_bytes")  # fmt: skip


def booth_check_rows(
    db: DbSession, study: Study, include_rehearsal: bool
) -> Iterator[dict[str, Any]]:
    query = (
        select(BoothCheck, Participant.code)
        .outerjoin(Session, Session.id == BoothCheck.session_id)
        .outerjoin(Participant, Participant.id == Session.participant_id)
        .where(or_(
            and_(BoothCheck.session_id.is_(None), BoothCheck.study_id == study.id),
            and_(BoothCheck.session_id.is_not(None), *session_filter(study.id, include_rehearsal)),
        ))
        .order_by(BoothCheck.checked_at, BoothCheck.id)
    )  # fmt: skip
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
