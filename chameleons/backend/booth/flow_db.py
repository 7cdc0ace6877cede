"""The booth flow's database work, off the event loop: reads and write transactions in the
thread pool (a write's events reach the live hub once committed), and the events it logs."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any, TypeVar

from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.booth import repository
from chameleons.backend.booth.slots import Slot
from chameleons.backend.events import repository as events
from chameleons.backend.events.unit_of_work import write_session

T = TypeVar("T")
SOURCE = "server"


class FlowDb:
    def __init__(self, state: Any) -> None:
        self.state = state

    def read(self, work: Callable[..., T], *args: Any) -> Awaitable[T]:
        def run() -> T:
            db: Session = self.state.sessionmaker()
            try:
                return work(db, *args)
            finally:
                db.close()

        return run_in_threadpool(run)

    def write(self, work: Callable[..., T], *args: Any) -> Awaitable[T]:
        def run() -> T:
            with write_session(self.state.sessionmaker, self.state.live_hub) as db:
                return work(db, *args)

        return run_in_threadpool(run)

    def log(self, slot: Slot, kind: str, payload: dict[str, Any]) -> Awaitable[Any]:
        """An event of the interaction at ``slot``, from the server."""
        return self.write(
            lambda db: events.record(
                db, kind, source=SOURCE, study_id=slot.study_id, session_id=slot.session_id,
                interaction_id=slot.interaction_id, payload={"position": slot.position, **payload},
            )
        )  # fmt: skip

    async def log_outage(
        self, booth: str, kind: str, payload: dict[str, Any], worker_time: float | None
    ) -> None:
        """An event of the session running on ``booth`` (none running: nothing to flag)."""

        def work(db: Session) -> None:
            session = repository.active_session(db, booth)
            if session is None:
                return  # nobody is in the booth: nothing to flag
            interaction = repository.running_interaction(db, session)
            events.record(
                db, kind, source="bridge", study_id=session.study_id, session_id=session.id,
                interaction_id=interaction.id if interaction else None,
                payload={"position": interaction.position if interaction else None, **payload},
                worker_time=worker_time,
            )  # fmt: skip

        await self.write(work)
