"""The suggestion policy's promises, checked by property-based tests and worked examples."""

from __future__ import annotations

import random
from collections import Counter
from itertools import permutations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import chisquare

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


def moved(ranking: list[str], item: str, to_rank: int) -> list[str]:
    """Written out here rather than taken from the policy: the item moves, the rest keep
    their order."""
    rest = [other for other in ranking if other != item]
    rest.insert(to_rank - 1, item)
    return rest


def all_moves(ranking: list[str]) -> list[tuple[str, int, int]]:
    return [
        (item, ranking.index(item) + 1, to_rank)
        for item in ranking
        for to_rank in range(1, len(ranking) + 1)
        if to_rank != ranking.index(item) + 1
    ]


def best_error(ranking: list[str], expert: list[str], declined: set[str]) -> int | None:
    """Brute force: the lowest error any move of an item not declined reaches, up or down."""
    errors = [
        error_score(moved(ranking, item, to), expert)
        for item, _, to in all_moves(ranking)
        if item not in declined
    ]
    return min(errors, default=None)


def improving_moves_up(ranking: list[str], expert: list[str], declined: set[str]) -> list[str]:
    """Brute force for up_only: items not declined that some move up to at most their
    expert position would bring closer to the expert order."""
    now = error_score(ranking, expert)
    return [
        item
        for item, from_rank, to in all_moves(ranking)
        if item not in declined
        and expert.index(item) + 1 <= to < from_rank
        and error_score(moved(ranking, item, to), expert) < now
    ]


RULES = st.sampled_from(["expert_place", "best_move", "up_only"])


@given(situations(), RULES)
def test_every_suggestion_is_a_real_move_that_applies_to_a_permutation(situation, rule) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), rule)
    assert 1 <= suggestion.to_rank <= len(ranking)
    assert suggestion.to_rank != suggestion.from_rank
    assert ranking[suggestion.from_rank - 1] == suggestion.item
    after = apply_suggestion(ranking, suggestion)
    assert after == moved(ranking, suggestion.item, suggestion.to_rank)
    if rule == "up_only" or suggestion.kind == "random":
        assert suggestion.direction == "up"


@given(situations(), RULES)
def test_optimal_never_worsens_the_error_and_never_moves_a_declined_item(situation, rule):
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), rule)
    if suggestion.kind == "optimal":
        after = error_score(apply_suggestion(ranking, suggestion), expert)
        now = error_score(ranking, expert)
        # best_move and up_only only propose a move that lowers the error; expert_place
        # lowers it whenever any move of an item not declined can (and never raises it).
        lowest = best_error(ranking, expert, declined)
        if rule != "expert_place" or (lowest is not None and lowest < now):
            assert after < now
        assert after <= now
        assert suggestion.item not in declined


@given(situations())
def test_best_move_takes_the_move_that_most_reduces_the_error_in_either_direction(situation):
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), "best_move")
    best = best_error(ranking, expert, declined)
    if suggestion.kind == "optimal":
        assert error_score(apply_suggestion(ranking, suggestion), expert) == best


@given(situations())
def test_best_move_falls_back_only_when_no_move_improves_the_ranking(situation) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), "best_move")
    best = best_error(ranking, expert, declined)
    improvable = best is not None and best < error_score(ranking, expert)
    assert (suggestion.kind == "random") == (not improvable)


@given(situations())
def test_up_only_falls_back_only_when_no_move_up_improves_the_ranking(situation) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), "up_only")
    assert (suggestion.kind == "random") == (not improving_moves_up(ranking, expert, declined))


@given(situations(), RULES)
def test_declined_items_are_not_proposed_while_another_choice_exists(situation, rule) -> None:
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), rule)
    other_choice = any(item not in declined for item in ranking[1:])
    if other_choice:
        assert suggestion.item not in declined


