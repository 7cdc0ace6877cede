"""Withdraw a participant: delete every row and file of theirs and what was derived from
them (see :mod:`.derived`), free their plan row, and report each thing removed.

Order matters for "no trace" even after a crash: rows are deleted and flushed, then the
files; the request commits afterwards. If deleting a file fails the transaction rolls
back and the withdrawal can be repeated; if the commit fails after the files are gone,
a repeat finds the rows and deletes them (missing files are fine). The audit event says
only that a withdrawal happened and which plan row was freed: no code, no content.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from sqlalchemy import delete, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.events.repository import announce_gone
from chameleons.backend.instruments.retention import forget_instruments
from chameleons.backend.models import (
    BoothCheck,
    Event,
    Interaction,
    Participant,
    PlanRow,
    QuestionnaireResponse,
    Recording,
    Session,
    Suggestion,
)
from chameleons.backend.synchrony.repository import forget_derived as forget_synchrony
from chameleons.backend.video.service import forget_videos
from chameleons.backend.withdrawal.derived import (
    Withdrawn,
    YokedReplay,
    forget_replays,
    redact_events,
    yoked_replays,
)
from chameleons.backend.withdrawal.files import delete_files, files_of, recording_file

WITHDRAWN_EVENT = "participant.withdrawn"


class WithdrawalError(ValueError):
    """The withdrawal was refused (unknown participant, confirmation does not match)."""


class ParticipantNotFoundError(WithdrawalError):
    pass


@dataclass(frozen=True)
class WithdrawalResult:
    """``removed``: one sentence per kind of thing deleted; ``kept``: what could not be
    removed from here, each with why (see :mod:`.scrub` for the database file)."""

    plan_row_number: int | None
    sessions: int
    files_deleted: int
    removed: tuple[str, ...] = ()
    kept: tuple[str, ...] = field(default_factory=tuple)


def find_participant(db: DbSession, study_id: int, code: str) -> Participant:
    participant = db.scalars(
        select(Participant).where(Participant.study_id == study_id, Participant.code == code)
    ).first()
    if participant is None:
        raise ParticipantNotFoundError(f"There is no participant {code!r} in this study.")
    return participant


def withdraw_participant(
    db: DbSession, study_id: int, code: str, confirmation: str, data_dir: Path
) -> WithdrawalResult:
    """Delete participant ``code`` of the study entirely; ``confirmation`` must repeat the code."""
    if confirmation.strip() != code:
        raise WithdrawalError(
            f"To withdraw {code}, type the participant code {code} exactly; nothing was deleted."
        )
    participant = find_participant(db, study_id, code)
    session_ids = list(
        db.scalars(select(Session.id).where(Session.participant_id == participant.id))
    )
    interaction_ids = list(
        db.scalars(select(Interaction.id).where(Interaction.session_id.in_(session_ids)))
    )
    recordings = list(
        db.execute(
            select(Recording.id, Recording.path).where(
                Recording.interaction_id.in_(interaction_ids)
            )
        ).tuples()
    )
    indexed = [recording_file(data_dir, stored) for _, stored in recordings]
    files = files_of(indexed, interaction_ids, data_dir)
    withdrawn = Withdrawn(
        code, participant.id, frozenset(interaction_ids), frozenset(r for r, _ in recordings)
    )
    replays = yoked_replays(db, study_id, withdrawn, data_dir)
    replay_files = [path for replay in replays.values() for path in replay.files]
    withdrawn = replace(withdrawn, file_names=frozenset(p.name for p in files + replay_files))
    row = _plan_row_of(db, participant, session_ids)
    # Synchrony measured with their face (their own, a yoked replay's, a baseline's pairs).
    resynchronise = forget_synchrony(
        db, study_id, [r for r, _ in recordings], [*interaction_ids, *replays]
    )
    instrument_files = forget_instruments(db, session_ids, data_dir)  # XDF streams, ELAN codes
    video_files = forget_videos(db, session_ids, data_dir)  # the booth camera's video
    _delete_rows(db, participant, session_ids, interaction_ids)
    forget_replays(db, replays)
    redacted = redact_events(db, study_id, withdrawn)
    if row is not None:
        row.withdrawals += 1
    deleted, refused = delete_files(files, data_dir)
    replayed, refused_replays = delete_files(replay_files, data_dir)
    analyses.clear()  # cached analyses were computed from their rows
    db.add(
        Event(
            study_id=study_id,
            kind=WITHDRAWN_EVENT,
            source="pi",
            payload={"plan_row": row.row_number if row else None},
        )
    )
    db.flush()
    announce_gone(db, session_ids)
    removed = _removed(code, len(session_ids), len(interaction_ids), deleted, replays, replayed)
    if redacted:
        removed.append(
            f"what {redacted} event{_s(redacted)} of other sessions said about them "
            "(each keeps its kind and time, not its content)"
        )
    if video_files:
        removed.append(f"{video_files} video file{_s(video_files)} of the participant")
    if instrument_files:
        removed.append(f"{instrument_files} file{_s(instrument_files)} of other instruments "
                       "(streams attached with import-xdf)")  # fmt: skip
    others = len(set(resynchronise) - set(interaction_ids))
    if others > 0:
        removed.append(
            f"the synchrony of {others} other interaction{_s(others)} measured with their "
            "face (a yoked replay, or a pseudo-pair of its baseline): run `chameleons "
            "synchrony` to compute it again without them"
        )
    removed.append("the analysis page's cached results")
    kept = _outside(refused + refused_replays)
    return WithdrawalResult(
        row.row_number if row else None, len(session_ids), deleted, tuple(removed), kept
    )


def _outside(paths: list[Path]) -> tuple[str, ...]:
    """The files the index named outside the recordings folder: not deleted from here."""
    if not paths:
        return ()
    named = ", ".join(str(p) for p in paths[:5]) + (", ..." if len(paths) > 5 else "")
    return (
        f"{len(paths)} file{_s(len(paths))} the index named outside the data folder's "
        f"recordings ({named}): not deleted, since no recording is ever written there. "
        "Check whether they are this participant's and delete them by hand if so.",
    )


def _s(count: int) -> str:
    return "" if count == 1 else "s"


def _removed(
    code: str, sessions: int, interactions: int, files: int,
    replays: dict[int, YokedReplay], replay_files: int,
) -> list[str]:  # fmt: skip
    removed = [
        f"{code}'s {sessions} session{_s(sessions)} with {interactions} "
        f"interaction{_s(interactions)}: rankings, suggestions, answers and timeline",
        f"{files} face recording file{_s(files)} of {code}",
    ]
    for replay in sorted(replays.values(), key=lambda r: (r.code, r.position)):
        removed.append(
            f"the robot's recording in {replay.code}'s interaction {replay.position}, which "
            f"replayed {code}'s face (yoked natural; {len(replay.files)} file"
            f"{_s(len(replay.files))}; {replay.code}'s own data stays)"
        )
    if replays and replay_files == 0:
        removed.append("(the robot's replay recordings had no files left on this server)")
    return removed


def _plan_row_of(db: DbSession, participant: Participant, session_ids: list[int]) -> PlanRow | None:
    row_id = participant.plan_row_id
    if row_id is None and session_ids and not participant.is_rehearsal:
        row_id = db.scalar(select(Session.plan_row_id).where(Session.id == session_ids[0]))
    return db.get(PlanRow, row_id) if row_id is not None else None


def _delete_rows(
    db: DbSession, participant: Participant, session_ids: list[int], interaction_ids: list[int]
) -> None:
    """Bottom-up, explicitly: correct even where the database does not cascade."""
    mentions = _study_events_naming(db, participant)
    db.execute(delete(Event).where(Event.id.in_(mentions)))
    db.execute(delete(Event).where(Event.session_id.in_(session_ids)))
    db.execute(delete(Event).where(Event.interaction_id.in_(interaction_ids)))
    db.execute(delete(Recording).where(Recording.interaction_id.in_(interaction_ids)))
    db.execute(delete(BoothCheck).where(BoothCheck.session_id.in_(session_ids)))
    db.execute(delete(Suggestion).where(Suggestion.interaction_id.in_(interaction_ids)))
    db.execute(
        delete(QuestionnaireResponse).where(QuestionnaireResponse.session_id.in_(session_ids))
    )
    db.execute(delete(Interaction).where(Interaction.id.in_(interaction_ids)))
    db.execute(delete(Session).where(Session.id.in_(session_ids)))
    db.execute(delete(Participant).where(Participant.id == participant.id))
    db.expunge(participant)
    db.flush()


def _study_events_naming(db: DbSession, participant: Participant) -> list[int]:
    """Study-level events (no session) that mention the participant, e.g. its registration.
    Payloads are JSON, queried differently per database, so they are matched here."""
    query = select(Event.id, Event.payload).where(
        Event.study_id == participant.study_id, Event.session_id.is_(None)
    )
    return [
        event_id
        for event_id, payload in db.execute(query)
        if _mentions(payload, participant.code, participant.id)
    ]


def _mentions(value: Any, code: str, participant_id: int) -> bool:
    if isinstance(value, dict):
        if value.get("participant_id") == participant_id:
            return True
        return any(_mentions(item, code, participant_id) for item in value.values())
    if isinstance(value, list):
        return any(_mentions(item, code, participant_id) for item in value)
    return isinstance(value, str) and re.search(rf"\b{re.escape(code)}\b", value) is not None
