"""Scripted wizard and participant that drive a whole session through the public HTTP API,
exactly as the wizard console and the phone do (staff login + CSRF header; the phone link).

Used by the tests and by rehearsals. Works with an ``httpx.Client`` on a live server's URL,
or with Starlette's ``TestClient`` (an ``httpx2.Client``).
"""

from __future__ import annotations

import random
import re
import secrets
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

import httpx
import httpx2

CSRF_PATTERN = re.compile(r'name="csrf_token" value="([^"]+)"')
Json = dict[str, Any]
HttpClient = httpx.Client | httpx2.Client


class ApiError(Exception):
    def __init__(self, status: int, detail: Any) -> None:
        super().__init__(f"HTTP {status}: {detail}")
        self.status = status
        self.detail = detail


def _json(response: httpx.Response | httpx2.Response) -> Any:
    if response.status_code >= 400:
        try:
            detail = response.json().get("detail")
        except ValueError:
            detail = response.text
        raise ApiError(response.status_code, detail)
    return response.json()


def new_client_id() -> str:
    return secrets.token_urlsafe(16)


class StaffApi:
    """A logged-in staff member's JSON calls (CSRF header on unsafe methods)."""

    def __init__(self, http: HttpClient) -> None:
        self.http = http
        self.csrf = ""

    def login(self, username: str, password: str) -> StaffApi:
        form = self.http.get("/login").text
        token = _csrf(form)
        response = self.http.post(
            "/login",
            data={"username": username, "password": password, "csrf_token": token, "next": "/"},
            follow_redirects=False,
        )
        if response.status_code != 303:
            raise ApiError(response.status_code, "login failed")
        self.csrf = _csrf(self.http.get("/").text)
        return self

    def get(self, path: str) -> Any:
        return _json(self.http.get(path))

    def post(self, path: str, body: Json | None = None) -> Any:
        return _json(self.http.post(path, json=body or {}, headers={"X-CSRF-Token": self.csrf}))


def _csrf(html: str) -> str:
    match = CSRF_PATTERN.search(html)
    if match is None:
        raise ApiError(0, "no CSRF token on the page")
    return match.group(1)


@dataclass
class WizardBot:
    staff: StaffApi
    session_id: int
    snapshot: Json = field(default_factory=dict)

    @classmethod
    def create(
        cls,
        staff: StaffApi,
        study_id: int,
        participant_code: str | None = None,
        booth: str = "booth-1",
        rehearsal: bool = False,
        language: str | None = None,
    ) -> WizardBot:
        body = {
            "study_id": study_id,
            "participant_code": participant_code,
            "booth": booth,
            "rehearsal": rehearsal,
            "language": language,
        }
        snapshot = staff.post("/api/sessions", body)
        return cls(staff, snapshot["id"], snapshot)

    @property
    def phone_path(self) -> str:
        return str(urlsplit(self.snapshot["phone"]["url"]).path)

    @property
    def token(self) -> str:
        return self.phone_path.rsplit("/", 1)[-1]

    def _do(self, action: str, body: Json | None = None) -> Json:
        self.snapshot = self.staff.post(f"/api/sessions/{self.session_id}/{action}", body)
        return self.snapshot

    def refresh(self) -> Json:
        self.snapshot = self.staff.get(f"/api/sessions/{self.session_id}")
        return self.snapshot

    def start(self, prepare: bool = True) -> Json:
        """Start the session; ``prepare``: first let the participant agree on the phone and
        answer the questions before the session, as a participant does (tests of the
        refusal pass False)."""
        if prepare:
            ParticipantBot(self.staff.http, self.token).prepare(random.Random(self.session_id))
        return self._do("start")

    def advance(self, position: int, to: str) -> Json:
        return self._do("advance", {"position": position, "to": to})

    def decide(self, position: int, index: int, accepted: bool) -> Json:
        return self._do("decide", {"position": position, "index": index, "accepted": accepted})

    def undo(self, position: int, index: int) -> Json:
        return self._do("undo", {"position": position, "index": index})

    def switch_condition(
        self, condition: str, position: int | None = None, confirm_deviation: bool = False
    ) -> Json:
        body = {"condition": condition, "position": position}
        return self._do("condition", {**body, "confirm_deviation": confirm_deviation})

    def end(self, reason: str, note: str = "") -> Json:
        """End the session early (reasons: participant_withdrew, technical_failure, time,
        other with a note)."""
        return self._do("end", {"reason": reason, "note": note})

    def interaction(self, position: int) -> Json:
        interaction: Json = self.snapshot["interactions"][position - 1]
        return interaction

    def negotiate(self, position: int, accept: Callable[[Json], bool]) -> list[bool]:
        """Decide every suggestion of the interaction; ``accept`` sees each suggestion."""
        decisions: list[bool] = []
        while True:
            pending = [
                s for s in self.interaction(position)["suggestions"] if s["accepted"] is None
            ]
            if not pending:
                return decisions
            decision = accept(pending[0])
            self.decide(position, pending[0]["index"], decision)
            decisions.append(decision)


