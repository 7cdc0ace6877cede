"""The phones of ``bench.server_bench``: sessions walked against the real server (with the
wizard's actions, a console socket and the phone's own socket each), and the same traffic
against the baseline app.

A phone's pace: before each submission it "thinks" a uniform 0..T s; before each of the
wizard's actions the wizard "thinks" a uniform 0..W s (W = 0: the instant wizard of the
stress run, whose ~8 actions per ranking land within milliseconds of each other).
"""

from __future__ import annotations

import itertools
import math
import random
import secrets
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from typing import Any

from bench.server_load import Figures, Listener, Server
from chameleons.backend.sessions.bot import (
    ApiError,
    ParticipantBot,
    StaffApi,
    WizardBot,
    answers_for,
)
from chameleons.backend.sessions.consent import BEFORE_POSITION

UPDATE_TIMEOUT_S = 60.0
PHONE_ENDED = 4410  # the phone socket's close code once its session is over


class TimeUpError(Exception):
    """The scenario's time is over: the phone stops after what it was doing."""


@dataclass
class Pace:
    """Think times of one phone and its wizard, and the scenario's end (monotonic)."""

    rng: random.Random
    phone_max: float
    wizard_max: float = 0.0
    deadline: float = math.inf
    stop: threading.Event | None = None  # set: the scenario is over (as the deadline)

    def phone(self) -> None:
        self._pause(self.phone_max)

    def wizard(self) -> None:
        self._pause(self.wizard_max)

    def _pause(self, most: float) -> None:
        if most > 0:
            Listener.pause(self.rng.uniform(0, most))
        if time.monotonic() >= self.deadline or (self.stop is not None and self.stop.is_set()):
            raise TimeUpError


@dataclass
class Phone:
    """One participant: the session's wizard, the phone's link and socket, the console."""

    wizard: WizardBot
    participant: ParticipantBot
    console: Listener
    socket: Listener


@dataclass
class RealServer:
    server: Server
    staff_cookie: dict[str, str]
    csrf: str
    study_ids: list[int]
    phone_servers: list[Server] = field(default_factory=list)  # none: the phones use ``server``
    sockets_opened: int = 0
    _opened: Iterator[int] = field(default_factory=itertools.count)
    _one_at_a_time: threading.Lock = field(default_factory=threading.Lock)

    @classmethod
    def of(cls, server: Server, setup: dict[str, Any]) -> RealServer:
        return cls(server, setup["cookies"], setup["csrf"], setup["study_ids"],
                   list(setup.get("phone_servers", [])))  # fmt: skip

    def new_phone(self) -> Phone:
        """A new session with its console socket and the phone's socket open (as the phone
        page opens ``/ws/p/{token}?device=...`` as soon as it loads)."""
        http = self.server.client(cookies=self.staff_cookie)
        staff = StaffApi(http)
        staff.csrf = self.csrf
        opened = next(self._opened)  # the studies' plans fill evenly
        wizard = WizardBot.create(staff, self.study_ids[opened % len(self.study_ids)])
        # The phone's link and socket on a phone server when there are any (as a proxy
        # sends them, docs/performance.md), the wizard and the console on the main one.
        phones = self.phone_servers or [self.server]
        phone_server = phones[opened % len(phones)]
        participant = ParticipantBot(phone_server.client(), wizard.token)
        console = Listener(self.server.ws_url(f"/ws/wizard/sessions/{wizard.session_id}"),
                           self.server.base, self.staff_cookie)  # fmt: skip
        device = secrets.token_hex(8)
        socket = Listener(phone_server.ws_url(f"/ws/p/{wizard.token}?device={device}"),
                          phone_server.base, ended_codes=(PHONE_ENDED,))  # fmt: skip
        self.sockets_opened += 2
        return Phone(wizard, participant, console, socket)

    def new_phone_alone(self) -> Phone:
        """:meth:`new_phone`, one caller at a time: for a scenario's set-up, which is not
        measured (sessions opened at the same moment are a scenario's own load)."""
        with self._one_at_a_time:
            return self.new_phone()

    @staticmethod
    def release(phone: Phone, figures: Figures) -> None:
        figures.release("console socket", phone.console)
        figures.release("phone socket", phone.socket)
        phone.wizard.staff.http.close()
        phone.participant.http.close()


Send = Callable[[str], Any]


