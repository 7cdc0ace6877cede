"""``chameleons export``: the videos only with ``--video``; the ``.eaf`` files link the
session's video (ELAN's MEDIA_DESCRIPTOR: the file, its relative path, the time origin)."""

from __future__ import annotations

import csv
import secrets
from datetime import timedelta
from pathlib import Path

import pytest
from click.testing import CliRunner
from pympi.Elan import Eaf
from sqlalchemy import select

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.instruments.eaf import origin_of, session_marks
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import Participant, ParticipantVideo, Session
from chameleons.backend.video.storage import EBML_MAGIC, relative_path
from chameleons.cli.main import cli
from tests.support.factories import populate

BEFORE_MS, AFTER_MS = 1500, 2500  # the videos' starts: before / after their session's origin


@pytest.fixture
def filmed(tmp_path: Path) -> tuple[dict[str, str], dict[int, tuple[str, int, bytes]]]:
    """Two sessions with a video each: the first began 1.5 s before its session's origin,
    the second 2.5 s after. Returns the CLI's environment and session -> (code, video, bytes)."""
    data = tmp_path / "data"
    data.mkdir()
    url = f"sqlite:///{data / 'chameleons.sqlite3'}"
    upgrade(url)
    engine = build_engine(url)
    videos: dict[int, tuple[str, int, bytes]] = {}
    with session_scope(build_sessionmaker(engine)) as db:
        study = populate(db, participants=2)
        for session_id, shift in zip(study.session_ids, (-BEFORE_MS, AFTER_MS), strict=True):
            session = db.get(Session, session_id)
            assert session is not None
            origin = origin_of(session, session_marks(db, session_id))
            content = EBML_MAGIC + f"video of session {session_id}".encode()
            video = ParticipantVideo(session_id=session_id, booth=session.booth,
                                     mime_type="video/webm;codecs=vp8", path="",
                                     started_at=origin + timedelta(milliseconds=shift),
                                     chunks=1, size_bytes=len(content))  # fmt: skip
            db.add(video)
            db.flush()
            video.path = relative_path(session_id, video.id)
            (data / video.path).parent.mkdir(parents=True)
            (data / video.path).write_bytes(content)
            code = db.scalars(select(Participant.code)
                              .where(Participant.id == session.participant_id)).one()  # fmt: skip
            videos[session_id] = (code, video.id, content)
    engine.dispose()
    env = {"CHAMELEONS_DATABASE_URL": url, "CHAMELEONS_DATA_DIR": str(data),
           "CHAMELEONS_SECRET_KEY": secrets.token_urlsafe(32)}  # fmt: skip
    return env, videos


def test_videos_are_exported_only_when_asked(
    filmed: tuple[dict[str, str], dict[int, tuple[str, int, bytes]]], tmp_path: Path
) -> None:
    env, videos = filmed
    plain = tmp_path / "plain"
    ran = CliRunner().invoke(cli, ["export", "--out", str(plain)], env=env)
    assert ran.exit_code == 0, ran.output
    assert "video(s) in video/" not in ran.output
    assert not (plain / "video").exists()
    assert not list(plain.rglob("*.webm"))
    asked = tmp_path / "asked"
    ran = CliRunner().invoke(cli, ["export", "--out", str(asked), "--video"], env=env)
    assert ran.exit_code == 0, ran.output
    assert "2 video(s) in video/" in ran.output
    with (asked / "video" / "videos.csv").open(encoding="utf-8") as file:
        index = list(csv.DictReader(file))
    assert sorted(int(row["session_id"]) for row in index) == sorted(videos)
    for row in index:
        code, video_id, content = videos[int(row["session_id"])]
        assert row["file"] == f"{code}-session{row['session_id']}-video{video_id}.webm"
        assert (asked / "video" / row["file"]).read_bytes() == content
    starts = sorted(float(row["start_s"]) for row in index)
    assert starts == [-BEFORE_MS / 1000, AFTER_MS / 1000]


def _descriptors(path: Path) -> list[dict[str, str]]:
    return list(Eaf(str(path)).media_descriptors)


def test_the_eaf_files_link_the_video(
    filmed: tuple[dict[str, str], dict[int, tuple[str, int, bytes]]], tmp_path: Path
) -> None:
    env, videos = filmed
    out = tmp_path / "out"
    ran = CliRunner().invoke(cli, ["export", "--out", str(out), "--format", "eaf", "--video"],
                             env=env)  # fmt: skip
    assert ran.exit_code == 0, ran.output
    (early, (code_a, video_a, _)), (late, (code_b, _video_b, _)) = sorted(videos.items())
    [linked] = _descriptors(out / "eaf" / f"{code_a}-session{early}.eaf")
    name = f"{code_a}-session{early}-video{video_a}.webm"
    assert linked["RELATIVE_MEDIA_URL"] == f"../video/{name}"
    assert linked["MEDIA_URL"] == (out / "video" / name).resolve().as_uri()
    assert linked["MIME_TYPE"] == "video/webm"
    assert linked["TIME_ORIGIN"] == str(BEFORE_MS)  # the video's point at the tiers' time 0
    eaf = Eaf(str(out / "eaf" / f"{code_a}-session{early}.eaf"))
    assert dict(eaf.properties)["chameleons_video1_start_ms"] == str(-BEFORE_MS)
    [later] = _descriptors(out / "eaf" / f"{code_b}-session{late}.eaf")
    assert "TIME_ORIGIN" not in later  # ELAN cannot start a video after time 0
    eaf = Eaf(str(out / "eaf" / f"{code_b}-session{late}.eaf"))
    assert dict(eaf.properties)["chameleons_video1_start_ms"] == str(AFTER_MS)
    # Without --video, the .eaf names the server's own file (nothing copied)
    bare = tmp_path / "bare"
    ran = CliRunner().invoke(cli, ["export", "--out", str(bare), "--format", "eaf"], env=env)
    assert ran.exit_code == 0, ran.output
    [stored] = _descriptors(bare / "eaf" / f"{code_a}-session{early}.eaf")
    data = Path(env["CHAMELEONS_DATA_DIR"])
    assert stored["MEDIA_URL"] == (data / relative_path(early, video_a)).resolve().as_uri()
    assert "RELATIVE_MEDIA_URL" not in stored
    assert not (bare / "video").exists()
