"""Pair the booth's face capture with the next phone: the worker accepts capture from one
sender only (:mod:`chameleons.worker.ingest.pairing`). The booth flow resets the pairing when
a session starts on the booth; the wizard resets it from the console (a phone was replaced,
or the wrong one paired first). Logged as ``capture.pairing_reset`` with what the worker
said: the previously paired sender, or why the reset was not sent.

A new phone or participant also gets a new neutral head pose: the worker measures it afresh
(``recentre_head``; the copied head is re-centred on it, see
:mod:`chameleons.worker.behaviours.neutral`), and the event says so (``head``)."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.events import repository as events
from chameleons.backend.studies.errors import NotFoundError
from chameleons.backend.wizard import repository, worker_link
from chameleons.backend.wizard.playback import write
from chameleons.worker.control import RECENTRE_HEAD, RESET_PAIRING

PAIRING_RESET = "capture.pairing_reset"


def _view(db: Session, session_id: int) -> repository.SessionView:
    try:
        return repository.load_session(db, session_id)
    except repository.SessionNotFoundError as exc:
        raise NotFoundError(str(exc)) from None


async def reset_pairing(
    state: Any, session_id: int, source: str = "wizard", *, log_unsent: bool = True
) -> dict[str, Any]:
    """Ask the booth's worker to pair afresh; logged unless it was not sent and
    ``log_unsent`` is off (a session start on a booth without a worker is no news)."""
    view = await run_in_threadpool(write, state, _view, session_id)
    booth, current = view.session.booth, view.current
    outcome = await worker_link.send_command(worker_link.bridge_of(state), booth,
                                             RESET_PAIRING, {})  # fmt: skip
    result: dict[str, Any] = {"booth": booth, "sent": outcome.sent, "reason": outcome.reason,
                              "detail": outcome.detail}  # fmt: skip
    if outcome.sent and outcome.result is not None:
        result["previous_sender"] = outcome.result.get("previous")
        result["mode"] = outcome.result.get("mode")
        head = await worker_link.send_command(worker_link.bridge_of(state), booth,
                                              RECENTRE_HEAD, {})  # fmt: skip
        result["head"] = head.result if head.sent else {"sent": False, "detail": head.detail}

    def log(db: Session) -> Any:
        return events.record(db, PAIRING_RESET, source=source, study_id=view.session.study_id,
                             session_id=session_id,
                             interaction_id=current.id if current else None,
                             payload=result)  # fmt: skip

    if not outcome.sent and not log_unsent:
        return {"event_id": None, **result}
    event = await run_in_threadpool(write, state, log)
    return {"event_id": event.id, **result}
