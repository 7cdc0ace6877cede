"""Realistic study data inserted as model rows (for tests that need sessions already run).

``populate`` builds a study from the default study config, a plan for N participants (the
experiment core's planner) and, per participant, a completed session: three interactions
as planned, three decided suggestions each, every questionnaire item answered on its scale
(reverse-keyed items stored raw), the final questionnaire, a timeline of events and,
when ``recordings_dir`` is given, real Parquet recordings. Values come from a seeded RNG
with a per-participant level and a small per-condition effect, so statistics are not
degenerate. No names are stored: participant codes are ``P001``...
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import (
    BoothCheck,
    Event,
    Interaction,
    Participant,
    PlanRow,
    QuestionnaireResponse,
    Recording,
    Session,
    Study,
    Suggestion,
)
from chameleons.experiment.design import plan
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.study import load_default_study

START = datetime(2026, 3, 2, 9, 0, tzinfo=UTC)


@dataclass
class PopulatedStudy:
    study_id: int
    spec: StudySpec
    participant_ids: list[int] = field(default_factory=list)
    codes: list[str] = field(default_factory=list)
    session_ids: list[int] = field(default_factory=list)
    recording_paths: list[Path] = field(default_factory=list)


def create_study(db: DbSession, spec: StudySpec | None = None, name: str | None = None) -> Study:
    spec = spec or load_default_study()
    study = Study(name=name or spec.name, config=spec.config, config_hash=spec.content_hash)
    db.add(study)
    db.flush()
    return study


def create_plan(
    db: DbSession, study: Study, spec: StudySpec, count: int, seed: int = 0
) -> list[PlanRow]:
    """Plan rows from the experiment core's planner, as the session flow stores them."""
    planned = plan(spec, count, seed)
    rows = [
        PlanRow(
            study_id=study.id,
            row_number=row.participant,
            interactions=row.to_dict()["interactions"],
        )
        for row in planned.rows
    ]
    db.add_all(rows)
    db.flush()
    return rows


def booth_check(session: Session, at: datetime) -> BoothCheck:
    """The booth check a technician ran before the participant sat down (all steps pass)."""
    steps = [{"id": step, "status": "pass", "value": "", "figures": {}}
             for step in ("face", "head", "robot", "copy", "speech", "disk")]  # fmt: skip
    return BoothCheck(
        booth=session.booth, study_id=session.study_id, session_id=session.id, checked_at=at,
        passed=True, steps=steps, face_fps=59.9, capture_to_send_ms=8.5, head_yaw_deg=38.0,
        head_pitch_deg=14.0, copy_delay_s=4.0, measured_delay_s=4.02, speech_start_ms=180.0,
        speech_ok=True, disk_free_bytes=50 * 1000**3,
    )  # fmt: skip


def populate(
    db: DbSession,
    participants: int = 12,
    *,
    seed: int = 1,
    rehearsals: int = 0,
    free_rows: int = 0,
    recordings_dir: Path | None = None,
    spec: StudySpec | None = None,
    effects: dict[str, float] | None = None,
    name: str | None = None,
) -> PopulatedStudy:
    """A study with ``participants`` completed sessions (codes P001...), then ``rehearsals``
    rehearsal ones (R001..., on the next rows without holding them), and ``free_rows``
    plan rows nobody used."""
    spec = spec or load_default_study()
    study = create_study(db, spec, name)
    rows = create_plan(db, study, spec, participants + rehearsals + free_rows)
    rng = random.Random(seed)
    result = PopulatedStudy(study_id=study.id, spec=spec)
    for number in range(1, participants + rehearsals + 1):
        rehearsal = number > participants
        participant = add_completed_participant(
            db,
            study,
            spec,
            rows[number - 1],
            code=f"R{number - participants:03d}" if rehearsal else f"P{number:03d}",
            rng=rng,
            rehearsal=rehearsal,
            recordings_dir=recordings_dir,
            result=result,
            effects=effects,
        )
        result.participant_ids.append(participant.id)
        result.codes.append(participant.code)
    db.flush()
    return result