@dataclass
class ParticipantBot:
    """The phone: only the session's token, no login."""

    http: HttpClient
    token: str
    sent: list[Json] = field(default_factory=list)

    def state(self) -> Json:
        """The phone's view; ``{"view": "ended"}`` once the link has stopped working."""
        response = self.http.get(f"/api/phone/{self.token}/state")
        if response.status_code == 410:
            return {"view": "ended"}
        result: Json = _json(response)
        return result

    def _send(self, kind: str, body: Json) -> Json:
        self.sent.append({"kind": kind, **body})
        url = f"/api/phone/{self.token}/{kind}"
        try:
            response = self.http.post(url, json=body)
        except httpx.RemoteProtocolError:
            # The server closed a kept-alive connection as the submission went out on it
            # (uvicorn lets one go after 5 s idle; a client that waited longer, or was
            # slowed down, reused it). The phone's page sends the same submission again,
            # and so does the bot: its client id makes the server store it once.
            response = self.http.post(url, json=body)
        receipt: Json = _json(response)
        return receipt

    def submit_ranking(
        self, position: int, ranking: list[str], client_id: str | None = None
    ) -> Json:
        body = {"client_id": client_id or new_client_id(), "position": position, "ranking": ranking}
        return self._send("ranking", body)

    def submit_questionnaire(
        self, position: int, questionnaire: str, answers: Json, client_id: str | None = None
    ) -> Json:
        body = {
            "client_id": client_id or new_client_id(),
            "position": position,
            "questionnaire": questionnaire,
            "answers": answers,
        }
        return self._send("questionnaire", body)

    def choose_language(self, language: str) -> Json:
        """The language buttons of the phone's first page (before consent)."""
        return self._send("language", {"client_id": new_client_id(), "language": language})

    def consent(
        self,
        agree: bool = True,
        client_id: str | None = None,
        *,
        video: bool = False,
        audio: bool = False,
    ) -> Json:
        body = {"client_id": client_id or new_client_id(), "agree": agree, "video": video,
                "audio": audio}  # fmt: skip
        return self._send("consent", body)

    def prepare(self, rng: random.Random) -> None:
        """Agree on the consent page and answer the questions before the session (if the
        study has them and they are not answered yet)."""
        state = self.state()
        if state["view"] == "consent":
            state = self.consent(True)["state"]
        if state["view"] == "questionnaire" and state.get("before"):
            self.answer_questionnaires(-1, rng)

    def rank(self, rng: random.Random) -> Json:
        state = self.state()
        if state["view"] != "ranking":
            raise ApiError(0, f"the phone shows {state['view']!r}, not the ranking")
        ranking = [item["id"] for item in state["items"]]
        rng.shuffle(ranking)
        return self.submit_ranking(state["position"], ranking)

    def answer_questionnaires(self, position: int, rng: random.Random) -> int:
        """Answer every questionnaire page of ``position`` (0: the final one) the phone shows
        now; returns the number of pages answered."""
        pages = 0
        state = self.state()
        while state["view"] == "questionnaire" and state["position"] == position:
            questionnaire = state["questionnaire"]
            answers = answers_for(questionnaire, rng)
            receipt = self.submit_questionnaire(position, questionnaire["id"], answers)
            pages += 1
            state = receipt["state"]
            if state["view"] == "ended":
                break
        return pages


def answers_for(questionnaire: Json, rng: random.Random) -> Json:
    return {
        item["id"]: (
            f"Answer {rng.randint(1, 999)} to {item['id']}."
            if item["type"] == "text"
            else rng.choice(item["options"])["id"]
            if item.get("options")
            else rng.randint(1, questionnaire["points"])
        )
        for item in questionnaire["items"]
    }


@dataclass
class SessionResult:
    session_id: int
    participant_code: str
    decisions: list[list[bool]]
    snapshot: Json
    participant: ParticipantBot


def run_session(
    staff: StaffApi,
    phone: HttpClient,
    study_id: int,
    rng: random.Random,
    accept_probability: float = 0.5,
    rehearsal: bool = False,
    booth: str = "booth-1",
) -> SessionResult:
    """A whole new session: every interaction in plan order, then the final questionnaire."""
    wizard = WizardBot.create(staff, study_id, rehearsal=rehearsal, booth=booth)
    participant = ParticipantBot(phone, wizard.token)
    return drive_session(wizard, participant, rng, accept_probability)


def drive_session(
    wizard: WizardBot,
    participant: ParticipantBot,
    rng: random.Random,
    accept_probability: float = 0.5,
    on_step: Callable[[str], None] | None = None,
) -> SessionResult:
    """Drive an existing, not yet started session to its end; ``on_step`` is called with
    the name of each step just taken (e.g. ``"2:ranking"``)."""
    step = on_step or (lambda _name: None)
    wizard.start()
    step("start")
    decisions = []
    for position in range(1, wizard.snapshot["interaction_count"] + 1):
        for to in ("discussion", "ranking"):
            wizard.advance(position, to)
            step(f"{position}:{to}")
        participant.rank(rng)
        step(f"{position}:ranked")
        wizard.advance(position, "negotiation")
        decisions.append(wizard.negotiate(position, lambda _s: rng.random() < accept_probability))
        step(f"{position}:negotiated")
        wizard.advance(position, "questionnaire")
        step(f"{position}:questionnaire")
        participant.answer_questionnaires(position, rng)
        step(f"{position}:answered")
    participant.answer_questionnaires(0, rng)
    snapshot = wizard.refresh()
    if snapshot["state"] != "complete":
        raise ApiError(0, f"the session ended in state {snapshot['state']!r}")
    code = snapshot["participant"]["code"]
    return SessionResult(wizard.session_id, code, decisions, snapshot, participant)
