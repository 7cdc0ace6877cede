"""The consent page's own video items (issue 33): shown only where the study records
video, unticked; what the participant ticked is kept on the session and in the timeline;
the microphone counts only with the video; a study without video keeps nothing."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Event
from chameleons.backend.models import Session as SessionRow
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, study_with_plan


def consented(engine: Engine, session_id: int) -> tuple[Any, Any, dict[str, Any]]:
    with engine.connect() as db:
        row = db.execute(select(SessionRow.video_consent, SessionRow.video_audio_consent)
                         .where(SessionRow.id == session_id)).one()  # fmt: skip
        payload = db.scalar(select(Event.payload).where(Event.session_id == session_id,
                                                        Event.kind == "consent.given"))  # fmt: skip
    assert payload is not None
    return row[0], row[1], payload


def test_the_consent_page_asks_for_video_and_sound(pi: StaffApi, video_study: int) -> None:
    wizard = WizardBot.create(pi, video_study)
    state = ParticipantBot(pi.http, wizard.token).state()
    assert state["view"] == "consent"
    assert state["consent"]["video"] == {
        "label": "I agree to be filmed during the conversations (the video stays with the lab)",
        "audio_label": "I agree to my voice being recorded with the video",
    }


@pytest.mark.parametrize(("video", "audio", "kept"), [
    (True, True, (True, True)), (True, False, (True, False)), (False, True, (False, False)),
    (False, False, (False, False)),
])  # fmt: skip
def test_the_ticks_are_kept(pi: StaffApi, video_study: int, engine: Engine, video: bool,
                            audio: bool, kept: tuple[bool, bool]) -> None:  # fmt: skip
    wizard = WizardBot.create(pi, video_study)
    ParticipantBot(pi.http, wizard.token).consent(True, video=video, audio=audio)
    filmed, voiced, payload = consented(engine, wizard.session_id)
    assert (filmed, voiced) == kept
    assert (payload["video"], payload["audio"]) == kept


def test_a_study_without_video_asks_and_keeps_nothing(pi: StaffApi, engine: Engine) -> None:
    wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
    phone = ParticipantBot(pi.http, wizard.token)
    assert phone.state()["consent"]["video"] is None
    phone.consent(True, video=True, audio=True)  # a forged tick changes nothing
    filmed, voiced, payload = consented(engine, wizard.session_id)
    assert (filmed, voiced) == (None, None)
    assert "video" not in payload


def test_the_participants_table_says_who_agreed_to_what(
    pi: StaffApi, video_study: int, engine: Engine, tmp_path: Path
) -> None:
    ticks = {}
    for video, audio in ((True, True), (False, False)):
        wizard = WizardBot.create(pi, video_study)
        ParticipantBot(pi.http, wizard.token).consent(True, video=video, audio=audio)
        ticks[wizard.session_id] = (str(video), str(audio))
    with build_sessionmaker(engine)() as db:
        export_to_directory(db, ExportRequest(study_id=video_study, formats=("csv", "sav")),
                            tmp_path)  # fmt: skip
    with (tmp_path / "participants.csv").open(encoding="utf-8") as file:
        rows = {int(r["session"]): (r["video_consent"], r["video_audio_consent"])
                for r in csv.DictReader(file)}  # fmt: skip
    assert {s: (v.lower(), a.lower()) for s, (v, a) in rows.items()} == {
        s: (v.lower(), a.lower()) for s, (v, a) in ticks.items()
    }
    assert (tmp_path / "participants.sav").is_file()