def submit_measured(figures: Figures, console: Listener, send: Send) -> Any:
    """One submission: its HTTP time, and the time until the console shows it."""
    client_id = secrets.token_urlsafe(12)
    start = console.clock()
    try:
        result = send(client_id)
    except ApiError as error:
        figures.count_error(f"HTTP {error.status} ({error.detail})")
        return None
    figures.add(http=console.clock() - start, update=None)
    arrived = console.wait_for(client_id, timeout=UPDATE_TIMEOUT_S)
    if arrived is None:
        figures.count_error(f"no console update within {UPDATE_TIMEOUT_S:g} s")
        return result
    figures.add(http=None, update=arrived - start)
    # What the wizard sees: the console state sent after the event (console.js renders it).
    rendered = console.wait_for_state(client_id, timeout=UPDATE_TIMEOUT_S)
    if rendered is None:
        figures.count_error(f"no console state within {UPDATE_TIMEOUT_S:g} s")
    else:
        figures.add(http=None, update=None, state=rendered - start)
    return result


def walk_session(phone: Phone, figures: Figures, pace: Pace) -> None:
    """The whole session as ``drive_session`` walks it, measuring each phone submission; a
    wizard action the server refuses or fails ends this phone's walk, counted as an error
    of the scenario it happened in; the scenario's end stops it quietly."""
    try:
        _walk(phone, figures, pace)
    except ApiError as error:
        figures.count_error(f"wizard action: HTTP {error.status} ({error.detail})")
    except TimeUpError:
        pass


def _walk(phone: Phone, figures: Figures, pace: Pace) -> None:
    wizard, participant, rng = phone.wizard, phone.participant, pace.rng
    prepare(phone, figures, pace)
    pace.wizard()
    wizard.start(prepare=False)

    def decide(_suggestion: Any) -> bool:
        pace.wizard()
        return rng.random() < 0.5

    for position in range(1, wizard.snapshot["interaction_count"] + 1):
        for to in ("discussion", "ranking"):
            pace.wizard()
            wizard.advance(position, to)
        ranking = [item["id"] for item in participant.state()["items"]]
        rng.shuffle(ranking)
        pace.phone()
        submit_measured(figures, phone.console,
                        partial(participant.submit_ranking, position, ranking))  # fmt: skip
        pace.wizard()
        wizard.advance(position, "negotiation")
        wizard.negotiate(position, decide)
        pace.wizard()
        wizard.advance(position, "questionnaire")
        answer_pages(phone, figures, pace, position)
    answer_pages(phone, figures, pace, 0)


def prepare(phone: Phone, figures: Figures, pace: Pace) -> None:
    """The participant's part before the wizard starts the session, at the phone's pace and
    measured as every other submission: the consent page, then the questions before the
    session. (The wizard's ``start`` used to do it at once, unmeasured: every phone's
    consent and first pages then landed within the scenario's first second, a burst no lab
    makes that slowed the submissions measured just after it.)"""
    state = phone.participant.state()
    if state["view"] == "consent":
        pace.phone()
        receipt = submit_measured(figures, phone.console, partial(phone.participant.consent, True))
        if receipt is None:
            return
        state = receipt["state"]
    if state["view"] == "questionnaire" and state.get("before"):
        answer_pages(phone, figures, pace, BEFORE_POSITION, state)


def answer_pages(
    phone: Phone, figures: Figures, pace: Pace, position: int, state: dict[str, Any] | None = None
) -> None:
    """Answer the questionnaire pages of ``position`` the phone shows (``state``: its view
    now, when the caller has it)."""
    state = phone.participant.state() if state is None else state
    while state["view"] == "questionnaire" and state["position"] == position:
        questionnaire = state["questionnaire"]
        answers = answers_for(questionnaire, pace.rng)
        pace.phone()
        send = partial(phone.participant.submit_questionnaire, position, questionnaire["id"],
                       answers)  # fmt: skip
        receipt = submit_measured(figures, phone.console, send)
        if receipt is None:
            return
        state = receipt["state"]


@dataclass
class BaselinePhone:
    """The baseline's phone: a console socket and a phone socket on one channel, to which
    each submission is pushed (the real server pushes to both too)."""

    server: Server
    channel: str
    http: Any = field(init=False)

    def __post_init__(self) -> None:
        url = self.server.ws_url(f"/ws/{self.channel}")
        self.console = Listener(url, self.server.base)
        self.socket = Listener(url, self.server.base)
        self.http = self.server.client()

    def send(self, client_id: str) -> Any:
        body = {"client_id": client_id, "answers": {"q1": 3, "q2": "a few words", "q3": [1, 2]}}
        response = self.http.post(f"/api/submit/{self.channel}", json=body)
        if response.status_code >= 400:
            raise ApiError(response.status_code, response.text)
        return response.json()

    def submit(self, figures: Figures, count: float, pace: Pace) -> None:
        """``count`` submissions (``math.inf``: until the pace's deadline)."""
        done = 0
        try:
            while done < count:
                pace.phone()
                submit_measured(figures, self.console, self.send)
                done += 1
        except TimeUpError:
            pass

    def close(self, figures: Figures) -> None:
        figures.release("console socket", self.console)
        figures.release("phone socket", self.socket)
        self.http.close()
