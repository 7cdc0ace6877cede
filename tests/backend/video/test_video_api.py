"""The recording page's API through the real app: who is filmed (study opt-in and the
participant's own consent items), chunks stored in order with every refusal counted and
said in a sentence, the key checked, the PI's file behind the PI's login."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.models import ParticipantVideo, VideoChunk
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.video.service import MAX_CHUNK_BYTES
from chameleons.backend.video.storage import EBML_MAGIC
from chameleons.settings import Settings
from tests.backend.video.conftest import BOOTH, RunSession
from tests.support.bots import StaffApi, WizardBot, study_with_plan

API = f"/api/video/{BOOTH}"
FIRST = EBML_MAGIC + b"\x42\x86\x81\x01" + b"first chunk"


def state(client: TestClient, key: str) -> dict[str, Any]:
    response = client.get(f"{API}/state", headers={"X-Booth-Key": key})
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


def start(client: TestClient, key: str, session_id: int, audio: bool = False) -> Any:
    now_ms = time.time() * 1000
    body = {"session_id": session_id, "mime_type": "video/webm;codecs=vp8", "audio": audio,
            "clock": {"start_ms": 1500.0, "offset_ms": now_ms - 1500.0, "rtt_ms": 3.0}}  # fmt: skip
    return client.post(f"{API}/videos", json=body, headers={"X-Booth-Key": key})


def chunk(client: TestClient, key: str, video_id: int, seq: int, data: bytes) -> Any:
    return client.post(f"{API}/videos/{video_id}/chunks/{seq}?media_ms={2000 * (seq + 1)}",
                       content=data, headers={"X-Booth-Key": key,
                                              "Content-Type": "video/webm"})  # fmt: skip


def test_only_a_consented_session_of_a_video_study_is_filmed(
    client: TestClient, booth_key: str, running: RunSession
) -> None:
    assert state(client, booth_key)["reason"] == "No session is running at this booth."
    declined = running(video=False)
    now = state(client, booth_key)
    assert (now["session_id"], now["record"]) == (declined.session_id, False)
    assert now["reason"] == "The participant did not agree to be filmed."
    refused = start(client, booth_key, declined.session_id)
    assert refused.status_code == 409
    assert "did not agree to be filmed" in refused.json()["detail"]


def test_the_microphone_needs_its_own_consent(
    client: TestClient, booth_key: str, running: RunSession
) -> None:
    wizard = running(video=True, audio=False)
    now = state(client, booth_key)
    assert (now["record"], now["audio"]) == (True, False)
    refused = start(client, booth_key, wizard.session_id, audio=True)
    assert refused.status_code == 403
    assert refused.json()["problem"] == "no_audio"
    assert start(client, booth_key, wizard.session_id, audio=False).status_code == 201


def test_a_study_without_video_films_nobody(
    client: TestClient, booth_key: str, pi: StaffApi
) -> None:
    wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
    wizard.start()
    now = state(client, booth_key)
    assert (now["session_id"], now["record"]) == (wizard.session_id, False)
    assert now["reason"] == "This session's study does not record video."


def test_chunks_are_stored_in_order_and_every_refusal_is_counted(
    client: TestClient, booth_key: str, running: RunSession, engine: Engine, settings: Settings
) -> None:
    wizard = running(video=True, audio=True)
    assert state(client, booth_key)["audio"] is True
    answer = start(client, booth_key, wizard.session_id, audio=True)
    assert answer.status_code == 201, answer.text
    video_id = answer.json()["video_id"]
    not_webm = chunk(client, booth_key, video_id, 0, b"not a webm file")
    assert (not_webm.status_code, not_webm.json()["problem"]) == (422, "not_webm")
    assert chunk(client, booth_key, video_id, 0, FIRST).status_code == 200
    early = chunk(client, booth_key, video_id, 2, b"third")
    assert early.status_code == 409
    said = f"Chunk 2 of video {video_id} came out of order: chunk 1 comes next."
    assert early.json()["detail"] == said
    again = chunk(client, booth_key, video_id, 0, FIRST)
    assert (again.status_code, again.json()["problem"]) == (409, "duplicate")
    empty = chunk(client, booth_key, video_id, 1, b"")
    assert (empty.status_code, empty.json()["problem"]) == (422, "empty")
    huge = chunk(client, booth_key, video_id, 1, b"x" * (MAX_CHUNK_BYTES + 1))
    assert (huge.status_code, huge.json()["problem"]) == (413, "too_large")
    stored = chunk(client, booth_key, video_id, 1, b"second chunk")
    assert stored.json() == {"video_id": video_id, "seq": 1, "size": 12, "chunks": 2,
                             "size_bytes": len(FIRST) + 12}  # fmt: skip
    assert chunk(client, booth_key, video_id, -1, b"x").status_code == 422
    stop = client.post(f"{API}/videos/{video_id}/stop", headers={"X-Booth-Key": booth_key})
    assert stop.json() == {"video_id": video_id, "chunks": 2, "refused": 5}
    late = chunk(client, booth_key, video_id, 2, b"late")
    assert (late.status_code, late.json()["problem"]) == (409, "stopped")
    with engine.connect() as db:
        video = db.execute(select(ParticipantVideo)).one()
        chunks = db.execute(select(VideoChunk.seq, VideoChunk.offset, VideoChunk.size,
                                   VideoChunk.media_ms).order_by(VideoChunk.seq)).all()  # fmt: skip
    assert (video.chunks, video.refused, video.audio) == (2, 6, True)
    assert [tuple(c) for c in chunks] == [(0, 0, len(FIRST), 2000.0), (1, len(FIRST), 12, 4000.0)]
    path = Path(settings.data_dir) / video.path
    assert path.read_bytes() == FIRST + b"second chunk"
    assert video.path == f"video/session-{wizard.session_id}/video-{video_id}.webm"


def test_a_crash_between_writing_and_indexing_loses_only_that_chunk(
    client: TestClient, booth_key: str, running: RunSession, engine: Engine, settings: Settings
) -> None:
    wizard = running(video=True)
    video_id = start(client, booth_key, wizard.session_id).json()["video_id"]
    assert chunk(client, booth_key, video_id, 0, FIRST).status_code == 200
    path = Path(settings.data_dir) / f"video/session-{wizard.session_id}/video-{video_id}.webm"
    with path.open("ab") as half_written:  # the server died after writing, before its commit
        half_written.write(b"half of chunk 1")
    assert chunk(client, booth_key, video_id, 1, b"chunk 1 again").status_code == 200
    assert path.read_bytes() == FIRST + b"chunk 1 again"


def test_the_key_and_the_booth_are_checked(
    client: TestClient, booth_key: str, running: RunSession, pi: StaffApi
) -> None:
    wizard = running(video=True)
    video_id = start(client, booth_key, wizard.session_id).json()["video_id"]
    for headers in ({}, {"X-Booth-Key": "not-the-key"}, {"X-Booth-Key": wizard.token}):
        assert client.get(f"{API}/state", headers=headers).status_code == 404
        assert client.post(f"{API}/videos/{video_id}/chunks/0", content=FIRST,
                           headers=headers).status_code == 404  # fmt: skip
    # booth-2's key opens nothing of booth-1, and booth-1's video is not booth-2's
    other = client.get("/api/video/booth-2/state", headers={"X-Booth-Key": booth_key})
    assert other.status_code == 404
    # a participant's phone link is no key; the phone API knows no video
    assert client.get(f"/video/{BOOTH}/{wizard.token}").status_code == 404
    assert client.get(f"/video/{BOOTH}/{booth_key}").status_code == 200
    capture = client.get(f"/capture/{BOOTH}/{booth_key}").text  # the capture page links it
    assert f'href="/video/{BOOTH}/{booth_key}" id="video-link"' in capture


def test_the_pi_alone_gets_the_video_and_the_replay(
    client: TestClient, booth_key: str, running: RunSession, engine: Engine, pi: StaffApi
) -> None:
    wizard = running(video=True)
    video_id = start(client, booth_key, wizard.session_id).json()["video_id"]
    chunk(client, booth_key, video_id, 0, FIRST)
    url = f"/pi/sessions/{wizard.session_id}/videos/{video_id}.webm"
    assert client.get(url).content == FIRST
    ranged = client.get(url, headers={"Range": "bytes=0-3"})
    assert (ranged.status_code, ranged.content) == (206, EBML_MAGIC)
    page = client.get(f"/pi/sessions/{wizard.session_id}").text
    assert '<span id="video-consent">video agreed</span>' in page
    assert 'data-replay="/pi/sessions/' in page
    replay = client.get(f"/pi/sessions/{wizard.session_id}/replay.json").json()
    assert [v["id"] for v in replay["videos"]] == [video_id]
    assert replay["videos"][0]["url"] == url
    assert "consent.given" in [e["kind"] for e in replay["events"]]
    assert replay["faces"]["reason"] == "No face recordings of this session."
    other_video = f"/pi/sessions/{wizard.session_id}/videos/{video_id + 1}.webm"
    assert client.get(other_video).status_code == 404
    client.post("/logout", headers={"X-CSRF-Token": pi.csrf})
    client.cookies.clear()
    assert client.get(url, follow_redirects=False).status_code in (303, 401, 403)
    with engine.connect() as db:
        assert db.scalar(select(SessionRow.video_consent).where(
            SessionRow.id == wizard.session_id)) is True  # fmt: skip
