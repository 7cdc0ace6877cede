"""ELAN: one ``.eaf`` per session for video coders (``chameleons export --format eaf``), and
the coders' annotations read back (``chameleons import-eaf``). Written and read with
pympi-ling (EAF 2.8, which ELAN opens and saves).

Times are milliseconds from the session's origin: its first timeline event or its start,
whichever came first, kept in the file's header (``chameleons_origin``, with
``chameleons_session_id``) so an imported file maps back onto the same session.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy import delete, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import CodedAnnotation, Event, Interaction, Session, Suggestion

TIERS = ("prompts", "robot speech", "condition", "suggestions and decisions", "rankings",
         "wizard notes", "typed speech")  # fmt: skip
PROMPT_MS = 1000  # a prompt's mark when its speech end is unknown
INSTANT_MS = 500  # a submission's or a note's mark
SESSION_PROPERTY = "chameleons_session_id"
ORIGIN_PROPERTY = "chameleons_origin"
CODER_PATTERN = re.compile(r"^[A-Za-z0-9_.@-]{1,64}$")


class EafError(ValueError):
    """Why a file could not be read back, in one sentence."""


@dataclass(frozen=True, slots=True)
class LinkedMedia:
    """A video of the session to link in the ``.eaf``: the file, its path relative to the
    ``.eaf`` (ELAN looks there first when the files move together), and when its first
    frame was on the server's clock."""

    path: Path
    relative: str | None
    started_at: datetime
    mime_type: str = "video/webm"


@dataclass(frozen=True, slots=True)
class Mark:
    tier: str
    start: datetime
    end: datetime | None
    value: str


def _aware(moment: datetime) -> datetime:
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)


def session_marks(db: DbSession, session_id: int) -> list[Mark]:
    """What the session's timeline says, tier by tier."""
    events = list(db.scalars(select(Event).where(Event.session_id == session_id)
                             .order_by(Event.server_time, Event.id)))  # fmt: skip
    marks: list[Mark] = []
    speaking: dict[str, datetime] = {}
    for event in events:
        at, payload = _aware(event.server_time), event.payload or {}
        prompt = str(payload.get("prompt_id") or "")
        if event.kind == "prompt.played":
            marks.append(Mark("prompts", at, None, prompt or "prompt"))
        elif event.kind == "prompt.speech_start":
            speaking[str(payload.get("play_id") or prompt)] = at
        elif event.kind == "prompt.speech_end":
            began = speaking.pop(str(payload.get("play_id") or prompt), None)
            if began is not None:
                marks.append(Mark("robot speech", began, at, prompt or "speech"))
        elif event.kind == "ranking.submitted":
            ranking = payload.get("ranking") or []
            marks.append(Mark("rankings", at, None, " > ".join(str(r) for r in ranking)))
        elif event.kind == "wizard.note":
            marks.append(Mark("wizard notes", at, None, str(payload.get("text") or "")))
        elif event.kind == "wizard.typed_speech":
            marks.append(Mark("typed speech", at, None, str(payload.get("text") or "")))
    interactions = list(db.scalars(select(Interaction).where(Interaction.session_id == session_id)
                                   .order_by(Interaction.position)))  # fmt: skip
    for interaction in interactions:
        if interaction.started_at is not None:
            end = _aware(interaction.ended_at) if interaction.ended_at else None
            marks.append(Mark("condition", _aware(interaction.started_at), end,
                              f"{interaction.position}: {interaction.condition}"))  # fmt: skip
    ids = [i.id for i in interactions]
    for s in db.scalars(select(Suggestion).where(Suggestion.interaction_id.in_(ids))
                        .order_by(Suggestion.proposed_at)):  # fmt: skip
        decided = {True: "accepted", False: "declined", None: "undecided"}[s.accepted]
        marks.append(Mark("suggestions and decisions", _aware(s.proposed_at),
                          _aware(s.decided_at) if s.decided_at else None,
                          f"{s.index}. {s.item} {s.from_rank}->{s.to_rank} ({s.kind}): "
                          f"{decided}"))  # fmt: skip
    return marks


def origin_of(session: Session, marks: Iterable[Mark]) -> datetime:
    moments = [m.start for m in marks]
    if session.started_at is not None:
        moments.append(_aware(session.started_at))
    return min(moments) if moments else _aware(session.created_at)


def _spans(marks: list[Mark], origin: datetime) -> list[tuple[int, int, str]]:
    """Milliseconds from the origin; each mark ends by the next one on its tier (ELAN keeps
    a tier's annotations apart), and lasts at least 1 ms."""
    ordered = sorted(marks, key=lambda m: m.start)
    spans = []
    for i, mark in enumerate(ordered):
        start = round((mark.start - origin).total_seconds() * 1000)
        default = PROMPT_MS if mark.tier == "prompts" else INSTANT_MS
        end = (round((mark.end - origin).total_seconds() * 1000) if mark.end is not None
               else start + default)  # fmt: skip
        if i + 1 < len(ordered):
            end = min(end, round((ordered[i + 1].start - origin).total_seconds() * 1000))
        spans.append((start, max(end, start + 1), mark.value))
    return spans


