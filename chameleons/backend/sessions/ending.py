"""Ending a session early, with a reason. Nothing is deleted: what was recorded stays, an
interaction that was running stays as far as it got (``partial`` in the export), later
ones were never run (``not_run``), and the analysis counts both as missing.

The ``session.ended_early`` event is logged on the interaction that was running (if any),
so the booth stops and indexes that interaction's recording as it does when one finishes.
"""

from __future__ import annotations

from datetime import UTC, datetime

from chameleons.backend.models import Interaction
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.sessions.pausing import close_pause
from chameleons.backend.sessions.reasons import check_reason
from chameleons.backend.sessions.states import END_REASONS

ENDED_EARLY = "session.ended_early"
RUNNING_STEPS = ("discussion", "ranking", "negotiation", "questionnaire")


def end_early(
    flow: Flow, reason: str, note: str = "", worker_time: float | None = None
) -> Interaction | None:
    """End the session now; returns the interaction that was running, if one was."""
    note = check_reason(END_REASONS, reason, note, "end a session", "the session ends")
    state = flow.session.state
    if state == "complete":
        raise flow.refuse("The session is already complete: there is nothing to end.")
    if state == "ended":
        raise flow.refuse("The session has already been ended.")
    running = _running(flow)
    now = datetime.now(UTC)
    paused = close_pause(flow, now)
    flow.session.state = "ended"
    flow.session.ended_at = now
    flow.session.end_reason = reason
    flow.session.end_note = note or None
    flow.participant.status = "ended_early"
    flow.db.flush()
    flow.log(
        ENDED_EARLY,
        interaction=running,
        worker_time=worker_time,
        payload={
            "reason": reason,
            "reason_text": END_REASONS[reason],
            "note": note,
            "from_state": state,
            "position": running.position if running else None,
            "step": running.state if running else None,
            "paused_s": paused,
        },
    )
    return running


def _running(flow: Flow) -> Interaction | None:
    if flow.session.state != "running":
        return None
    current = flow.current
    return current if current.state in RUNNING_STEPS else None