def add_completed_participant(
    db: DbSession,
    study: Study,
    spec: StudySpec,
    row: PlanRow,
    *,
    code: str,
    rng: random.Random,
    rehearsal: bool = False,
    recordings_dir: Path | None = None,
    result: PopulatedStudy | None = None,
    effects: dict[str, float] | None = None,
) -> Participant:
    start = START + timedelta(hours=row.row_number)
    participant = Participant(  # a rehearsal borrows its row without holding it
        study_id=study.id,
        code=code,
        plan_row_id=None if rehearsal else row.id,
        status="complete",
        is_rehearsal=rehearsal,
        consent_at=start,
    )
    db.add(participant)
    db.flush()
    session = Session(
        study_id=study.id,
        participant_id=participant.id,
        plan_row_id=row.id,
        booth=f"booth-{1 + row.row_number % 2}",
        state="complete",
        current_position=len(row.interactions),
        phone_token=f"token-{study.id}-{code}-{rng.getrandbits(48):x}",
        short_code=f"{study.id % 100:02d}{code}{rng.randint(10, 99)}"[:16],
        is_rehearsal=rehearsal,
        consent_at=start,
        started_at=start,
        completed_at=start + timedelta(minutes=45),
    )
    db.add(session)
    db.flush()
    db.add(booth_check(session, start - timedelta(minutes=2)))
    if result is not None:
        result.session_ids.append(session.id)
    _event(db, study, session, None, "session_started", start, {"booth": session.booth})
    level = rng.gauss(0.0, 0.8)
    for planned in row.interactions:
        _add_interaction(
            db, study, spec, session, planned, start, level, rng, recordings_dir, result, effects
        )
    final_time = start + timedelta(minutes=42)
    answers = [
        *((q, -1, start) for q in spec.questionnaires_for("before")),
        *((q, 0, final_time) for q in spec.questionnaires_for("final")),
    ]
    for questionnaire, position, moment in answers:
        for item in questionnaire.items:
            value, text = _closed_answer(item, len(row.interactions), rng)
            db.add(
                QuestionnaireResponse(
                    session_id=session.id,
                    interaction_id=None,
                    position=position,
                    questionnaire=questionnaire.id,
                    version=questionnaire.version,
                    item=item.id,
                    value=value,
                    text=text
                    if item.type != "text"
                    else f'Answer to {item.id} by {code}, with a comma, and a "quote".',
                    created_at=moment,
                )
            )
    _event(db, study, session, None, "session_completed", start + timedelta(minutes=45), {})
    db.flush()
    return participant


# Small, like the paper found (nothing significant); tests wanting an effect pass their own.
CONDITION_EFFECT = {"still": 0.0, "natural": -0.1, "copy": 0.1}


def _add_interaction(
    db: DbSession,
    study: Study,
    spec: StudySpec,
    session: Session,
    planned: dict[str, Any],
    start: datetime,
    level: float,
    rng: random.Random,
    recordings_dir: Path | None,
    result: PopulatedStudy | None,
    effects: dict[str, float] | None = None,
) -> None:
    position = int(planned["position"])
    began = start + timedelta(minutes=2 + 13 * (position - 1))
    presented = list(planned["item_order"])
    initial = presented[:]
    rng.shuffle(initial)
    interaction = Interaction(
        session_id=session.id,
        position=position,
        state="done",
        planned_condition=planned["condition"],
        condition=planned["condition"],
        actor=planned["actor"],
        robot_name=planned["robot_name"],
        face=planned["face"],
        task=planned["task"],
        item_set=planned["item_set"],
        presented_order=presented,
        initial_ranking=initial,
        started_at=began,
        ended_at=began + timedelta(minutes=12),
    )
    db.add(interaction)
    db.flush()
    _event(db, study, session, interaction, "interaction_started", began, {"position": position})
    for prompt in range(4):
        latency = rng.uniform(40, 180)
        _event(
            db,
            study,
            session,
            interaction,
            "prompt_played",
            began + timedelta(seconds=20 * (prompt + 1)),
            {"prompt": f"p{prompt:03d}", "ack_latency_ms": round(latency, 1)},
            worker_time=1000.0 + prompt,
        )
    effect = (effects or CONDITION_EFFECT).get(interaction.condition, 0.0)
    final = _add_suggestions(db, spec, interaction, initial, began, effect, rng)
    interaction.final_ranking = final
    interaction.current_ranking = final
    _add_answers(db, spec, session, interaction, began, level + effect, rng)
    if recordings_dir is not None:
        for stream in ("participant", "agent"):
            path = _write_recording(recordings_dir, session, interaction, stream, rng)
            db.add(
                Recording(
                    interaction_id=interaction.id,
                    stream=stream,
                    path=str(path),
                    frames=60,
                    size_bytes=path.stat().st_size,
                )
            )
            if result is not None:
                result.recording_paths.append(path)
    _event(db, study, session, interaction, "interaction_ended", began + timedelta(minutes=12), {})