@given(situations())
def test_up_only_without_declines_moves_the_most_important_misplaced_item_to_its_place(
    situation,
) -> None:
    ranking, expert, _, seed = situation
    suggestion = next_suggestion(ranking, expert, set(), random.Random(seed), "up_only")
    below = [item for item in expert if ranking.index(item) > expert.index(item)]
    if below:
        assert suggestion == Suggestion(
            below[0], ranking.index(below[0]) + 1, expert.index(below[0]) + 1, "optimal"
        )
    else:
        assert ranking == expert
        assert suggestion.kind == "random"


@given(situations(), RULES)
def test_the_policy_is_a_pure_function_of_its_inputs_and_seed(situation, rule) -> None:
    ranking, expert, declined, seed = situation
    first = next_suggestion(ranking, expert, declined, random.Random(seed), rule)
    assert next_suggestion(ranking, expert, declined, random.Random(seed), rule) == first


def test_best_move_proposes_a_move_down_when_that_helps_most() -> None:
    # b sits first but belongs third; moving it down to 3 puts everything in order (error
    # 4 -> 0), which no move up achieves (moving a or c up leaves the error at 2 or 4).
    expert = ["a", "c", "b"]
    suggestion = next_suggestion(["b", "a", "c"], expert, set(), random.Random(1), "best_move")
    assert suggestion == Suggestion("b", 1, 3, "optimal")
    assert suggestion.direction == "down"
    # up_only finds the best it can going up: a to rank 1 (error 4 -> 2).
    up = next_suggestion(["b", "a", "c"], expert, set(), random.Random(1), "up_only")
    assert up == Suggestion("a", 2, 1, "optimal")


def test_worked_example_with_a_declined_item() -> None:
    expert = ["a", "b", "c"]
    # a is declined; under up_only moving b up leaves the error at 4: no optimal move up.
    suggestion = next_suggestion(["c", "a", "b"], expert, {"a"}, random.Random(1), "up_only")
    assert suggestion.kind == "random"
    assert suggestion.item == "b"  # the only non-declined item that can move up
    # best_move can still improve it: c (not declined) down to rank 3 gives error 2.
    best = next_suggestion(["c", "a", "b"], expert, {"a"}, random.Random(1), "best_move")
    assert best == Suggestion("c", 1, 3, "optimal")
    assert next_suggestion(["c", "a", "b"], expert, set(), random.Random(1), "up_only") == (
        Suggestion("a", 2, 1, "optimal")
    )


FALLBACK_CASES = [
    (["a", "b", "c", "d"], set()),  # in expert order: every move up is allowed
    (["a", "b", "c", "d"], {"d"}),  # a declined item is avoided while others can move
    (["a", "b", "c", "d"], {"b", "c", "d"}),  # only declined items can move: all of them
]


@pytest.mark.parametrize(("ranking", "declined"), FALLBACK_CASES)
@pytest.mark.parametrize("rule", ["best_move", "up_only"])
def test_the_random_fallback_is_uniform_over_the_allowed_moves(ranking, declined, rule) -> None:
    """Every allowed move up (counted here, independently of the policy) is drawn equally
    often: a chi-squared goodness-of-fit test over 12 000 seeded draws."""
    expert = ["a", "b", "c", "d"]
    movable = [m for m in all_moves(ranking) if m[2] < m[1]]
    allowed = [m for m in movable if m[0] not in declined] or movable
    draws = 12_000
    counts: Counter[tuple[str, int, int]] = Counter()
    for seed in range(draws):
        s = next_suggestion(ranking, expert, declined, random.Random(seed), rule)
        assert s.kind == "random"
        counts[(s.item, s.from_rank, s.to_rank)] += 1
    assert set(counts) == set(allowed)
    observed = [counts[m] for m in allowed]
    assert chisquare(observed).pvalue > 0.001, observed


def out_of_place(ranking: list[str], expert: list[str], declined: set[str]) -> list[str]:
    """Written out here: the items not declined that are not where the expert order has them
    (the paper's fallback is for when this is empty)."""
    return [item for item in ranking if item not in declined
            and ranking.index(item) != expert.index(item)]  # fmt: skip


