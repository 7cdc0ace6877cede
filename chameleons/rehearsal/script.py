"""One rehearsed session: a scripted wizard at the console and a scripted participant on the
phone, through the same HTTP and WebSocket interfaces the pages use.

Built on the session flow's bots (:mod:`chameleons.backend.sessions.bot`): the wizard adds
what the console does besides the flow (set the robot up when an interaction starts, play
prompts), the participant adds the phone page's socket and a persona's answers.
"""

from __future__ import annotations

import random
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from chameleons.backend.sessions.answers import FINAL_POSITION
from chameleons.backend.sessions.bot import ApiError, ParticipantBot, StaffApi, WizardBot
from chameleons.rehearsal.patterns import Keying, Persona, not_keyed
from chameleons.rehearsal.situations import NONE as NO_SITUATION
from chameleons.rehearsal.situations import Situation, repeat_earlier_condition
from chameleons.rehearsal.sockets import PhoneSocket

Json = dict[str, Any]
SCRIPTS = ("full", "brief", "silent")  # how many prompts the wizard plays


@dataclass
class Tally:
    """What the rehearsal did, summed over its sessions."""

    sessions: int = 0
    prompts_played: int = 0
    prompts_not_sent: int = 0
    robot_applied: int = 0
    robot_not_applied: int = 0
    phone_updates: int = 0
    unstarted: int = 0  # --drop-out: registered, never started
    ended_early: int = 0  # --drop-out: ended during an interaction
    deviations: int = 0  # --deviate: an earlier condition run again, confirmed
    accepted: dict[str, list[int]] = field(default_factory=dict)  # condition -> per interaction
    problems: list[str] = field(default_factory=list)

    def note(self, problem: str) -> None:
        if problem not in self.problems:
            self.problems.append(problem)


@dataclass
class ConsoleWizard:
    """The wizard console: the session flow's buttons plus the prompt buttons and the robot."""

    bot: WizardBot
    script: str
    tally: Tally
    rng: random.Random
    hold: float = 0.0  # seconds the discussion lasts at least: recordings long enough to measure
    _buttons: dict[int, dict[str, list[Json]]] = field(default_factory=dict)

    @property
    def staff(self) -> StaffApi:
        return self.bot.staff

    @property
    def console(self) -> str:
        return f"/api/wizard/sessions/{self.bot.session_id}"

    def buttons(self, position: int) -> dict[str, list[Json]]:
        """The interaction's prompt buttons by section (empty without a prompt catalogue)."""
        if position not in self._buttons:
            try:
                answer = self.staff.get(f"{self.console}/prompts?position={position}")
                sections = {s["id"]: list(s["buttons"]) for s in answer["sections"]}
            except ApiError as error:
                self.tally.note(f"no prompt buttons: {error.detail}")
                sections = {}
            self._buttons[position] = sections
        return self._buttons[position]

    def play(self, group: str | None) -> None:
        if group is None or self.script == "silent":
            return
        result = self.staff.post(f"{self.console}/prompts/play", {"group": group})
        if result.get("sent"):
            self.tally.prompts_played += 1
        else:
            self.tally.prompts_not_sent += 1
            self.tally.note(f"a prompt was not sent: {result.get('detail')}")

    def count_robot_set_ups(self) -> None:
        """How the server set the robot up for this session's interactions. The server's
        booth flow does it as each interaction starts (the console no longer repeats it,
        and neither does this script: the timeline logged every set-up twice)."""
        path = f"/api/sessions/{self.bot.session_id}/events?limit=5000"
        for event in self.staff.get(path):
            if event["kind"] == "robot.applied":
                self.tally.robot_applied += 1
            elif event["kind"] == "robot.not_applied":
                self.tally.robot_not_applied += 1
                result = event["payload"]
                failed = [r for r in (result.get("behaviour"), result.get("face_result")) if r]
                details = "; ".join(str(r.get("detail")) for r in failed if not r.get("sent"))
                self.tally.note(f"robot not set to {result.get('condition')}: {details}")

    def stage(self, position: int, stage: str) -> str | None:
        """The first script button of ``stage`` (intro, scenario, rank_instruction...)."""
        return next(self._groups(position, "script", stage=stage), None)

    def _groups(self, position: int, section: str, **match: Any) -> Iterator[str]:
        for button in self.buttons(position).get(section, []):
            if all(button.get(key) == value for key, value in match.items()):
                yield str(button["group"])

    def discuss(self, position: int) -> None:
        """Introduce the robot and the scenario, then talk the items through."""
        self.play(self.stage(position, "intro"))
        self.play(self.stage(position, "scenario"))
        descriptions = list(self._groups(position, "items", stage="item_description"))
        questions = list(self._groups(position, "items", stage="item_question"))
        if self.script == "brief":
            descriptions, questions = descriptions[:1], []
        self.play(next(self._groups(position, "script", group="first_item"), None))
        for number, description in enumerate(descriptions):
            if number:
                self.play(next(self._groups(position, "script", group="next_item"), None))
            self.play(description)
            if number < len(questions):
                self.play(questions[number])
                self.play(self._reply(position))

    def _reply(self, position: int) -> str | None:
        replies = list(self._groups(position, "replies", stage="acknowledgement"))
        return self.rng.choice(replies) if replies else None

    def suggest(self, position: int) -> None:
        """Phrase the pending suggestion with the console's best matching prompt."""
        if self.script == "silent":
            return
        prompts = self.staff.get(f"{self.console}/console")["suggestion_prompts"]
        self.play(prompts[0] if prompts else None)

    def acknowledge(self, position: int) -> None:
        if self.script == "full":
            self.play(self._reply(position))


