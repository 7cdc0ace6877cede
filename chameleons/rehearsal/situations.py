"""Dropouts and deviations on demand: ``chameleons rehearse --drop-out RATE --deviate RATE``.

So a PI sees how the dashboard, the export and the analysis handle the situations every
real study has, before the first real participant. Each session independently (seeded, on
a random stream of its own, so the answers stay those of the same seed without them):

- with probability ``drop_out`` it is a dropout: registered and never started, or ended
  early during interaction *p* (after the ranking and one decided suggestion, so that
  interaction is partial) with a reason the console offers;
- with probability ``deviate`` one interaction (2 or later, among those that run) is
  switched to the condition an earlier interaction already ran, confirmed as a deviation
  as a wizard does on the console after the server's refusal.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from chameleons.backend.sessions.bot import WizardBot

END_REASONS = ("participant_withdrew", "technical_failure", "time")


@dataclass(frozen=True)
class Situation:
    """``stop_at``: None runs to the end, 0 never starts, *p* ends during interaction *p*;
    ``deviate_at``: the interaction that reruns an earlier one's condition."""

    stop_at: int | None = None
    reason: str = ""
    deviate_at: int | None = None
    repeat_from: int = 1

    def describe(self, code: str, repeated: str | None = None) -> list[str]:
        said = []
        if self.stop_at == 0:
            said.append(f"{code} registered but never started")
        elif self.stop_at is not None:
            why = self.reason.replace("_", " ")
            said.append(f"{code} ended early during interaction {self.stop_at} ({why})")
        if self.deviate_at is not None and repeated is not None:
            said.append(f"{code} interaction {self.deviate_at} ran {repeated} again (deviation)")
        return said


NONE = Situation()


def situations_rng(seed: int) -> random.Random:
    return random.Random(f"rehearsal situations {seed}")


def draw(rng: random.Random, drop_out: float, deviate: float, interactions: int) -> Situation:
    """One session's situation. Always the same draws, whatever the rates, so raising one
    rate does not reshuffle the other's sessions."""
    drops, stop, reason = (
        rng.random() < drop_out,
        rng.randint(0, interactions),
        rng.choice(END_REASONS),
    )
    deviates, where, source = rng.random() < deviate, rng.random(), rng.random()
    stop_at = stop if drops else None
    last = stop_at if stop_at is not None else interactions
    deviate_at = 2 + int(where * (last - 1)) if deviates and last >= 2 else None
    repeat_from = 1 + int(source * (deviate_at - 1)) if deviate_at else 1
    return Situation(stop_at, reason if drops else "", deviate_at, repeat_from)


def repeat_earlier_condition(bot: WizardBot, situation: Situation) -> str:
    """Switch interaction ``deviate_at`` to the condition interaction ``repeat_from`` ran;
    the server refuses (409) until the switch is confirmed as a deviation, as on the
    console, so it is sent confirmed."""
    assert situation.deviate_at is not None
    earlier = str(bot.interaction(situation.repeat_from)["condition"])
    bot.switch_condition(earlier, situation.deviate_at, confirm_deviation=True)
    return earlier
