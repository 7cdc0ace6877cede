"""The booths monitor (like oTree's): every booth's participant, step, health, phone and
robot presence and last events on one PI page, refreshed every second, with alarms.

    GET /pi/monitor            the page (static/pi/monitor.js polls the JSON)
    GET /api/pi/monitor        {"booths": [...], "alarms": n, "generated_at": ...}

A booth is listed while it has an open session (pending or running) in the study, or a
worker connected to this server. Its problems are the wizard's health alarms (the same
checks and thresholds as the console's health strip, the *Participant video* chip of a
study that films included: :mod:`chameleons.backend.wizard.video_health`) and a running
session whose phone is gone; they raise the booth's alarm while the booth is in use (a
running session or a connected worker), and only show while it waits for its participant.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from fastapi import Request
from fastapi.responses import HTMLResponse, Response
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSessionType

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import page_context, study_or_404
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub
from chameleons.backend.models import Interaction, Participant, Session, Study
from chameleons.backend.routing import make_router
from chameleons.backend.sessions.snapshot import phone_presence_key
from chameleons.backend.wizard import health, robot, worker_link
from chameleons.backend.wizard.live import display_presence
from chameleons.backend.wizard.video_health import filming, study_records_video, video_check

router = make_router(tags=["dashboard"])
OPEN_STATES = ("pending", "running")
LAST_EVENTS = 4


def booth_sessions(db: DbSessionType, study: Study) -> dict[str, Session]:
    """Each booth's open session: the running one, else the newest pending one."""
    rows = db.scalars(
        select(Session)
        .where(Session.study_id == study.id, Session.state.in_(OPEN_STATES))
        .order_by(Session.id)
    )
    found: dict[str, Session] = {}
    for row in rows:
        held = found.get(row.booth)
        if held is None or held.state != "running":
            found[row.booth] = row
    return found


def _session_view(db: DbSessionType, session: Session, hub: LiveHub) -> dict[str, Any]:
    participant = db.get(Participant, session.participant_id)
    interaction = db.scalars(
        select(Interaction).where(
            Interaction.session_id == session.id,
            Interaction.position == session.current_position,
        )
    ).first()
    recent = events.for_session(db, session.id, 0, 1_000_000)[-LAST_EVENTS:]
    return {
        "id": session.id,
        "participant": participant.code if participant else "?",
        "rehearsal": session.is_rehearsal,
        "state": session.state,
        "position": session.current_position if session.state == "running" else None,
        "step": interaction.state if interaction and session.state == "running" else None,
        "condition": interaction.condition if interaction else None,
        "phone_connected": hub.present(phone_presence_key(session.id)) > 0,
        "phones": hub.present(phone_presence_key(session.id)),
        "paused": session.paused_at is not None,
        "events": [events.to_dict(e) for e in reversed(recent)],
    }


def monitor_state(db: DbSessionType, state: Any, study: Study) -> dict[str, Any]:
    sessions = booth_sessions(db, study)
    bridge = worker_link.bridge_of(state)
    workers = bridge.workers() if bridge is not None and hasattr(bridge, "workers") else {}
    tracker = health.tracker_of(state)
    hub: LiveHub = state.live_hub
    needs = robot.robots_needed(db, study.id)  # a booth with both robots: the one missing
    filmed = study_records_video(db, study.id)  # a study that films: the video chip
    now = datetime.now(UTC)
    booths = []
    for booth in sorted(set(sessions) | set(workers)):
        telemetry, age = worker_link.latest_telemetry(bridge, booth)
        session = sessions.get(booth)
        video = video_check(filming(db, session.id), now) if filmed and session else None
        robot_health = tracker.snapshot(booth, telemetry, age, needs=needs, extra=video,
                                        display=display_presence(state, booth))  # fmt: skip
        view = _session_view(db, session, hub) if session is not None else None
        running = bool(view and view["state"] == "running")
        phone_gone = running and not (view and view["phone_connected"])
        problems = [
            f"{c['label']}: {c['value']}" for c in robot_health["checks"] if c["level"] == "alarm"
        ]
        if phone_gone:
            problems.append("Phone: not connected during the session")
        booths.append({
            "booth": booth,
            "session": view,
            "health": {"checks": robot_health["checks"], "alarm": robot_health["alarm"],
                       "ok": robot_health["ok"]},
            "worker_connected": booth in workers,
            # A booth waiting for its participant warns; one in use raises the alarm.
            "alarm": bool(problems) and (booth in workers or running),
            "problems": problems,
        })  # fmt: skip
    return {
        "study": {"id": study.id, "name": study.name},
        "booths": booths,
        "alarms": sum(1 for b in booths if b["alarm"]),
        "generated_at": now.isoformat(),
    }


@router.get("/pi/monitor", response_class=HTMLResponse)
def monitor_page(
    request: Request, user: CurrentPI, db: DbSession, templates: Templates, study: int | None = None
) -> Response:
    found = study_or_404(db, study)
    context = page_context(request, user, found, "monitor",
                           monitor=monitor_state(db, request.app.state, found))  # fmt: skip
    return templates.TemplateResponse(request, "pi/monitor.html", context)


@router.get("/api/pi/monitor")
def monitor_api(
    request: Request, _pi: CurrentPI, db: DbSession, study: int | None = None
) -> dict[str, Any]:
    return monitor_state(db, request.app.state, study_or_404(db, study))
