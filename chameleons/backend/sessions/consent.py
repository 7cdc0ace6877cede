"""Consent on the phone, before anything else.

A study with a consent page (``procedure.consent``) cannot start until the participant
agreed on the phone; ``consent_at`` records when (on the session, and on the participant
for the participants table). Declining ends the session at once, politely: the session is
``ended`` with reason ``consent_declined``, the participant ``declined``, and nothing but
the refusal is kept: the consent page comes before every question, so there are no
answers, and the timeline only says that the phone connected and consent was declined.
The participant's plan row is freed for the next participant, as nothing of it ran.

What a pending session waits for (consent, the ``before`` questionnaires) is the flow's to
say, as its allowed actions ask it: ``waiting_before_start`` and ``BEFORE_POSITION`` live in
:mod:`.flow` and are re-exported here.
"""

from __future__ import annotations

from datetime import UTC, datetime

from chameleons.backend.models import Event
from chameleons.backend.sessions.flow import BEFORE_POSITION as BEFORE_POSITION
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.sessions.flow import waiting_before_start as waiting_before_start
from chameleons.backend.studies.errors import ConflictError, GoneError
from chameleons.i18n import N_

CONSENT_DECLINED = "consent_declined"


def record_consent(
    flow: Flow, client_id: str, agree: bool, *, video: bool = False, audio: bool = False
) -> Event:
    """Agree or decline; with agreement, the video items as ticked (``video``: may be
    filmed; ``audio``: the microphone too). They count only where the study asks them
    (``procedure.video``), audio only with video; elsewhere they stay None (not asked)."""
    consent = flow.spec.procedure.consent
    session = flow.session
    if session.state in ("complete", "ended"):
        raise GoneError(N_("This session has ended. Thank you!"))
    if consent is None:
        raise ConflictError(N_("This study does not ask for consent on the phone."))
    if session.consent_at is not None:
        raise ConflictError(N_("Your consent was already recorded."))
    if session.state != "pending":
        raise ConflictError(N_("The session has already started."))
    now = datetime.now(UTC)
    payload: dict[str, object] = {"version": consent.version}
    if agree:
        session.consent_at = now
        flow.participant.consent_at = now
        asked = flow.spec.procedure.video if flow.spec.procedure.records_video else None
        if asked is not None:
            session.video_consent = video
            session.video_audio_consent = bool(video and audio) if asked.audio else None
            payload["video"] = session.video_consent
            payload["audio"] = session.video_audio_consent
        flow.db.flush()
        return flow.log("consent.given", source="participant", client_id=client_id, payload=payload)
    session.state = "ended"
    session.ended_at = now
    session.end_reason = CONSENT_DECLINED
    flow.participant.status = "declined"
    # Nothing ran, so the plan row goes to the next participant (the session still names it).
    flow.participant.plan_row_id = None
    flow.db.flush()
    return flow.log("consent.declined", source="participant", client_id=client_id, payload=payload)
