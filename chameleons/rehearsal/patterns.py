"""How scripted participants answer: seeded, plausible, with an optional built-in effect.

A pattern turns a participant's hidden attitude into what they do on the phone: how they
rank, whether they accept the robot's suggestions, and their questionnaire answers. The
behaviour the robot runs in the interaction's condition reaches the participant only
through the rehearsal's script (the phone never shows it); patterns with an effect use it
as the "true" effect a study would hope to find, so a PI can see the analysis pick it up.

Attitudes live on a 0..1 scale (0 the unfavourable end, 1 the favourable one) and become
scale points per questionnaire; a reverse-keyed item is answered from its other end, as a
person reading its anchors would, so the scoring turns it back.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

Json = dict[str, Any]
# (questionnaire id, item id) -> reverse-keyed?
Keying = Callable[[str, str], bool]

TEXT_ANSWERS = (
    "The robot explained the items clearly.",
    "It was interesting to discuss the task with the robot.",
    "The robot seemed to listen to me.",
    "I was not always sure why the robot wanted to move an item.",
    "The conversation felt quite natural.",
    "The robot's face was a bit distracting at times.",
)
FINAL_ANSWERS = (
    "They sounded different; one of them seemed more attentive than the others.",
    "I did not notice big differences apart from the voices.",
    "One robot moved its head more, which made it feel more alive.",
    "No further comments.",
)


def not_keyed(_questionnaire: str, _item: str) -> bool:
    return False


@dataclass(frozen=True)
class Pattern:
    """A way of answering. ``accept`` and ``shift`` are per behaviour the robot runs
    (missing: the participant's own acceptance and no shift)."""

    name: str
    description: str
    accept: Mapping[str, float] = field(default_factory=dict)
    shift: Mapping[str, float] = field(default_factory=dict)
    noise: float = 0.12  # item-to-item spread of answers (0..1 scale)
    uniform: bool = False  # answers and decisions at random, ignoring any attitude


PATTERNS: Mapping[str, Pattern] = {
    pattern.name: pattern
    for pattern in (
        Pattern(
            "neutral",
            "No effect: each participant has an attitude and an acceptance rate of their "
            "own, the same in every condition.",
        ),
        Pattern(
            "random",
            "Uniformly random answers and 50/50 decisions: noise only.",
            uniform=True,
        ),
        Pattern(
            "effect",
            "A built-in effect of mimicry: with the copying robot participants accept more "
            "suggestions (90% vs 45% natural, 30% still) and rate it higher (+0.2 of the "
            "scale; still -0.05).",
            accept={"copy": 0.9, "natural": 0.45, "still": 0.3},
            shift={"copy": 0.2, "natural": 0.0, "still": -0.05},
        ),
    )
}


@dataclass
class Persona:
    """One simulated participant: a hidden attitude and acceptance rate, and a seeded
    random source of their own (runs with the same seed answer the same)."""

    pattern: Pattern
    rng: random.Random
    attitude: float  # 0..1, how favourably they see robots
    acceptance: float  # their own probability of accepting a suggestion

    @classmethod
    def draw(cls, pattern: Pattern, rng: random.Random) -> Persona:
        attitude = min(0.85, max(0.25, rng.gauss(0.6, 0.1)))
        return cls(pattern, rng, attitude, rng.uniform(0.3, 0.7))

    def accepts(self, behaviour: str) -> bool:
        if self.pattern.uniform:
            return self.rng.random() < 0.5
        return self.rng.random() < self.pattern.accept.get(behaviour, self.acceptance)

    def rank(self, items: Sequence[str], expert_rank: Mapping[str, int]) -> list[str]:
        """Items roughly in expert order (people know some of it), shuffled otherwise."""
        if self.pattern.uniform or not all(item in expert_rank for item in items):
            ranking = list(items)
            self.rng.shuffle(ranking)
            return ranking
        return sorted(items, key=lambda item: expert_rank[item] + self.rng.gauss(0.0, 2.0))

    def answers(
        self, questionnaire: Json, behaviour: str | None, keying: Keying = not_keyed
    ) -> Json:
        """Answers to one questionnaire page as the phone shows it (``points``, items with
        ``id`` and ``type``); ``behaviour`` (the robot's) None for the final questionnaire."""
        points = int(questionnaire["points"])
        level = self.attitude + (self.pattern.shift.get(behaviour, 0.0) if behaviour else 0.0)
        answers: Json = {}
        for item in questionnaire["items"]:
            if item["type"] == "text":
                answers[item["id"]] = self.rng.choice(FINAL_ANSWERS if behaviour is None
                                                      else TEXT_ANSWERS)  # fmt: skip
                continue
            if item.get("options"):  # a choice or a robot item: one of its answers
                answers[item["id"]] = self.rng.choice(item["options"])["id"]
                continue
            value = self._point(level, points)
            reverse = keying(str(questionnaire["id"]), str(item["id"]))
            answers[item["id"]] = points + 1 - value if reverse else value
        return answers

    def _point(self, level: float, points: int) -> int:
        if self.pattern.uniform:
            return self.rng.randint(1, points)
        favourable = level + self.rng.gauss(0.0, self.pattern.noise)
        return max(1, min(points, 1 + round(favourable * (points - 1))))
