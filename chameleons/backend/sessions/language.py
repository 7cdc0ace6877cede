"""The participant's language, changed on the phone's first page (before consent).

The session starts in the language chosen at registration (the study's default when none
was); until the participant agrees to take part (or, in a study without a consent page,
answers the first question) the phone offers the study's other languages. Each change is
an event (``phone.language``) on the timeline, so the console and the export show it.
"""

from __future__ import annotations

from chameleons.backend.models import Event
from chameleons.backend.sessions.answers import answered
from chameleons.backend.sessions.consent import BEFORE_POSITION
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.studies.errors import ConflictError, GoneError, InvalidInputError
from chameleons.i18n import N_


def may_choose_language(flow: Flow) -> bool:
    session = flow.session
    return (
        len(flow.spec.languages) > 1
        and session.state == "pending"
        and session.consent_at is None
        and not answered(flow, BEFORE_POSITION)
    )


def choose_language(flow: Flow, client_id: str, language: str) -> Event:
    if flow.session.state in ("complete", "ended"):
        raise GoneError(N_("This session has ended. Thank you!"))
    if language not in flow.spec.languages:
        raise InvalidInputError(N_("This study is not available in that language."))
    if not may_choose_language(flow):
        raise ConflictError(N_("The language can only be changed before the study begins."))
    before = flow.session.language
    flow.session.language = language
    flow.db.flush()
    return flow.log(
        "phone.language",
        source="participant",
        client_id=client_id,
        payload={"from": before, "to": language},
    )
