"""The wizard's JSON API: create and drive a session. Any logged-in staff member may;
unsafe methods need the ``X-CSRF-Token`` header.

    POST /api/sessions                {study_id, participant_code?, booth?, rehearsal?,
                                       language?}                        -> 201
    GET  /api/sessions?study_id=&state=                                  -> [summary]
    GET  /api/sessions/{id}                                              -> snapshot
    POST /api/sessions/{id}/start     {worker_time?}                     -> snapshot
    POST /api/sessions/{id}/advance   {position, to, worker_time?}       -> snapshot
    POST /api/sessions/{id}/decide    {position, index, accepted, worker_time?} -> snapshot
    POST /api/sessions/{id}/undo      {position, index}                  -> snapshot
    POST /api/sessions/{id}/condition {condition, position?, confirm_deviation?, worker_time?}
    POST /api/sessions/{id}/end       {reason, note?, worker_time?}      -> snapshot
    POST /api/sessions/{id}/pause     {reason, note?}                    -> snapshot
    POST /api/sessions/{id}/resume    {}                                 -> snapshot
    POST /api/sessions/{id}/events    {kind, payload?, position?, worker_time?} -> 201 event
    POST /api/sessions/{id}/notes     {text}                             -> 201 event
    POST /api/sessions/{id}/phones/{device}/disconnect                   -> snapshot
    GET  /api/sessions/{id}/events?after=&limit=                         -> [event]
    GET  /api/sessions/{id}/phone-qr.svg                                 -> image/svg+xml
    WS   /ws/sessions/{id}            (see ``live.py``)

Every change answers with the session's full snapshot (see ``snapshot.py``); an illegal
step answers 409 with a sentence saying why and what is allowed now, bad input 422. A
switch to a condition the session already ran answers 409 with ``{"message", "confirm":
"confirm_deviation"}`` until it is repeated with ``confirm_deviation: true``.
"""

from __future__ import annotations

import io
from typing import Annotated

import segno
from fastapi import Depends, Query, Request, Response, status
from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.dependencies import DbSession
from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub
from chameleons.backend.events.unit_of_work import Hub, WriteDb
from chameleons.backend.models import Participant
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.phone import devices
from chameleons.backend.phone.retained import retained_state
from chameleons.backend.routing import make_router
from chameleons.backend.sessions import ending, negotiation, pausing, service
from chameleons.backend.sessions.flow import Flow, load
from chameleons.backend.sessions.schemas import (
    AdvanceRequest,
    ConditionRequest,
    DecisionRequest,
    EndRequest,
    NoteRequest,
    PauseRequest,
    SessionCreate,
    SessionSummary,
    StartRequest,
    UndoRequest,
    WizardNoteCreate,
)
from chameleons.backend.sessions.snapshot import retain, session_snapshot
from chameleons.backend.studies import service as studies
from chameleons.backend.studies.errors import http_errors
from chameleons.backend.wizard import readiness

router = make_router(prefix="/api/sessions", tags=["sessions"])
WRITE = [Depends(verify_csrf)]
Snapshot = dict[str, object]


def base_url(request: Request) -> str:
    configured = request.app.state.settings.public_url
    return str(configured or request.base_url).rstrip("/")


def snapshot_of(flow: Flow, request: Request, hub: LiveHub) -> Snapshot:
    """The session as the response shows it, retained for the live consoles once committed
    (they are woken by this change's events and would otherwise load it again)."""
    url = base_url(request)
    snapshot = session_snapshot(flow, url, devices.phones(hub, flow.session.id))
    retain(flow, snapshot)
    retained_state(flow, snapshot["version"])  # and the phone's view, for the phone's socket
    return snapshot


