"""Run N rehearsal sessions against a server and summarise them.

The server may be anywhere (``chameleons rehearse --server URL``) or started on this
machine by :mod:`chameleons.rehearsal.embedded`. Everything goes through the server's
public HTTP API and WebSockets with a staff login, as the people running a study do.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from statistics import mean
from typing import Any

import httpx
from websockets.exceptions import InvalidHandshake

from chameleons.backend.sessions.bot import ApiError, ParticipantBot, StaffApi, WizardBot
from chameleons.experiment.model import Study
from chameleons.experiment.study import load_default_study
from chameleons.rehearsal.patterns import PATTERNS, Keying, Persona, not_keyed
from chameleons.rehearsal.script import ConsoleWizard, PhoneParticipant, Tally, run_session
from chameleons.rehearsal.situations import draw, situations_rng
from chameleons.rehearsal.sockets import DisplayScreen, PhoneSocket

Json = dict[str, Any]
Progress = Callable[[str], None]


class RehearsalError(RuntimeError):
    """The rehearsal cannot run (no study, a refused login, a session that broke off)."""


@dataclass(frozen=True)
class Target:
    """Where to rehearse: the server's URL, a staff login, the study and booth."""

    base_url: str
    username: str
    password: str
    study_id: int | None = None  # None: the server's newest active study
    booth: str = "booth-1"
    # The booth was named (--booth): rehearse there even when a real session is open on it
    # (with a warning); by default such a booth is refused (see ``check_booth``).
    booth_chosen: bool = False
    local: bool = False  # a server on this machine (no HTTP proxies)
    studies: Sequence[Study] = ()  # configurations whose reverse-keyed items are known


@dataclass(frozen=True)
class Options:
    participants: int
    seed: int = 0
    pattern: str = "neutral"
    script: str = "full"  # prompts the wizard plays: full, brief or silent
    display: bool = True  # also be the virtual robot's display page
    drop_out: float = 0.0  # share of sessions that drop out (see .situations)
    deviate: float = 0.0  # share of sessions with a confirmed repeated condition
    language: str | None = None  # the participants' language; None: the study's default
    hold: float = 0.0  # seconds each interaction's discussion lasts at least (face recordings)


@dataclass
class Summary:
    study_id: int
    study_name: str
    codes: list[str]
    session_ids: list[int]
    seconds: float
    options: Options
    tally: Tally
    display: dict[str, int] = field(default_factory=dict)
    situations: list[str] = field(default_factory=list)  # dropouts and deviations made
    voiced: int = 0  # prompts the display loaded the audio of and reported spoken
    unloaded: list[str] = field(default_factory=list)  # "prompt: why" of audio that failed
    fetched: list[tuple[str, str, str]] = field(default_factory=list)  # (prompt, path, sha256)
    warnings: list[str] = field(default_factory=list)  # said before the first session

    def lines(self) -> list[str]:
        count = len(self.codes)
        span = f"{self.codes[0]}-{self.codes[-1]}" if count > 1 else "".join(self.codes)
        per = self.seconds / count if count else 0.0
        tally = self.tally
        sessions, people = _count(count, "session"), _count(count, "participant")
        lines = [
            f"Rehearsed {sessions} ({people}, {span}) of study "
            f"{self.study_id} ({self.study_name}) in {self.seconds:.1f} s ({per:.1f} s each); "
            f"pattern {self.options.pattern}, seed {self.options.seed}"
            f"{f', language {self.options.language}' if self.options.language else ''}.",
            f"Prompts: {tally.prompts_played} played through the worker, "
            f"{tally.prompts_not_sent} not sent; robot set up {tally.robot_applied} times, "
            f"{tally.robot_not_applied} not.",
        ]
        if self.display:
            lines.append(
                f"Virtual robot display: {self.display.get('face', 0)} face frames, "
                f"{self.display.get('head', 0)} head poses, "
                f"{self.voiced} prompts voiced (audio loaded from the server)."
            )
        if self.unloaded:
            lines.append(
                f"NOT VOICED: the audio of {len(self.unloaded)} prompts could not be loaded: "
                + "; ".join(self.unloaded[:3])
                + ("; ..." if len(self.unloaded) > 3 else "")
            )
        lines += [f"Warning: {warning}" for warning in self.warnings]
        accepted = ", ".join(
            f"{condition} {mean(values):.2f}"
            for condition, values in sorted(tally.accepted.items())
        )
        lines.append(f"Accepted suggestions per interaction (mean): {accepted or '-'}.")
        if self.options.drop_out or self.options.deviate:
            lines.append(
                f"Dropouts and deviations (--drop-out {self.options.drop_out:g}, --deviate "
                f"{self.options.deviate:g}): {tally.unstarted} never started, "
                f"{tally.ended_early} ended early, {tally.deviations} deviated."
            )
            lines += [f"  {said}" for said in self.situations]
        lines += [f"Note: {problem}" for problem in tally.problems[:5]]
        lines.append("Export with: chameleons export --include-rehearsal --out DIR")
        return lines


