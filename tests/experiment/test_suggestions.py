"""The suggestion policy's promises, checked by property-based tests and worked examples."""

from __future__ import annotations

import random
from itertools import permutations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from chameleons.experiment.suggestions import (
    Suggestion,
    apply_suggestion,
    error_score,
    next_suggestion,
)


@st.composite
def situations(draw: st.DrawFn) -> tuple[list[str], list[str], set[str], int]:
    """A ranking, its expert order, the items declined so far, and an rng seed."""
    size = draw(st.integers(min_value=2, max_value=7))
    items = [f"item_{i}" for i in range(size)]
    ranking = draw(st.permutations(items))
    expert = draw(st.permutations(items))
    declined = draw(st.sets(st.sampled_from(items)))
    return list(ranking), list(expert), declined, draw(st.integers(0, 2**32))


def improving_moves(ranking: list[str], expert: list[str], declined: set[str]) -> list[str]:
    """Brute force: items not declined that some move up to at most their expert position
    would bring closer to the expert order."""
    now = error_score(ranking, expert)
    found = []
    for from_rank, item in enumerate(ranking, start=1):
        goal = expert.index(item) + 1
        for to_rank in range(goal, from_rank):
            moved = ranking[: from_rank - 1] + ranking[from_rank:]
            moved.insert(to_rank - 1, item)
            if item not in declined and error_score(moved, expert) < now:
                found.append(item)
    return found


@given(situations())
def test_every_suggestion_moves_an_item_up_and_applies_to_a_permutation(situation) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed))
    assert 1 <= suggestion.to_rank < suggestion.from_rank <= len(ranking)
    assert ranking[suggestion.from_rank - 1] == suggestion.item
    after = apply_suggestion(ranking, suggestion)
    assert sorted(after) == sorted(ranking)
    assert after[suggestion.to_rank - 1] == suggestion.item


@given(situations())
def test_optimal_suggestions_reduce_the_error(situation) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed))
    if suggestion.kind == "optimal":
        assert error_score(apply_suggestion(ranking, suggestion), expert) < error_score(
            ranking, expert
        )
        assert suggestion.item not in declined


@given(situations())
def test_random_only_when_no_item_that_was_not_declined_can_be_improved(situation) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed))
    assert (suggestion.kind == "random") == (not improving_moves(ranking, expert, declined))


@given(situations())
def test_declined_items_are_not_proposed_while_another_choice_exists(situation) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed))
    other_choice = any(item not in declined for item in ranking[1:])
    if other_choice:
        assert suggestion.item not in declined


@given(situations())
def test_without_declines_the_most_important_misplaced_item_goes_to_its_place(situation):
    ranking, expert, _, seed = situation
    suggestion = next_suggestion(ranking, expert, set(), random.Random(seed))
    below = [item for item in expert if ranking.index(item) > expert.index(item)]
    if below:
        assert suggestion == Suggestion(
            below[0], ranking.index(below[0]) + 1, expert.index(below[0]) + 1, "optimal"
        )
    else:
        assert ranking == expert
        assert suggestion.kind == "random"


@given(situations())
def test_the_policy_is_a_pure_function_of_its_inputs_and_seed(situation) -> None:
    ranking, expert, declined, seed = situation
    first = next_suggestion(ranking, expert, declined, random.Random(seed))
    assert next_suggestion(ranking, expert, declined, random.Random(seed)) == first


def test_worked_example_with_a_declined_item() -> None:
    expert = ["a", "b", "c"]
    # a is declined; moving b up to rank 2 or 1 leaves the error at 4: no optimal move.
    suggestion = next_suggestion(["c", "a", "b"], expert, {"a"}, random.Random(1))
    assert suggestion.kind == "random"
    assert suggestion.item in {"b"}  # the only non-declined item below rank 1
    assert next_suggestion(["c", "a", "b"], expert, set(), random.Random(1)) == Suggestion(
        "a", 2, 1, "optimal"
    )


def test_every_random_move_is_reachable() -> None:
    seen = {
        (s.item, s.to_rank)
        for seed in range(300)
        for s in [next_suggestion(["a", "b", "c"], ["a", "b", "c"], set(), random.Random(seed))]
    }
    assert seen == {("b", 1), ("c", 1), ("c", 2)}


def test_error_score_full_partial_and_maximum() -> None:
    assert error_score(["a", "b", "c"], ["a", "b", "c"]) == 0
    assert error_score(["c", "a", "b"], {"a": 3, "b": 4, "c": 5}) == 4
    # Partial: only the order among the ranked items counts.
    assert error_score(["c", "a"], ["a", "b", "c"]) == 2
    assert error_score([], ["a"]) == 0
    fifteen = [f"i{n}" for n in range(15)]
    assert error_score(list(reversed(fifteen)), fifteen) == 112
    assert max(error_score(list(p), "abcde") for p in permutations("abcde")) == 12


def test_bad_inputs_are_refused() -> None:
    rng = random.Random(0)
    with pytest.raises(ValueError, match="same items"):
        next_suggestion(["a", "b"], ["a", "c"], set(), rng)
    with pytest.raises(ValueError, match="declined items"):
        next_suggestion(["a", "b"], ["a", "b"], {"z"}, rng)
    with pytest.raises(ValueError, match="at least two"):
        next_suggestion(["a"], ["a"], set(), rng)
    with pytest.raises(ValueError, match="twice"):
        error_score(["a", "a"], ["a"])
    with pytest.raises(ValueError, match="without an expert rank"):
        error_score(["x"], ["a"])
    with pytest.raises(ValueError, match="not at rank"):
        apply_suggestion(["a", "b"], Suggestion("a", 2, 1, "optimal"))