@router.post("", status_code=status.HTTP_201_CREATED, dependencies=WRITE)
def create_session(
    data: SessionCreate, request: Request, _user: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    with http_errors():
        study = studies.get_study(db, data.study_id)
        if data.participant_code is None:
            participant = studies.register_participant(db, study, data.rehearsal)
        else:
            participant = studies.participant_by_code(db, study, data.participant_code)
        flow = service.create_session(db, study, participant, data.booth, data.language)
        readiness.require_prompts(request.app.state, flow)  # before the session exists
        return snapshot_of(flow, request, hub)


@router.get("")
def list_sessions(
    _user: CurrentStaff, db: DbSession, study_id: int | None = None, state: str | None = None
) -> list[SessionSummary]:
    query = select(SessionRow, Participant.code).join(
        Participant, Participant.id == SessionRow.participant_id
    )
    if study_id is not None:
        query = query.where(SessionRow.study_id == study_id)
    if state is not None:
        query = query.where(SessionRow.state == state)
    return [
        SessionSummary(
            id=row.id,
            study_id=row.study_id,
            participant_code=code,
            state=row.state,
            current_position=row.current_position,
            booth=row.booth,
            is_rehearsal=row.is_rehearsal,
            created_at=row.created_at.isoformat(),
        )
        for row, code in db.execute(query.order_by(SessionRow.id)).tuples()
    ]


@router.get("/{session_id}")
def get_session(
    session_id: int, request: Request, _user: CurrentStaff, db: DbSession, hub: Hub
) -> Snapshot:
    with http_errors():
        return snapshot_of(load(db, session_id, lock=False), request, hub)


@router.post("/{session_id}/start", dependencies=WRITE)
def start(
    session_id: int, data: StartRequest, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    with http_errors():
        flow = load(db, session_id)
        if flow.session.state == "pending":  # the phone may have changed the language
            readiness.require_prompts(request.app.state, flow)
        service.start(flow, data.worker_time)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/advance", dependencies=WRITE)
def advance(
    session_id: int, data: AdvanceRequest, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    with http_errors():
        flow = load(db, session_id)
        service.advance(flow, data.position, data.to, data.worker_time)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/decide", dependencies=WRITE)
def decide(
    session_id: int,
    data: DecisionRequest,
    request: Request,
    _u: CurrentStaff,
    db: WriteDb,
    hub: Hub,
) -> Snapshot:
    with http_errors():
        flow = load(db, session_id)
        negotiation.decide(flow, data.position, data.index, data.accepted, data.worker_time)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/undo", dependencies=WRITE)
def undo(
    session_id: int, data: UndoRequest, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    with http_errors():
        flow = load(db, session_id)
        negotiation.undo(flow, data.position, data.index)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/condition", dependencies=WRITE)
def switch_condition(
    session_id: int,
    data: ConditionRequest,
    request: Request,
    _u: CurrentStaff,
    db: WriteDb,
    hub: Hub,
) -> Snapshot:
    with http_errors():
        flow = load(db, session_id)
        service.switch_condition(
            flow, data.condition, data.position, data.worker_time, data.confirm_deviation
        )
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/end", dependencies=WRITE)
def end_early(
    session_id: int, data: EndRequest, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    """End the session early with a reason; its data stay (and count as missing where the
    interactions did not run)."""
    with http_errors():
        flow = load(db, session_id)
        ending.end_early(flow, data.reason, data.note, data.worker_time)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/pause", dependencies=WRITE)
def pause(
    session_id: int, data: PauseRequest, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    """Pause with a reason: nothing moves on, the phone shows a short-pause page."""
    with http_errors():
        flow = load(db, session_id)
        pausing.pause(flow, data.reason, data.note)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/resume", dependencies=WRITE)
def resume(session_id: int, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub) -> Snapshot:
    with http_errors():
        flow = load(db, session_id)
        pausing.resume(flow)
        return snapshot_of(flow, request, hub)


@router.post("/{session_id}/events", status_code=status.HTTP_201_CREATED, dependencies=WRITE)
def add_note(
    session_id: int, data: NoteRequest, _u: CurrentStaff, db: WriteDb
) -> dict[str, object]:
    with http_errors():
        flow = load(db, session_id)
        service.log_note(flow, data.kind, data.payload, data.position, data.worker_time)
        return events.to_dict(events.for_session(db, session_id, limit=1_000_000)[-1])


@router.post("/{session_id}/notes", status_code=status.HTTP_201_CREATED, dependencies=WRITE)
def add_wizard_note(
    session_id: int, data: WizardNoteCreate, _u: CurrentStaff, db: WriteDb
) -> dict[str, object]:
    """A wizard's note on the timeline, in any state of the session (also after its end)."""
    with http_errors():
        flow = load(db, session_id)
        return events.to_dict(service.add_wizard_note(flow, data.text))


@router.post("/{session_id}/phones/{device}/disconnect", dependencies=WRITE)
def disconnect_phone(
    session_id: int, device: str, request: Request, _u: CurrentStaff, db: WriteDb, hub: Hub
) -> Snapshot:
    """Send one of two (or more) phones on the participant's link away; it says so."""
    with http_errors():
        flow = load(db, session_id)
        devices.send_away(request.app.state, hub, flow, device)
        return snapshot_of(flow, request, hub)


@router.get("/{session_id}/events")
def list_events(
    session_id: int,
    _u: CurrentStaff,
    db: DbSession,
    after: Annotated[int, Query(ge=0, description="Only events with a larger id.")] = 0,
    limit: Annotated[int, Query(ge=1, le=5000, description="At most this many.")] = 1000,
) -> list[dict[str, object]]:
    # Bounded here: a negative LIMIT is an error on PostgreSQL (a 500 found by the fuzz).
    with http_errors():
        load(db, session_id, lock=False)
    return [events.to_dict(e) for e in events.for_session(db, session_id, after, limit)]


@router.get("/{session_id}/phone-qr.svg")
def phone_qr(session_id: int, request: Request, _u: CurrentStaff, db: DbSession) -> Response:
    with http_errors():
        flow = load(db, session_id, lock=False)
    return Response(
        qr_svg(f"{base_url(request)}/p/{flow.session.phone_token}"),
        media_type="image/svg+xml",
        headers={"Cache-Control": "no-store"},
    )


def qr_svg(url: str, title: str = "Phone link") -> bytes:
    buffer = io.BytesIO()
    segno.make_qr(url, error="m").save(
        buffer, kind="svg", scale=6, border=2, xmldecl=False, title=title
    )
    return buffer.getvalue()


def session_row(db: Session, session_id: int) -> SessionRow | None:
    return db.get(SessionRow, session_id)
