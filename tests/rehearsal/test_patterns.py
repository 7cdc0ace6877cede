"""Answer patterns: seeded, on the scale, reverse-keyed items from their other end, and the
built-in effect pointing the way it says."""

from __future__ import annotations

import random
from statistics import mean
from typing import Any

import pytest

from chameleons.rehearsal.patterns import PATTERNS, Pattern, Persona

SCALE: dict[str, Any] = {
    "id": "credibility",
    "points": 7,
    "items": [
        {"id": "reliable", "type": "differential"},
        {"id": "informed", "type": "differential"},
        {"id": "comment", "type": "text"},
    ],
}


def _persona(pattern: str | Pattern, seed: int) -> Persona:
    chosen = PATTERNS[pattern] if isinstance(pattern, str) else pattern
    return Persona.draw(chosen, random.Random(seed))


def _scored(persona: Persona, condition: str, reverse: bool = False) -> float:
    answers = persona.answers(SCALE, condition, lambda _q, item: reverse and item == "reliable")
    reliable = 8 - answers["reliable"] if reverse else answers["reliable"]
    return float(mean([reliable, answers["informed"]]))


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_the_same_seed_gives_the_same_participant(pattern: str) -> None:
    def run(seed: int) -> list[Any]:
        persona = _persona(pattern, seed)
        items = ["a", "b", "c", "d", "e"]
        return [
            persona.answers(SCALE, "copy"),
            persona.rank(items, {item: n for n, item in enumerate(items, 1)}),
            [persona.accepts("still") for _ in range(10)],
            persona.answers(SCALE, None),
        ]

    assert run(5) == run(5)
    assert run(5) != run(6)


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_answers_stay_on_the_scale_and_text_is_text(pattern: str) -> None:
    for seed in range(50):
        answers = _persona(pattern, seed).answers(SCALE, "natural")
        assert 1 <= answers["reliable"] <= 7
        assert 1 <= answers["informed"] <= 7
        assert isinstance(answers["comment"], str)
        assert answers["comment"]


def test_a_reverse_keyed_item_is_answered_from_its_other_end() -> None:
    exact = Pattern("exact", "no item noise", noise=0.0)
    plain = _persona(exact, 3).answers(SCALE, "copy")
    reversed_ = _persona(exact, 3).answers(SCALE, "copy", lambda _q, item: item == "reliable")
    assert reversed_["reliable"] == 8 - plain["reliable"]
    assert reversed_["informed"] == plain["informed"]


def test_rankings_are_permutations_near_the_expert_order() -> None:
    items = [f"item{n}" for n in range(1, 11)]
    expert = {item: n for n, item in enumerate(items, 1)}
    rankings = [_persona("neutral", seed).rank(list(reversed(items)), expert) for seed in range(40)]
    assert all(sorted(r) == sorted(items) for r in rankings)
    assert mean(r.index("item1") for r in rankings) < mean(r.index("item10") for r in rankings)
    shuffled = [_persona("random", seed).rank(items, expert) for seed in range(40)]
    assert len({tuple(r) for r in shuffled}) > 30


def test_the_effect_pattern_favours_the_copying_robot_and_neutral_does_not() -> None:
    people = range(200)
    effect = [_persona("effect", seed) for seed in people]
    copy = mean(_scored(p, "copy", reverse=True) for p in effect)
    still = mean(_scored(p, "still", reverse=True) for p in effect)
    assert copy - still > 1.0
    rate = {c: mean(p.accepts(c) for p in effect for _ in range(10)) for c in ("copy", "still")}
    assert rate["copy"] > 0.8
    assert rate["still"] < 0.4
    neutral = [_persona("neutral", seed) for seed in people]
    gap = mean(_scored(p, "copy") for p in neutral) - mean(_scored(p, "still") for p in neutral)
    assert abs(gap) < 0.3
