"""No condition or behaviour name ever reaches the participant's phone: not in a page, a
JSON answer, a WebSocket message or the JavaScript and CSS the page loads."""

from __future__ import annotations

import contextlib
import importlib
import json
import random
import re
from typing import Any

from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from chameleons.experiment.study import load_default_study
from tests.support.bots import (
    ParticipantBot,
    StaffApi,
    WizardBot,
    drive_session,
    staff_api,
    study_with_plan,
)

PHONE_PREFIXES = ("/p/", "/api/phone/", "/join", "/static/")
BUILT_IN_BEHAVIOURS = ("still", "natural", "copy")


def forbidden_words() -> set[str]:
    study = load_default_study()
    words = set(BUILT_IN_BEHAVIOURS)
    for condition in study.conditions:
        words.update({condition.id, condition.label})
    try:  # every behaviour the worker knows, when the worker is installed
        registry = importlib.import_module("chameleons.worker.behaviours.registry")
        words.update(registry.available_behaviours())
    except (ImportError, AttributeError):
        pass
    return {w.lower() for w in words if w}


def leaks(text: str, words: set[str]) -> list[str]:
    return sorted(w for w in words if re.search(rf"\b{re.escape(w)}\b", text, re.IGNORECASE))


def test_the_scan_catches_a_condition_name() -> None:
    words = forbidden_words()
    assert leaks('{"condition": "copy"}', words) == ["copy"]
    assert leaks("Natural movement", words) == ["natural", "natural movement"]
    assert leaks("Copyright, stillness and naturally", words) == []


def test_no_participant_facing_text_names_a_condition(client: TestClient, engine: Any) -> None:
    pi: StaffApi = staff_api(client, engine, "pi")
    wizard = WizardBot.create(pi, study_with_plan(pi))
    captured: list[tuple[str, str]] = []

    def capture(response: Any) -> None:
        path = response.request.url.path
        if path.startswith(PHONE_PREFIXES):
            response.read()
            captured.append((path, response.text))

    def load_page(_step: str) -> None:
        page = client.get(wizard.phone_path)
        for asset in re.findall(r'(?:src|href)="(?:https?://[^/"]+)?(/static/[^"]+)"', page.text):
            assert client.get(asset).status_code == 200

    client.event_hooks["response"].append(capture)
    client.get("/join")
    messages: list[str] = []
    with client.websocket_connect(f"/ws/p/{wizard.token}") as socket:
        participant = ParticipantBot(client, wizard.token)
        drive_session(wizard, participant, random.Random(4), on_step=load_page)
        with contextlib.suppress(WebSocketDisconnect):
            while len(messages) < 500:
                messages.append(socket.receive_text())
    client.get(wizard.phone_path)  # the "ended" page
    views = {json.loads(m)["state"]["view"] for m in messages if '"state"' in m}
    assert {"welcome", "listen", "ranking", "ranked", "questionnaire", "ended"} <= views
    sources = {"/".join(path.split("/")[:3]) for path, _ in captured}
    assert {"/api/phone", "/static/phone", "/static/vendor", "/join"} <= sources
    words = forbidden_words()
    texts = [*captured, *(("websocket", m) for m in messages)]
    assert [(where, leaks(text, words)) for where, text in texts if leaks(text, words)] == []