def write_eaf(
    db: DbSession, session_id: int, path: Path, *, media: Iterable[LinkedMedia] = ()
) -> Path:
    """The session's ``.eaf``: the tiers of :data:`TIERS` (empty ones too, for the coders'
    template), linked to the session's videos (``media``) when there are any."""
    from pympi.Elan import Eaf

    session = db.get(Session, session_id)
    if session is None:
        raise EafError(f"There is no session {session_id}.")
    marks = session_marks(db, session_id)
    origin = origin_of(session, marks)
    eaf = Eaf(author="Mechanical Chameleons")
    eaf.add_property(SESSION_PROPERTY, str(session_id))
    eaf.add_property(ORIGIN_PROPERTY, origin.isoformat())
    for tier in TIERS:
        eaf.add_tier(tier)
        for start, end, value in _spans([m for m in marks if m.tier == tier], origin):
            eaf.add_annotation(tier, start, end, value)
    eaf.remove_tier("default")
    for index, video in enumerate(media):
        _link(eaf, video, origin, index)
    path.parent.mkdir(parents=True, exist_ok=True)
    eaf.to_file(str(path))
    return path


def _link(eaf: Any, video: LinkedMedia, origin: datetime, index: int) -> None:
    """ELAN's ``MEDIA_DESCRIPTOR``: ``MEDIA_URL`` (a file URL), ``RELATIVE_MEDIA_URL`` and
    ``TIME_ORIGIN``, the point in the video that is the annotations' time 0, when the video
    began before the origin. One that began later cannot be placed so (ELAN's offsets are
    into the media): ``chameleons_video<n>_start_ms`` says where it begins on the tiers'
    time either way."""
    start_ms = round((_aware(video.started_at) - origin).total_seconds() * 1000)
    eaf.add_linked_file(video.path.resolve().as_uri(), relpath=video.relative,
                        mimetype=video.mime_type,
                        time_origin=str(-start_ms) if start_ms <= 0 else None)  # fmt: skip
    eaf.add_property(f"chameleons_video{index + 1}_start_ms", str(start_ms))


@dataclass(frozen=True, slots=True)
class EafImport:
    session_id: int
    coder: str
    tiers: dict[str, int]  # tier -> annotations read


def _property(eaf: Any, name: str) -> str | None:
    return next((str(v) for k, v in eaf.properties if k == name), None)


def read_eaf(db: DbSession, path: Path, *, session_id: int | None = None,
             coder: str | None = None, all_tiers: bool = False) -> EafImport:  # fmt: skip
    """Keep a coder's annotations of a session (replacing what that coder's earlier import
    of the session kept). The tiers this system wrote are left out unless ``all_tiers``."""
    from pympi.Elan import Eaf

    if not path.is_file():
        raise EafError(f"There is no file {path}.")
    try:
        eaf = Eaf(str(path), suppress_version_warning=True)
    except Exception as exc:  # pympi raises what the XML parser or its own checks raise
        raise EafError(f"{path.name} is not a readable ELAN file ({exc}).") from exc
    stated = _property(eaf, SESSION_PROPERTY)
    if session_id is None:
        if stated is None or not stated.isdigit():
            raise EafError(f"{path.name} does not say its session: give --session.")
        session_id = int(stated)
    if db.get(Session, session_id) is None:
        raise EafError(f"There is no session {session_id}.")
    if coder is None:
        annotators = {str(t[2].get("ANNOTATOR")) for t in eaf.tiers.values()
                      if t[2].get("ANNOTATOR")}  # fmt: skip
        if len(annotators) != 1:
            raise EafError(f"{path.name} names no single annotator on its tiers: give --coder.")
        coder = annotators.pop()
    if not CODER_PATTERN.match(coder):
        raise EafError(f"{coder!r} is not a coder name (letters, digits, . _ @ -; 64 at most).")
    db.execute(delete(CodedAnnotation).where(CodedAnnotation.session_id == session_id,
                                             CodedAnnotation.coder == coder))  # fmt: skip
    counts: dict[str, int] = {}
    for tier in eaf.get_tier_names():
        if tier in TIERS and not all_tiers:
            continue
        data = eaf.get_annotation_data_for_tier(tier)
        counts[str(tier)] = len(data)
        for annotation in data:
            start, end, value = annotation[0], annotation[1], annotation[2]
            db.add(CodedAnnotation(session_id=session_id, coder=coder, tier=str(tier)[:128],
                                   start_ms=int(start), end_ms=int(end), value=str(value),
                                   source_file=path.name[:512]))  # fmt: skip
    db.flush()
    return EafImport(session_id, coder, counts)