@given(situations())
def test_the_default_rule_falls_back_exactly_when_the_paper_says(situation) -> None:
    """The paper: random "if the order already was at its optimal configuration or only
    objects that the participant has declined are in an suboptimal position"."""
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed))
    assert (suggestion.kind == "random") == (not out_of_place(ranking, expert, declined))


def test_best_move_falls_back_while_an_item_not_declined_is_out_of_place() -> None:
    """Why best_move is not the paper's sentence: ranking (b c a) of expert order (a b c)
    with a and c declined leaves b out of place and not declined, yet no move of b lowers
    the error (4), so best_move goes random; expert_place moves b to its place (rank 2; the
    error stays 4, the declined items block every gain)."""
    expert, ranking, declined = ["a", "b", "c"], ["b", "c", "a"], {"a", "c"}
    assert error_score(ranking, expert) == 4
    assert best_error(ranking, expert, declined) == 4
    assert next_suggestion(ranking, expert, declined, random.Random(0), "best_move").kind == (
        "random"
    )
    assert next_suggestion(ranking, expert, declined, random.Random(0)) == Suggestion(
        "b", 1, 2, "optimal"
    )


@given(situations())
def test_expert_place_moves_a_misplaced_item_to_its_place_preferring_gain_then_up(situation):
    """Brute force over the candidates, independently of the policy: the chosen move puts
    its item at its expert place; it lowers the error whenever any candidate does; among
    the candidates that lower it, a move up is taken when there is one, and of those the
    most important item."""
    ranking, expert, declined, seed = situation
    suggestion = next_suggestion(ranking, expert, declined, random.Random(seed), "expert_place")
    candidates = out_of_place(ranking, expert, declined)
    if not candidates:
        return
    now = error_score(ranking, expert)

    def lowers(item: str) -> bool:
        return error_score(moved(ranking, item, expert.index(item) + 1), expert) < now

    def goes_up(item: str) -> bool:
        return bool(expert.index(item) < ranking.index(item))

    pool = [i for i in candidates if lowers(i)] or candidates
    pool = [i for i in pool if goes_up(i)] or pool
    chosen = min(pool, key=expert.index)
    assert suggestion == Suggestion(
        chosen, ranking.index(chosen) + 1, expert.index(chosen) + 1, "optimal"
    )
    # Moving an item to its place never raises the error: it passes d items and loses d
    # of its own distance, and each item passed changes its distance by one.
    assert all(
        error_score(moved(ranking, i, expert.index(i) + 1), expert) <= now for i in candidates
    )


def test_expert_place_without_declines_is_up_only() -> None:
    """With nothing declined the misplaced item that most matters and sits too low moves up
    to its place, as under up_only (every permutation of five items)."""
    expert = list("abcde")
    for ranking in map(list, permutations(expert)):
        if ranking == expert:
            continue
        ours = next_suggestion(ranking, expert, set(), random.Random(0))
        assert ours == next_suggestion(ranking, expert, set(), random.Random(0), "up_only")


@pytest.mark.parametrize(("ranking", "declined"), FALLBACK_CASES)
def test_expert_place_fallback_draws_an_item_then_a_rank_above_it(ranking, declined) -> None:
    """The paper's "randomly choose an item to move to a position above its current
    position": an item uniformly (not at rank 1; items not declined preferred), then a rank
    above it uniformly. Chi-squared goodness of fit against those probabilities."""
    expert = ["a", "b", "c", "d"]
    items = [i for i in ranking[1:] if i not in declined] or ranking[1:]
    expected = {
        (item, ranking.index(item) + 1, to): 1 / len(items) / ranking.index(item)
        for item in items
        for to in range(1, ranking.index(item) + 1)
    }
    draws = 12_000
    counts: Counter[tuple[str, int, int]] = Counter()
    for seed in range(draws):
        s = next_suggestion(ranking, expert, declined, random.Random(seed))
        assert s.kind == "random"
        counts[(s.item, s.from_rank, s.to_rank)] += 1
    assert set(counts) == set(expected)
    moves = list(expected)
    result = chisquare([counts[m] for m in moves], [expected[m] * draws for m in moves])
    assert result.pvalue > 0.001, counts


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