def _count(number: int, noun: str) -> str:
    return f"{number} {noun}{'' if number == 1 else 's'}"


def keying_for(config_hash: str, studies: Sequence[Study]) -> Keying:
    """Which items of the study are reverse-keyed (a participant reads the anchors; a script
    needs the configuration). Unknown configurations: none, and a note in the summary."""
    for spec in (*studies, load_default_study()):
        if spec.content_hash == config_hash:
            reverse = {(q.id, i.id) for q in spec.questionnaires for i in q.items if i.reverse}
            return lambda questionnaire, item: (questionnaire, item) in reverse
    return not_keyed


def pick_study(staff: StaffApi, study_id: int | None) -> Json:
    studies: list[Json] = staff.get("/api/studies")
    if study_id is not None:
        found = [s for s in studies if s["id"] == study_id]
    else:
        found = sorted(studies, key=lambda s: (s["is_active"], s["id"]))[-1:]
    if not found:
        raise RehearsalError(
            f"The server has no study {study_id}." if study_id is not None
            else "The server has no study yet: create one (and its plan) first."
        )  # fmt: skip
    if not found[0]["plan_rows"]:
        raise RehearsalError(f"Study {found[0]['id']} has no plan yet: generate it first.")
    return found[0]


def language_warnings(study: Json, language: str | None) -> list[str]:
    """Why the sessions' language cannot voice every prompt (the server refuses real
    sessions in it; rehearsals run, and the prompts it lacks are never played)."""
    chosen = language or study.get("default_language") or ""
    gap = (study.get("prompt_gaps") or {}).get(chosen)
    return [f"{gap} Rehearsing anyway: those prompts will not be played."] if gap else []


OPEN_STATES = ("pending", "running", "final_questionnaire")


def real_session_on(staff: StaffApi, booth: str) -> Json | None:
    """The oldest real (not rehearsal) session open on ``booth``, in any study, or None."""
    found = [
        session
        for state in OPEN_STATES
        for session in staff.get(f"/api/sessions?state={state}")
        if session["booth"] == booth and not session["is_rehearsal"]
    ]
    return min(found, key=lambda s: s["id"]) if found else None


def check_booth(staff: StaffApi, target: Target, say: Progress) -> None:
    """Refuse a booth where a participant may be sitting now (the rehearsal would drive its
    robot and display), unless the booth was named on purpose (then a warning)."""
    busy = real_session_on(staff, target.booth)
    if busy is None:
        return
    which = (
        f"Booth {target.booth} has a real session open (session {busy['id']}, participant "
        f"{busy['participant_code']}, {busy['state'].replace('_', ' ')})"
    )
    if not target.booth_chosen:
        raise RehearsalError(
            f"{which}: rehearse on another booth with --booth NAME, or name this one "
            f"(--booth {target.booth}) to rehearse there anyway."
        )
    say(f"Warning: {which}; rehearsing there as --booth {target.booth} asked.")


