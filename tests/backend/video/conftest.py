"""A study that records video (the shipped ``embodiment`` study: ``procedure.video`` with
audio) and a session of it running at booth-1, its participant's video items as asked."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.video.pages import current_video_path
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, staff_api, study_with_plan

STUDIES = Path(__file__).resolve().parents[3] / "chameleons" / "experiment" / "studies"
VIDEO_STUDY = (STUDIES / "embodiment" / "study.yaml").read_text(encoding="utf-8")
BOOTH = "booth-1"


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


@pytest.fixture
def video_study(pi: StaffApi) -> int:
    return study_with_plan(pi, participants=3, yaml=VIDEO_STUDY)


RunSession = Callable[..., WizardBot]


@pytest.fixture
def running(pi: StaffApi, video_study: int) -> RunSession:
    """Start a session at ``booth`` whose participant ticked ``video`` and ``audio``."""

    def run(video: bool = True, audio: bool = False, booth: str = BOOTH) -> WizardBot:
        wizard = WizardBot.create(pi, video_study, booth=booth)
        ParticipantBot(pi.http, wizard.token).consent(True, video=video, audio=audio)
        wizard.start()
        return wizard

    return run


@pytest.fixture
def booth_key(app: FastAPI, client: TestClient) -> str:
    path = current_video_path(app, BOOTH)
    assert path is not None
    return path.rsplit("/", 1)[-1]