@dataclass
class PhoneParticipant:
    """The participant's phone: the page's socket for what to do, its API to do it."""

    bot: ParticipantBot
    socket: PhoneSocket
    persona: Persona
    keying: Keying = not_keyed

    def rank(self, position: int, expert_rank: dict[str, int]) -> None:
        state = self.socket.wait_for(
            lambda s: s["view"] == "ranking" and s.get("position") == position,
            f"the ranking of interaction {position}",
        )
        items = [str(item["id"]) for item in state["items"]]
        self.bot.submit_ranking(position, self.persona.rank(items, expert_rank))

    def answer(self, position: int, behaviour: str | None) -> int:
        """Answer every questionnaire page of ``position``; returns the number of pages."""
        state = self.socket.wait_for(
            lambda s: s["view"] == "questionnaire" and s["position"] == position,
            "the final questionnaire" if position == FINAL_POSITION
            else f"the questionnaire of interaction {position}",
        )  # fmt: skip
        pages = 0
        while state["view"] == "questionnaire" and state["position"] == position:
            questionnaire = state["questionnaire"]
            answers = self.persona.answers(questionnaire, behaviour, self.keying)
            receipt = self.bot.submit_questionnaire(position, questionnaire["id"], answers)
            pages += 1
            state = receipt["state"]
        return pages


def run_interaction(
    wizard: ConsoleWizard, participant: PhoneParticipant, position: int, tally: Tally
) -> None:
    bot = wizard.bot
    bot.advance(position, "discussion")
    started = time.monotonic()
    wizard.discuss(position)
    # --hold: the discussion goes on like a person's (the face is recorded meanwhile), so
    # the interaction's recordings are long enough for its synchrony to be measured.
    time.sleep(max(0.0, wizard.hold - (time.monotonic() - started)))
    bot.advance(position, "ranking")
    wizard.play(wizard.stage(position, "rank_instruction"))
    interaction = bot.interaction(position)
    expert = {str(item["id"]): int(item["expert_rank"]) for item in interaction["items"]}
    participant.rank(position, expert)
    bot.advance(position, "negotiation")
    condition = str(bot.interaction(position)["condition"])
    behaviour = behaviour_of(bot.snapshot, condition)
    decisions = _negotiate(wizard, participant, position, behaviour)
    tally.accepted.setdefault(condition, []).append(sum(decisions))
    bot.advance(position, "questionnaire")
    wizard.play(wizard.stage(position, "closing"))
    participant.answer(position, behaviour)


def behaviour_of(snapshot: Json, condition: str) -> str:
    """The behaviour a condition runs (a pattern's effect is the behaviour's, so "copy 1 s"
    and "copy 4 s" both get the copying robot's effect)."""
    details = snapshot.get("condition_details") or []
    return next((str(c["behaviour"]) for c in details if c["id"] == condition), condition)


def _negotiate(
    wizard: ConsoleWizard, participant: PhoneParticipant, position: int, behaviour: str
) -> list[bool]:
    """Each suggestion: the robot phrases it, the participant answers, the wizard records."""
    decisions: list[bool] = []
    while True:
        pending = [s for s in wizard.bot.interaction(position)["suggestions"]
                   if s["accepted"] is None]  # fmt: skip
        if not pending:
            return decisions
        wizard.suggest(position)
        accepted = participant.persona.accepts(behaviour)
        wizard.bot.decide(position, pending[0]["index"], accepted)
        wizard.acknowledge(position)
        decisions.append(accepted)


def end_during(
    wizard: ConsoleWizard, participant: PhoneParticipant, position: int, reason: str
) -> None:
    """Interaction ``position`` up to one decided suggestion, then the session ends early
    (that interaction is partial, later ones never run)."""
    bot = wizard.bot
    bot.advance(position, "discussion")
    bot.advance(position, "ranking")
    interaction = bot.interaction(position)
    expert = {str(item["id"]): int(item["expert_rank"]) for item in interaction["items"]}
    participant.rank(position, expert)
    bot.advance(position, "negotiation")
    behaviour = behaviour_of(bot.snapshot, str(bot.interaction(position)["condition"]))
    pending = [s for s in bot.interaction(position)["suggestions"] if s["accepted"] is None]
    if pending:
        bot.decide(position, pending[0]["index"], participant.persona.accepts(behaviour))
    bot.end(reason, "rehearsal (--drop-out)")


def run_session(
    wizard: ConsoleWizard,
    participant: PhoneParticipant,
    tally: Tally,
    situation: Situation = NO_SITUATION,
) -> Json:
    """Drive a created, not yet started session to its end (or to the dropout or deviation
    ``situation`` asks for); returns the final snapshot."""
    bot = wizard.bot
    if situation.stop_at == 0:
        tally.unstarted += 1
        return bot.refresh()
    bot.start()
    for position in range(1, bot.snapshot["interaction_count"] + 1):
        if position == situation.deviate_at:
            repeat_earlier_condition(bot, situation)
            tally.deviations += 1
        if position == situation.stop_at:
            end_during(wizard, participant, position, situation.reason)
            tally.ended_early += 1
            wizard.count_robot_set_ups()
            return bot.refresh()
        run_interaction(wizard, participant, position, tally)
    participant.answer(FINAL_POSITION, None)
    wizard.count_robot_set_ups()
    snapshot = bot.refresh()
    if snapshot["state"] != "complete":
        raise ApiError(0, f"the session ended in state {snapshot['state']!r}")
    tally.sessions += 1
    tally.phone_updates += participant.socket.updates
    return snapshot
