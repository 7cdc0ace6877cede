"""What was derived from a withdrawn participant's data: found and removed with it.

- **Yoked replays.** In another participant's interaction, the ``natural`` condition may have
  replayed one of the withdrawn participant's face recordings (``behaviour.natural_source``
  with ``source: yoked``, ``from_interaction_id``). The robot's face then moved as the
  withdrawn participant's face did, so that interaction's *agent* recording is derived from
  them: its rows and files go. The other participant's own recording, answers and scores
  stay; the interaction keeps ``natural_source = yoked`` (the condition ran as designed)
  and its ``natural_recording`` says the source was withdrawn.
- **Events quoting them.** Any remaining event of the study whose payload names the
  participant's code, one of their interactions or recordings, or a deleted file, keeps its
  kind and time (a timeline still shows that something happened) and loses its payload.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy import delete, or_, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.events.repository import announce_rewritten
from chameleons.backend.models import Event, Interaction, Participant, Recording, Session
from chameleons.backend.withdrawal.files import JOURNAL_SUFFIX, RECORDINGS_DIR, recording_file

NATURAL_SOURCE = "behaviour.natural_source"
REDACTED: dict[str, Any] = {"redacted": "participant withdrawn"}
SOURCE_WITHDRAWN = "yoked: the source participant withdrew; the robot's recording was deleted"
AGENT = "agent"


@dataclass(frozen=True)
class Withdrawn:
    """What identifies the withdrawn participant's data in what others hold."""

    code: str
    participant_id: int
    interaction_ids: frozenset[int]
    recording_ids: frozenset[int]
    file_names: frozenset[str] = field(default_factory=frozenset)


@dataclass(frozen=True)
class YokedReplay:
    """Another participant's interaction that replayed the withdrawn participant's face."""

    code: str
    position: int
    files: list[Path]


def yoked_replays(
    db: DbSession, study_id: int, withdrawn: Withdrawn, data_dir: Path
) -> dict[int, YokedReplay]:
    """Interactions of other participants whose ``natural`` replayed the withdrawn one's
    recordings, with the files of their agent (robot) stream."""
    query = (
        select(Event.interaction_id, Event.payload)
        .where(Event.study_id == study_id, Event.kind == NATURAL_SOURCE)
        .where(Event.interaction_id.is_not(None))
    )
    found: dict[int, YokedReplay] = {}
    for interaction_id, payload in db.execute(query):
        if interaction_id is None or interaction_id in withdrawn.interaction_ids:
            continue
        if not _replays(payload, withdrawn) or interaction_id in found:
            continue
        row = db.execute(
            select(Participant.code, Interaction.position)
            .join(Session, Session.id == Interaction.session_id)
            .join(Participant, Participant.id == Session.participant_id)
            .where(Interaction.id == interaction_id)
        ).first()
        if row is not None:
            found[interaction_id] = YokedReplay(
                row[0], row[1], _agent_files(db, interaction_id, data_dir)
            )
    return found


def _replays(payload: Any, withdrawn: Withdrawn) -> bool:
    if not isinstance(payload, dict) or payload.get("source") != "yoked":
        return False
    return (
        payload.get("from_interaction_id") in withdrawn.interaction_ids
        or payload.get("recording_id") in withdrawn.recording_ids
    )


def _agent_files(db: DbSession, interaction_id: int, data_dir: Path) -> list[Path]:
    """The indexed agent files, their journals and unindexed worker files of that stream."""
    indexed = [
        recording_file(data_dir, stored)
        for stored in db.scalars(
            select(Recording.path).where(
                Recording.interaction_id == interaction_id, Recording.stream == AGENT
            )
        )
    ]
    pattern = re.compile(
        rf"^interaction-{interaction_id}(?:-part\d+)?-{AGENT}\.parquet(?:{re.escape(JOURNAL_SUFFIX)})?$"
    )
    found = set(indexed) | {p.with_name(p.name + JOURNAL_SUFFIX) for p in indexed}
    roots = {p.parent for p in indexed} | {data_dir / RECORDINGS_DIR}
    for root in roots:
        if root.is_dir():
            found.update(
                p for p in root.rglob(f"interaction-{interaction_id}*") if pattern.match(p.name)
            )
    return sorted(found)


def forget_replays(db: DbSession, replays: dict[int, YokedReplay]) -> None:
    """Delete the replays' agent recording rows; say on each interaction that its source
    was withdrawn (its files are deleted with the withdrawn participant's own)."""
    if not replays:
        return
    ids = list(replays)
    db.execute(
        delete(Recording).where(Recording.interaction_id.in_(ids), Recording.stream == AGENT)
    )
    for interaction in db.scalars(select(Interaction).where(Interaction.id.in_(ids))):
        interaction.natural_recording = SOURCE_WITHDRAWN
    db.flush()


def redact_events(db: DbSession, study_id: int, withdrawn: Withdrawn) -> int:
    """Empty the payload of every remaining event of the study that quotes the withdrawn
    participant (code, interactions, recordings, deleted files). Returns how many."""
    query = select(Event).where(or_(Event.study_id == study_id, Event.study_id.is_(None)))
    rewritten: list[Event] = []
    for event in db.scalars(query):
        if event.payload != REDACTED and _quotes(event.payload, withdrawn):
            event.payload = dict(REDACTED)
            rewritten.append(event)
    db.flush()
    announce_rewritten(db, {e.session_id for e in rewritten if e.session_id is not None})
    return len(rewritten)


ID_KEYS = {
    "participant_id": "participant_id",
    "from_interaction_id": "interaction_ids",
    "interaction_id": "interaction_ids",
    "recording_id": "recording_ids",
}


def _quotes(value: Any, withdrawn: Withdrawn) -> bool:
    if isinstance(value, dict):
        for key, item in value.items():
            if key in ID_KEYS and _is_theirs(key, item, withdrawn):
                return True
            if _quotes(item, withdrawn):
                return True
        return False
    if isinstance(value, list):
        return any(_quotes(item, withdrawn) for item in value)
    if not isinstance(value, str):
        return False
    if re.search(rf"\b{re.escape(withdrawn.code)}\b", value):
        return True
    return any(name in value for name in withdrawn.file_names)


def _is_theirs(key: str, value: Any, withdrawn: Withdrawn) -> bool:
    if not isinstance(value, int) or isinstance(value, bool):
        return False
    if key == "participant_id":
        return value == withdrawn.participant_id
    ids: frozenset[int] = getattr(withdrawn, ID_KEYS[key])
    return value in ids
