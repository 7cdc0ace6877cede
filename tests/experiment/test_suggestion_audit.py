"""The suggestion rules' measured consequences (docs/science.md quotes the full run)."""

from __future__ import annotations

from chameleons.experiment.suggestion_audit import audit, random_share_by_acceptance
from chameleons.experiment.suggestions import RULES


def test_only_the_default_rule_never_falls_back_while_an_item_not_declined_is_misplaced():
    expert_place = audit("expert_place", 3000)
    best_move = audit("best_move", 3000)
    up_only = audit("up_only", 3000)
    assert expert_place.fallback_while_misplaced == 0
    assert best_move.fallback_while_misplaced > 0.1  # about 24 % in the docs' run
    assert up_only.fallback_while_misplaced > 0.5
    # The price of the paper's fallback condition: a few optimal suggestions cannot lower the
    # error (the declined items block it); the other rules never propose such a move.
    assert 0 < expert_place.optimal_no_gain < 0.06
    assert best_move.optimal_no_gain == up_only.optimal_no_gain == 0
    # Moves down: best_move takes the best move either way; expert_place only when a move
    # down is the one that lowers the error or the only one left; up_only never.
    assert up_only.optimal_down == 0 < expert_place.optimal_down < best_move.optimal_down
    assert expert_place.random_share < best_move.random_share < up_only.random_share


def test_the_audit_is_reproducible() -> None:
    assert audit("expert_place", 500, seed=3) == audit("expert_place", 500, seed=3)
    assert audit("expert_place", 500, seed=3) != audit("expert_place", 500, seed=4)


def test_the_random_share_depends_on_acceptance_under_every_rule() -> None:
    """The kind is a mediator: under expert_place and best_move accepting more reaches the
    expert order sooner and then the robot falls back to random suggestions; under up_only
    declining more blocks the moves up and the robot falls back sooner."""
    shares = {r: random_share_by_acceptance(r, (0.2, 0.8), interactions=2000) for r in RULES}
    assert shares["expert_place"][0.8] > shares["expert_place"][0.2] + 0.03
    assert shares["best_move"][0.8] > shares["best_move"][0.2] + 0.03
    assert shares["up_only"][0.8] < shares["up_only"][0.2] - 0.1
