"""The participant's JSON API and WebSocket, addressed by the session's phone token.

No login: the token (256 random bits) is the credential, and it opens only its own session.
"""

from __future__ import annotations

import contextlib

from fastapi import Request, WebSocket
from fastapi.concurrency import run_in_threadpool
from sqlalchemy.orm import Session, sessionmaker

from chameleons.backend.dependencies import DbSession
from chameleons.backend.events import live
from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub, Message, session_channel
from chameleons.backend.events.unit_of_work import WriteDb, write_session
from chameleons.backend.models import Event
from chameleons.backend.phone import devices
from chameleons.backend.phone.language import phone_errors
from chameleons.backend.phone.retained import committed
from chameleons.backend.phone.schemas import (
    ConsentSubmission,
    LanguageSubmission,
    QuestionnaireSubmission,
    RankingSubmission,
)
from chameleons.backend.phone.submissions import Receipt, submit
from chameleons.backend.phone.view import PhoneState, phone_state
from chameleons.backend.routing import make_router
from chameleons.backend.sessions.answers import submit_questionnaire, submit_ranking
from chameleons.backend.sessions.consent import record_consent
from chameleons.backend.sessions.flow import Flow, load_by_token
from chameleons.backend.sessions.language import choose_language
from chameleons.backend.sessions.snapshot import phone_presence_key
from chameleons.backend.studies.errors import (
    ConflictError,
    GoneError,
    InvalidInputError,
    NotFoundError,
)
from chameleons.backend.wizard import readiness
from chameleons.i18n import N_

router = make_router(tags=["phone"])
ENDED_MESSAGE = N_("This session has ended. Thank you for taking part!")
DECLINED_MESSAGE = N_(
    "You have chosen not to take part, and nothing about you has been kept. Thank you for "
    "your time; please give the phone back to the experimenter."
)


@router.get("/api/phone/{token}/state")
def get_state(token: str, db: DbSession) -> PhoneState:
    with phone_errors(db, token):
        flow = load_by_token(db, token, lock=False)
        if flow.session.state in ("complete", "ended"):
            raise GoneError(ENDED_MESSAGE)
        return phone_state(flow)


@router.post("/api/phone/{token}/ranking")
def post_ranking(token: str, data: RankingSubmission, db: WriteDb) -> Receipt:
    with phone_errors(db, token):
        return submit(
            db,
            token,
            data.client_id,
            lambda flow: submit_ranking(flow, data.client_id, data.position, data.ranking),
        )


@router.post("/api/phone/{token}/consent")
def post_consent(token: str, data: ConsentSubmission, db: WriteDb) -> Receipt:
    with phone_errors(db, token):
        return submit(
            db, token, data.client_id,
            lambda flow: record_consent(flow, data.client_id, data.agree,
                                        video=data.video, audio=data.audio),
        )  # fmt: skip


@router.post("/api/phone/{token}/language")
def post_language(token: str, data: LanguageSubmission, request: Request, db: WriteDb) -> Receipt:
    """The participant's language, before consent; the phone reloads its page in it. A
    real session is refused a language whose prompts cannot voice it (``readiness``)."""

    def change(flow: Flow) -> Event:
        try:
            readiness.require_prompts(request.app.state, flow, data.language)
        except ConflictError:
            raise InvalidInputError(N_("This study is not available in that language.")) from None
        return choose_language(flow, data.client_id, data.language)

    with phone_errors(db, token):
        return submit(db, token, data.client_id, change)


@router.post("/api/phone/{token}/questionnaire")
def post_questionnaire(token: str, data: QuestionnaireSubmission, db: WriteDb) -> Receipt:
    answers = {key: value for key, value in data.answers.items() if value is not None}
    with phone_errors(db, token):
        return submit(
            db,
            token,
            data.client_id,
            lambda flow: submit_questionnaire(
                flow, data.client_id, data.position, data.questionnaire, answers
            ),
        )


def _read_state(factory: sessionmaker[Session], hub: LiveHub, token: str) -> tuple[int, Message]:
    """(session id, message) for the phone; ``ended`` when the session is complete."""
    with write_session(factory, hub) as db:
        flow = load_by_token(db, token, lock=False)
        return flow.session.id, {"type": "state", "state": phone_state(flow)}


def _log_connection(
    factory: sessionmaker[Session], hub: LiveHub, token: str, kind: str, device: Message
) -> None:
    with write_session(factory, hub) as db:
        flow = load_by_token(db, token, lock=False)
        if flow.session.state not in ("complete", "ended"):
            phones = hub.present(phone_presence_key(flow.session.id))
            events.record(
                db,
                kind,
                source="participant",
                study_id=flow.session.study_id,
                session_id=flow.session.id,
                payload={"device": device["id"], "label": device["label"], "phones": phones},
            )
        else:
            # Nothing is logged after the end, but the console's phone chip must still
            # learn that the phone came or went: a change without an event.
            hub.publish(session_channel(flow.session.id), {"type": "presence", "kind": kind})


async def _send_away(websocket: WebSocket) -> None:
    await live.send_json(websocket, {"type": "sent_away", "message": devices.SENT_AWAY_MESSAGE})
    await websocket.close(code=devices.SENT_AWAY_CODE)


@router.websocket("/ws/p/{token}")
async def phone_socket(websocket: WebSocket, token: str) -> None:
    factory = websocket.app.state.sessionmaker
    hub: LiveHub = websocket.app.state.live_hub
    try:
        session_id, first = await run_in_threadpool(_read_state, factory, hub, token)
    except NotFoundError:
        await websocket.close(code=4404)
        return
    await websocket.accept()
    device = devices.detail(
        devices.device_id(websocket.query_params.get("device")),
        websocket.headers.get("user-agent", ""),
    )
    if devices.refused(websocket.app.state, hub, session_id, device["id"]):
        await _send_away(websocket)
        return
    async with hub.subscribe(session_channel(session_id)) as subscription:
        await live.send_json(websocket, first)
        if first["state"]["view"] == "ended":
            await websocket.close(code=4410)
            return

        async def on_change(messages: list[Message]) -> bool:
            if devices.is_sent_away(messages, device["id"]):
                await _send_away(websocket)  # the wizard disconnected this phone
                return True
            # Whatever was published, the phone gets only its own whitelisted view: the one
            # the change committed when there is one, else read afresh.
            state = committed(hub, session_id, messages)
            message: Message
            if state is not None:
                message = {"type": "state", "state": state}
            else:
                _id, message = await run_in_threadpool(_read_state, factory, hub, token)
            await live.send_json(websocket, message)
            if message["state"]["view"] == "ended":
                await websocket.close(code=4410)  # the link has stopped working
                return True
            return False

        async def log(kind: str, device: Message) -> None:
            await run_in_threadpool(_log_connection, factory, hub, token, kind, device)

        try:
            with hub.presence(phone_presence_key(session_id), device):
                await log("phone.connected", device)
                await live.serve(websocket, subscription, on_change)
        finally:
            # Out of the presence count first, so the wizard's snapshot says "disconnected".
            with contextlib.suppress(Exception):  # the server may be shutting down
                await log("phone.disconnected", device)
