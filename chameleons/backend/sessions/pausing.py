"""Pausing a session and resuming it, with a reason (the wizard's side; issue 16).

A session that is running (or in its final questionnaire) may be paused: the participant
needs a break, the robot failed, someone came in. While paused nothing moves on: the
wizard's steps, decisions and prompts are refused with a sentence (409), the phone shows
a calm "short pause" page and keeps any answer until the session continues. Notes, a
condition switch (fixing the set-up) and ending the session early stay possible.

Each pause and resume is an event (``session.paused``, ``session.resumed`` with the
pause's length), so the export's events table has them; the session row adds up the
ended pauses (``pause_count``, ``paused_seconds``).
"""

from __future__ import annotations

from datetime import UTC, datetime

from chameleons.backend.models import Interaction
from chameleons.backend.sessions.flow import Flow, as_utc
from chameleons.backend.sessions.reasons import check_reason
from chameleons.backend.studies.errors import ConflictError

PAUSED = "session.paused"
RESUMED = "session.resumed"
PAUSE_REASONS = {
    "participant_break": "the participant needed a break",
    "technical_failure": "technical failure",
    "interruption": "an interruption in the booth",
    "other": "other",
}
PAUSABLE = ("running", "final_questionnaire")
PHONE_PAUSED = (
    "The session is paused for a moment. Your answer is kept on this phone and sent as "
    "soon as the session continues."
)


def is_paused(flow: Flow) -> bool:
    return flow.session.paused_at is not None


def pause(flow: Flow, reason: str, note: str = "") -> None:
    note = check_reason(PAUSE_REASONS, reason, note, "pause a session", "the session pauses")
    state = flow.session.state
    if is_paused(flow):
        raise flow.refuse("The session is already paused.")
    if state not in PAUSABLE:
        raise flow.refuse(f"Only a session that is running can be paused (it is {state}).")
    flow.session.paused_at = datetime.now(UTC)
    flow.session.pause_reason = reason
    flow.session.pause_note = note or None
    flow.db.flush()
    flow.log(PAUSED, interaction=_current(flow), payload=_describe(flow))


def resume(flow: Flow) -> float:
    """Continue where the session stopped; returns how long the pause lasted, in seconds."""
    if not is_paused(flow):
        raise flow.refuse("The session is not paused.")
    payload = _describe(flow)
    seconds = close_pause(flow, datetime.now(UTC))
    flow.db.flush()
    flow.log(RESUMED, interaction=_current(flow), payload={**payload, "paused_s": seconds})
    return seconds or 0.0


def close_pause(flow: Flow, now: datetime) -> float | None:
    """End an open pause (resumed, or the session ended meanwhile): add its length to the
    session's totals; None when the session was not paused."""
    session = flow.session
    if session.paused_at is None:
        return None
    seconds = round(max(0.0, (now - as_utc(session.paused_at)).total_seconds()), 3)
    session.paused_seconds = round((session.paused_seconds or 0.0) + seconds, 3)
    session.pause_count = (session.pause_count or 0) + 1
    session.paused_at = None
    session.pause_reason = None
    session.pause_note = None
    return seconds


def refuse_if_paused(flow: Flow, doing: str) -> None:
    """A wizard's step while paused: 409 saying so, and that resuming is what is allowed."""
    if is_paused(flow):
        raise flow.refuse(f"The session is paused: {doing} waits until it is resumed.")


def refuse_phone_if_paused(flow: Flow) -> None:
    if is_paused(flow):
        raise ConflictError(PHONE_PAUSED)


def paused_view(flow: Flow) -> dict[str, object] | None:
    """The pause as the wizard's snapshot shows it (None when not paused)."""
    session = flow.session
    if session.paused_at is None:
        return None
    return {"since": as_utc(session.paused_at).isoformat(), **_describe(flow)}


def _describe(flow: Flow) -> dict[str, object]:
    session = flow.session
    reason = session.pause_reason or "other"
    current = _current(flow)
    return {
        "reason": reason,
        "reason_text": PAUSE_REASONS.get(reason, reason),
        "note": session.pause_note or "",
        "position": current.position if current else None,
        "step": current.state if current else session.state,
    }


def _current(flow: Flow) -> Interaction | None:
    if flow.session.state != "running":
        return None
    return flow.current