def _add_suggestions(
    db: DbSession,
    spec: StudySpec,
    interaction: Interaction,
    ranking: list[str],
    began: datetime,
    effect: float,
    rng: random.Random,
) -> list[str]:
    """Three upward moves; an accepted one is applied. Optimal when it moves the item
    closer to its place in the expert order."""
    ranking = ranking[:]
    expert = spec.expert_order(interaction.task, ranking)
    for index in range(1, spec.suggestions_per_interaction + 1):
        from_rank = rng.randint(2, len(ranking))
        to_rank = rng.randint(1, from_rank - 1)
        item = ranking[from_rank - 1]
        kind = "optimal" if expert.index(item) + 1 < from_rank else "random"
        accepted = rng.random() < 0.5 + effect / 3
        proposed = began + timedelta(minutes=5, seconds=40 * index)
        db.add(
            Suggestion(
                interaction_id=interaction.id,
                index=index,
                item=item,
                from_rank=from_rank,
                to_rank=to_rank,
                kind=kind,
                accepted=accepted,
                proposed_at=proposed,
                decided_at=proposed + timedelta(seconds=15),
            )
        )
        if accepted:
            ranking.insert(to_rank - 1, ranking.pop(from_rank - 1))
    return ranking


def _add_answers(
    db: DbSession,
    spec: StudySpec,
    session: Session,
    interaction: Interaction,
    began: datetime,
    shift: float,
    rng: random.Random,
) -> None:
    answered = began + timedelta(minutes=11)
    for questionnaire in spec.questionnaires_for("interaction"):
        for item in questionnaire.items:
            value: int | None = None
            text: str | None = None
            if item.numeric:
                favourable = round(4.6 + shift + rng.gauss(0, 1.0))
                favourable = max(1, min(questionnaire.points, favourable))
                value = questionnaire.points + 1 - favourable if item.reverse else favourable
            else:
                text = f"It was fine; robot {interaction.robot_name} talked a lot."
            db.add(
                QuestionnaireResponse(
                    session_id=session.id,
                    interaction_id=interaction.id,
                    position=interaction.position,
                    questionnaire=questionnaire.id,
                    version=questionnaire.version,
                    item=item.id,
                    value=value,
                    text=text,
                    created_at=answered,
                )
            )


def _write_recording(
    directory: Path, session: Session, interaction: Interaction, stream: str, rng: random.Random
) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"session-{session.id}" / f"interaction-{interaction.id}-{stream}.parquet"
    path.parent.mkdir(parents=True, exist_ok=True)
    frames = 60
    table = pa.table(
        {
            "capture_time": [i / 60 for i in range(frames)],
            "jawOpen": [rng.random() for _ in range(frames)],
            "head_yaw": [rng.uniform(-10, 10) for _ in range(frames)],
        }
    )
    pq.write_table(table, path)
    return path


def _event(
    db: DbSession,
    study: Study,
    session: Session,
    interaction: Interaction | None,
    kind: str,
    at: datetime,
    payload: dict[str, Any],
    worker_time: float | None = None,
) -> Event:
    event = Event(
        study_id=study.id,
        session_id=session.id,
        interaction_id=interaction.id if interaction else None,
        kind=kind,
        source="test",
        server_time=at,
        worker_time=worker_time,
        payload=payload,
    )
    db.add(event)
    return event


def add_event(
    db: DbSession,
    session_id: int,
    kind: str,
    payload: dict[str, Any],
    position: int | None = None,
    source: str = "test",
) -> Event:
    """A single extra event (flags tests: deviations, outages, slow prompts), attached to the
    session's interaction at ``position`` when given."""
    session = db.get(Session, session_id)
    assert session is not None
    interaction_id = None
    if position is not None:
        interaction_id = db.scalars(
            select(Interaction.id).where(
                Interaction.session_id == session_id, Interaction.position == position
            )
        ).one()
    event = Event(
        study_id=session.study_id,
        session_id=session_id,
        interaction_id=interaction_id,
        kind=kind,
        source=source,
        payload=payload,
    )
    db.add(event)
    db.flush()
    return event


def _closed_answer(item: Any, robots: int, rng: random.Random) -> tuple[int | None, str | None]:
    """A choice: one of its options (text); a robot item: one of the robots met (value)."""
    if item.type == "choice":
        return None, rng.choice(item.options).id
    if item.type == "robot":
        return rng.randint(1, robots), None
    return None, None