def rehearse(target: Target, options: Options, progress: Progress | None = None) -> Summary:
    if options.pattern not in PATTERNS:
        raise RehearsalError(f"Unknown answer pattern {options.pattern!r}.")
    say = progress or (lambda _line: None)
    started = time.monotonic()
    trust_env = not target.local
    with (
        httpx.Client(base_url=target.base_url, timeout=30, trust_env=trust_env) as http,
        httpx.Client(base_url=target.base_url, timeout=30, trust_env=trust_env) as phone_http,
    ):
        staff = _log_in(http, target)
        study = pick_study(staff, target.study_id)
        check_booth(staff, target, say)
        warnings = language_warnings(study, options.language)
        for warning in warnings:
            say(f"Warning: {warning}")
        display = _open_display(target, http, say) if options.display else None
        try:
            summary = _sessions(target, options, staff, phone_http, study, say)
            if display is not None:  # every play the server sent, before the page closes
                display.wait_for_answered(summary.tally.prompts_played)
        finally:
            if display is not None:
                display.close()
        summary.warnings = warnings
        if display is not None:
            summary.display = dict(display.received)
            summary.voiced, summary.unloaded = display.voiced, list(display.unloaded)
            summary.fetched = list(display.fetched)
    summary.seconds = time.monotonic() - started
    return summary


def _create(staff: StaffApi, study_id: int, booth: str, language: str | None) -> WizardBot:
    try:
        return WizardBot.create(staff, study_id, booth=booth, rehearsal=True, language=language)
    except ApiError as error:  # e.g. a language the study does not have: say so, stop
        raise RehearsalError(f"Cannot open a session: {error.detail}") from error


def _log_in(http: httpx.Client, target: Target) -> StaffApi:
    try:
        return StaffApi(http).login(target.username, target.password)
    except ApiError as error:
        raise RehearsalError(
            f"Cannot log in to {target.base_url} as {target.username!r} ({error})."
        ) from error
    except httpx.HTTPError as error:
        raise RehearsalError(f"Cannot reach {target.base_url}: {error}") from error


def _open_display(target: Target, http: httpx.Client, say: Progress) -> DisplayScreen | None:
    """The booth's robot display, or None (said why) when the server refuses it: prompts
    then go unvoiced, as with a display page that is not open, and the sessions still run."""
    cookie = "; ".join(f"{name}={value}" for name, value in http.cookies.items())
    try:
        return DisplayScreen(target.base_url, target.booth, cookie, proxy=not target.local)
    except (InvalidHandshake, OSError, TimeoutError) as error:
        say(f"No robot display for {target.booth} ({error}); rehearsing without it.")
        return None


def _sessions(
    target: Target,
    options: Options,
    staff: StaffApi,
    phone_http: httpx.Client,
    study: Json,
    say: Progress,
) -> Summary:
    pattern = PATTERNS[options.pattern]
    rng = random.Random(options.seed)
    situations = situations_rng(options.seed)  # its own stream: answers stay the seed's
    tally = Tally()
    summary = Summary(study["id"], study["name"], [], [], 0.0, options, tally)
    for number in range(1, options.participants + 1):
        persona = Persona.draw(pattern, random.Random(rng.getrandbits(64)))
        wizard_rng = random.Random(rng.getrandbits(64))
        bot = _create(staff, study["id"], target.booth, options.language)
        count = int(bot.snapshot["interaction_count"])
        situation = draw(situations, options.drop_out, options.deviate, count)
        wizard = ConsoleWizard(bot, options.script, tally, wizard_rng, hold=options.hold)
        keying = keying_for(bot.snapshot["config_hash"], target.studies)
        if keying is not_keyed:
            tally.note("unknown study configuration: reverse-keyed items answered as plain")
        socket = PhoneSocket(target.base_url, bot.token, proxy=not target.local)
        try:
            participant = PhoneParticipant(ParticipantBot(phone_http, bot.token), socket,
                                           persona, keying)  # fmt: skip
            snapshot = run_session(wizard, participant, tally, situation)
        except (ApiError, TimeoutError) as error:
            code = bot.snapshot["participant"]["code"]
            raise RehearsalError(f"Session {bot.session_id} ({code}) broke off: {error}") from error
        finally:
            socket.close()
        code = snapshot["participant"]["code"]
        summary.codes.append(code)
        summary.session_ids.append(bot.session_id)
        repeated = None
        if situation.deviate_at is not None:
            repeated = str(snapshot["interactions"][situation.deviate_at - 1]["condition"])
        summary.situations += situation.describe(code, repeated)
        state = {"complete": "complete", "ended": "ended early"}.get(snapshot["state"])
        say(f"  {number}/{options.participants}: {code} {state or 'never started'} "
            f"(session {bot.session_id})")  # fmt: skip
    return summary
