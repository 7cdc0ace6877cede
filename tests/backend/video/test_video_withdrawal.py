"""Withdrawing a participant deletes their video: the files and the rows (issue 33)."""

from __future__ import annotations

from pathlib import Path

from fastapi.testclient import TestClient
from sqlalchemy import Engine, func, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Participant, ParticipantVideo, VideoChunk
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.withdrawal.service import withdraw_participant
from chameleons.settings import Settings
from tests.backend.video.conftest import RunSession
from tests.backend.video.test_video_api import FIRST, chunk, start


def test_withdrawal_deletes_the_video_files_and_rows(
    client: TestClient, booth_key: str, running: RunSession, engine: Engine, settings: Settings
) -> None:
    kept = running(video=True)  # another participant's video stays
    kept_id = start(client, booth_key, kept.session_id).json()["video_id"]
    assert chunk(client, booth_key, kept_id, 0, FIRST).status_code == 200
    kept.end("technical_failure")  # the booth is free for the next participant
    gone = running(video=True)
    gone_id = start(client, booth_key, gone.session_id).json()["video_id"]
    for seq, data in enumerate((FIRST, b"more")):
        assert chunk(client, booth_key, gone_id, seq, data).status_code == 200
    form = client.get(f"/pi/participants/{gone_code(engine, gone.session_id)}/withdraw").text
    assert '<span id="withdraw-videos">1 video</span> of them' in form
    data_dir = Path(settings.data_dir)
    folder = data_dir / "video" / f"session-{gone.session_id}"
    assert (folder / f"video-{gone_id}.webm").is_file()
    with session_scope(build_sessionmaker(engine)) as db:
        session = db.get(SessionRow, gone.session_id)
        assert session is not None
        participant = db.get(Participant, session.participant_id)
        assert participant is not None
        result = withdraw_participant(db, session.study_id, participant.code, participant.code,
                                      data_dir)  # fmt: skip
    assert "1 video file of the participant" in result.removed
    assert not folder.exists()
    assert (data_dir / "video" / f"session-{kept.session_id}" / f"video-{kept_id}.webm").is_file()
    with engine.connect() as db:
        assert db.scalar(select(func.count()).select_from(ParticipantVideo)) == 1
        assert db.scalar(select(func.count()).select_from(VideoChunk)) == 1


def gone_code(engine: Engine, session_id: int) -> str:
    with engine.connect() as db:
        return str(db.scalar(select(Participant.code).join(
            SessionRow, SessionRow.participant_id == Participant.id).where(
            SessionRow.id == session_id)))  # fmt: skip
