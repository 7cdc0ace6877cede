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
    # The same actor in Swedish: same file names, other recordings (half as long).
    swedish = tmp_path / "prompts" / "sv" / ACTOR
    (swedish / "audio").mkdir(parents=True)
    (swedish / "lipsync").mkdir()
    soundfile.write(swedish / "audio" / "hello.mp3", tone[: RATE // 2], RATE, format="MP3")
    soundfile.write(swedish / "audio" / "only_sv.mp3", tone[: RATE // 4], RATE, format="MP3")
    (swedish / "lipsync" / "hello.csv").write_text("time,jawOpen\n0.000,0.0\n0.033,0.9\n")
    (tmp_path / "prompts" / "sv" / "secret.mp3").write_bytes(b"ID3")
    return settings.model_copy(update={"prompts_dir": tmp_path / "prompts"})


def url(app: FastAPI, relative: str, *, wav: bool = False, language: str | None = None) -> str:
    return media_path(signing_key(app), ACTOR, relative, wav=wav, language=language)


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
    audio_url = prompt_audio_url_builder(app)(ACTOR, "audio/hello.mp3", None)
    assert audio_url.startswith(settings.effective_public_url + f"/media/prompts/{ACTOR}/")
    assert "/audio/hello.wav?key=" in audio_url
    relative = audio_url.removeprefix(settings.effective_public_url)
    assert client.get(relative).headers["content-type"] == "audio/wav"
    curves = lipsync_url_for(settings, audio_url)
    assert curves is not None
    assert client.get(curves.removeprefix(settings.effective_public_url)).text.startswith("time")
    assert lipsync_url_for(settings, audio_url.replace("hello", "other")) is None
    assert lipsync_url_for(settings, "http://elsewhere/x.wav") is None


def test_a_language_folder_serves_its_own_recordings(
    client: TestClient, app: FastAPI, settings: Settings
) -> None:
    """A Swedish prompt is the Swedish file, not the same-named English one (issue 28)."""
    root = settings.prompts_dir
    assert root is not None
    swedish = client.get(url(app, "audio/hello.mp3", language="sv"))
    assert swedish.status_code == 200
    assert swedish.content == (root / "sv" / ACTOR / "audio" / "hello.mp3").read_bytes()
    assert swedish.content != (root / ACTOR / "audio" / "hello.mp3").read_bytes()
    # Only in Swedish: served with the language, not found without it.
    assert client.get(url(app, "audio/only_sv.mp3", language="sv")).status_code == 200
    assert client.get(url(app, "audio/only_sv.mp3")).status_code == 404


def test_each_language_has_its_own_wav_cache(
    client: TestClient, app: FastAPI, settings: Settings
) -> None:
    english = client.get(url(app, "audio/hello.mp3", wav=True))
    swedish = client.get(url(app, "audio/hello.mp3", wav=True, language="sv"))
    durations = [soundfile.info(io.BytesIO(r.content)).duration for r in (english, swedish)]
    assert durations == [pytest.approx(1.0, abs=0.1), pytest.approx(0.5, abs=0.1)]
    assert (settings.data_dir / "media-cache" / "sv" / ACTOR / "audio" / "hello.wav").is_file()


def test_the_curves_of_a_language_are_its_own(
    client: TestClient, app: FastAPI, settings: Settings
) -> None:
    audio_url = prompt_audio_url_builder(app)(ACTOR, "audio/hello.mp3", "sv")
    assert "lang=sv" in audio_url
    curves = lipsync_url_for(settings, audio_url)
    assert curves is not None
    text = client.get(curves.removeprefix(settings.effective_public_url)).text
    assert text.endswith("0.033,0.9\n")
    only = prompt_audio_url_builder(app)(ACTOR, "audio/only_sv.mp3", "sv")
    assert lipsync_url_for(settings, only) is None  # no curves for it


@pytest.mark.parametrize("language", ["..", "sv/..", "SV!", "x" * 20, "nope"])
def test_a_language_names_only_a_language_folder(
    client: TestClient, app: FastAPI, language: str
) -> None:
    assert client.get(url(app, "audio/hello.mp3", language=language)).status_code == 404
    assert client.get(url(app, "../secret.mp3", language="sv")).status_code == 404


def test_an_actor_folder_may_be_a_link_the_lab_made(
    client: TestClient, app: FastAPI, settings: Settings, tmp_path: Path
) -> None:
    root = settings.prompts_dir
    assert root is not None
    elsewhere = tmp_path / "recordings" / "m8"
    shutil.copytree(root / ACTOR, elsewhere)
    (root / "m8").symlink_to(elsewhere, target_is_directory=True)
    key = signing_key(app)
    assert client.get(media_path(key, "m8", "audio/hello.mp3")).status_code == 200
    assert client.get(media_path(key, "m8", "audio/hello.mp3", wav=True)).status_code == 200
    assert client.get(media_path(key, "m8", "../m9/audio/hello.mp3")).status_code == 404
