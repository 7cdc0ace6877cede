"""Prompt media by URL: MP3 for browsers, WAV (decoded once, cached) for a Furhat."""

from __future__ import annotations

import io
import shutil
from pathlib import Path

import numpy as np
import pytest
import soundfile
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.display.media import lipsync_url_for, media_path, prompt_audio_url_builder
from chameleons.backend.display.tokens import signing_key
from chameleons.settings import Settings
from tests.backend.test_auth import add_user, login

ACTOR = "m9"
RATE = 22050


@pytest.fixture
def database_url(sqlite_template: Path, tmp_path: Path) -> str:
    path = tmp_path / "media.sqlite3"
    shutil.copyfile(sqlite_template, path)
    return f"sqlite:///{path}"


@pytest.fixture
def settings(settings: Settings, tmp_path: Path) -> Settings:
    actor = tmp_path / "prompts" / ACTOR
    (actor / "audio").mkdir(parents=True)
    (actor / "lipsync").mkdir()
    tone = 0.3 * np.sin(2 * np.pi * 300 * np.arange(RATE) / RATE)
    soundfile.write(actor / "audio" / "hello.mp3", tone, RATE, format="MP3")
    (actor / "lipsync" / "hello.csv").write_text("time,jawOpen\n0.000,0.0\n0.033,0.5\n")
    (actor / "manifest.py").write_text("not media\n")
    (tmp_path / "prompts" / "secret.mp3").write_bytes(b"ID3")
    return settings.model_copy(update={"prompts_dir": tmp_path / "prompts"})


def url(app: FastAPI, relative: str, *, wav: bool = False) -> str:
    return media_path(signing_key(app), ACTOR, relative, wav=wav)


def test_browsers_get_the_mp3_and_the_curves(client: TestClient, app: FastAPI) -> None:
    audio = client.get(url(app, "audio/hello.mp3"))
    assert audio.status_code == 200
    assert audio.headers["content-type"] == "audio/mpeg"
    curves = client.get(url(app, "lipsync/hello.csv"))
    assert curves.text.startswith("time,jawOpen")


def test_a_furhat_gets_a_pcm_wav_decoded_once(
    client: TestClient, app: FastAPI, settings: Settings
) -> None:
    response = client.get(url(app, "audio/hello.mp3", wav=True))
    assert response.status_code == 200
    assert response.headers["content-type"] == "audio/wav"
    info = soundfile.info(io.BytesIO(response.content))
    assert (info.format, info.subtype, info.channels) == ("WAV", "PCM_16", 1)
    assert abs(info.duration - 1.0) < 0.1
    cached = settings.data_dir / "media-cache" / ACTOR / "audio" / "hello.wav"
    first = cached.stat().st_mtime_ns
    assert client.get(url(app, "audio/hello.wav")).content == response.content
    assert cached.stat().st_mtime_ns == first


@pytest.mark.parametrize(
    "path",
    [
        f"/media/prompts/{ACTOR}/audio/hello.mp3?key=wrong",
        f"/media/prompts/{ACTOR}/audio/hello.mp3",
    ],
)
def test_without_the_key_nothing_is_served(client: TestClient, path: str) -> None:
    assert client.get(path).status_code == 404


@pytest.mark.parametrize(
    "relative", ["../secret.mp3", "manifest.py", "audio/missing.mp3", "audio/missing.wav"]
)
def test_only_media_inside_the_actor_folder(
    client: TestClient, app: FastAPI, relative: str
) -> None:
    assert client.get(url(app, relative)).status_code == 404


def test_staff_need_no_key(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "correct horse", "wizard")
    login(client, "wiz", "correct horse")
    assert client.get(f"/media/prompts/{ACTOR}/audio/hello.mp3").status_code == 200


def test_encoded_dot_dot_cannot_leave_the_actor_folder(client: TestClient, app: FastAPI) -> None:
    key = url(app, "x").split("?key=")[1]
    response = client.get(f"/media/prompts/{ACTOR}/%2e%2e/secret.mp3?key={key}")
    assert response.status_code == 404


def test_play_commands_get_a_keyed_wav_url_and_the_page_its_curves(
    client: TestClient, app: FastAPI, settings: Settings
) -> None:
    audio_url = prompt_audio_url_builder(app)(ACTOR, "audio/hello.mp3")
    assert audio_url.startswith(settings.effective_public_url + f"/media/prompts/{ACTOR}/")
    assert "/audio/hello.wav?key=" in audio_url
    relative = audio_url.removeprefix(settings.effective_public_url)
    assert client.get(relative).headers["content-type"] == "audio/wav"
    curves = lipsync_url_for(settings, audio_url)
    assert curves is not None
    assert client.get(curves.removeprefix(settings.effective_public_url)).text.startswith("time")
    assert lipsync_url_for(settings, audio_url.replace("hello", "other")) is None
    assert lipsync_url_for(settings, "http://elsewhere/x.wav") is None
